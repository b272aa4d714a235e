"""YAML as the project reads it (sim.yaml_loader): JSON's numbers, no key twice, bounded
aliases."""

from __future__ import annotations

import time

import pytest
import yaml

from sim.yaml_loader import MAX_NODES, load_yaml


def _laughs(levels: int) -> str:
    """Nested aliases, each level ten of the one before ("billion laughs")."""
    lines = ["a0: &a0 [x,x,x,x,x,x,x,x,x,x]"]
    lines += [f"a{i}: &a{i} [{','.join([f'*a{i - 1}'] * 10)}]" for i in range(1, levels)]
    return "\n".join([*lines, "rig_id: 1"])


def test_aliases_that_expand_beyond_the_bound_are_refused_before_they_expand() -> None:
    """A 340-byte paste of seven levels took 9.7 s and kept 285 MB of a worker once
    expanded (a security review's pass); it is refused as composed, at once."""
    text = _laughs(7)
    assert len(text) < 400
    started = time.perf_counter()
    with pytest.raises(yaml.composer.ComposerError, match=f"more than {MAX_NODES:,} values"):
        load_yaml(text)
    assert time.perf_counter() - started < 5.0    # a bound on a runaway, not a timing claim
    assert len(load_yaml(_laughs(3))["a2"]) == 10     # 1,000 values: read as written


def test_an_anchor_shared_by_a_few_entries_stays_as_written() -> None:
    document = load_yaml("hose: &h {L: 1.0, D: 0.02}\nhose_A: *h\nhose_B: {<<: *h, L: 2.0}\n"
                         "Vp: 1.75e-5\n")
    assert document["hose_A"] == {"L": 1.0, "D": 0.02}
    assert document["hose_B"] == {"L": 2.0, "D": 0.02} and document["Vp"] == 1.75e-5


def test_a_document_nested_deeper_than_it_can_be_read_is_a_yaml_error() -> None:
    """800 nested brackets raised RecursionError: a 500 from the console (a verification
    pass)."""
    with pytest.raises(yaml.YAMLError, match="nests deeper than it can be read"):
        load_yaml("a: " + "[" * 5000 + "]" * 5000)
