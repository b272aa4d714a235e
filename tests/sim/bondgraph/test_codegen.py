"""The generated module's source names everything its machine code depends on."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from sim.bondgraph import BondGraph, C, R, Sf, Zero, call, derive_equations
from sim.bondgraph.codegen import generate_source
from sim.bondgraph.laws import constant


def _tank(leak: Callable[..., Any]) -> BondGraph:
    """A flow source filling a capacitance that drains through the law ``leak``."""
    g = BondGraph("tank")
    for name, val in (("Q", 1e-4), ("Cap", 1e-10), ("Rl", 1e10)):
        g.parameter(name, val)
    g.add(Sf("pump", constant, "p:Q"))
    g.add(Zero("node"))
    g.add(C("cap", constant, "p:Cap", scale=1e5))
    g.add(R("leak", flow=call(leak, "e", "p:Rl")))
    g.connect("pump", "node")
    g.connect("node", "cap")
    g.connect("node", "leak")
    return g


@pytest.mark.parametrize("jit", [True, False])
def test_editing_a_law_changes_the_generated_module(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch,
                                                    jit: bool) -> None:
    """The module imports its laws by name, and numba's cache does not see a change in a
    called function: with the same source (hence the same cached module) a law edited to
    leak half as much kept its old machine code, so a rig's steady pressure stayed what the
    old law gave (a mutation review: the valve path's √ΔP made ΔP⁰ passed the rig tests
    until the cache was emptied).  An edited law must give another source."""
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    law_file = tmp_path / "hd_probe_leak_law.py"

    def write(divisor: str) -> Any:
        law_file.write_text("from sim.bondgraph.laws import law\n\n\n@law\n"
                            "def leak(e: float, R: float) -> float:\n"
                            f"    return e / ({divisor} * R)\n")
        importlib.invalidate_caches()
        if "hd_probe_leak_law" in sys.modules:
            return importlib.reload(sys.modules["hd_probe_leak_law"])
        return importlib.import_module("hd_probe_leak_law")

    try:
        laminar = generate_source(derive_equations(_tank(write("1.0").leak)), jit=jit)
        again = generate_source(derive_equations(_tank(write("1.0").leak)), jit=jit)
        halved = generate_source(derive_equations(_tank(write("2.0").leak)), jit=jit)
    finally:
        sys.modules.pop("hd_probe_leak_law", None)
    assert laminar == again  # the same law: the cached module is reused
    assert laminar != halved
