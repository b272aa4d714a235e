"""Loading a generated module is thread-safe: no caller ever sees a half-executed module."""

from __future__ import annotations

import sys
import threading
from concurrent.futures import ThreadPoolExecutor

from sim.bondgraph import codegen


def test_concurrent_first_loads_get_the_whole_module(tmp_path, monkeypatch):
    monkeypatch.setenv("HYDRODIAG_CACHE_DIR", str(tmp_path))
    # a module whose execution takes a while, so that callers overlap with it
    source = (
        "import time\n"
        f"MARK = {id(tmp_path)}\n"
        "time.sleep(0.3)\n"
        "def integrate():\n"
        "    return 42\n"
    )
    barrier = threading.Barrier(8)

    def first_call() -> int:
        barrier.wait()
        module = codegen.load_module(source)
        return int(module.integrate())

    try:
        with ThreadPoolExecutor(8) as pool:
            results = list(pool.map(lambda _: first_call(), range(8)))
        assert results == [42] * 8
    finally:
        for name in [n for n in sys.modules if n.startswith("hydrodiag_bg_")]:
            if getattr(sys.modules[name], "MARK", None) == id(tmp_path):
                del sys.modules[name]


def test_a_module_that_fails_to_execute_is_not_left_behind(tmp_path, monkeypatch):
    monkeypatch.setenv("HYDRODIAG_CACHE_DIR", str(tmp_path))
    source = f"MARK = {id(tmp_path)}\nraise RuntimeError('broken module')\n"
    for _ in range(2):  # the second call executes it again instead of returning a husk
        try:
            codegen.load_module(source)
        except RuntimeError as exc:
            assert "broken module" in str(exc)
        else:
            raise AssertionError("the broken module loaded")
    assert not any(getattr(m, "MARK", None) == id(tmp_path) for m in list(sys.modules.values()))
