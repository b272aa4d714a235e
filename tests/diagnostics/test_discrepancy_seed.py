"""A discrepancy report says the seed its random draws took, and the same seed repeats it."""

from __future__ import annotations

import json

import numpy as np

from diagnostics.discrepancy.report import html_page
from diagnostics.discrepancy.steady import PERMUTATIONS, discover_steady
from diagnostics.discrepancy.synthetic import synthesize_bench
from sim.rigs import reference_rig, reference_rig_document


def test_a_bench_tables_report_states_its_seed_and_the_same_seed_repeats_it() -> None:
    """The steady workflow's bootstrap and permutation test draw from ``seed``: the
    report says it (JSON and page; it said nothing of it) and the same seed gives the
    same report."""
    bench = synthesize_bench(reference_rig(), rng=np.random.default_rng(1),
                             effects={"viscous_pump_slip": 1e-8})
    doc = reference_rig_document()
    first = discover_steady(doc, bench, bootstrap=10, seed=3)
    again = discover_steady(doc, bench, bootstrap=10, seed=3)
    other = discover_steady(doc, bench, bootstrap=10, seed=4)
    report = first.to_dict()
    assert report["randomness"] == {"seed": 3, "bootstrap": 10, "permutations": PERMUTATIONS}
    assert json.dumps(again.to_dict()) == json.dumps(report)
    assert other.to_dict()["randomness"]["seed"] == 4
    assert f"seed 3, 10 bootstrap replicates, {PERMUTATIONS} permutations" in html_page(first)
