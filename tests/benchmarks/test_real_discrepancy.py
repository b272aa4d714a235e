"""The discrepancy workflow on slices of measured data: V32HL56 and ZeMA (issues 8 and 12)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.real_discrepancy import RELAXATION, ZEMA_RIG, cross_settings, stored_pump
from benchmarks.real_pump_map import THETA
from diagnostics.discrepancy.steady import discover_steady
from diagnostics.pump import bench_from_frame, derived_capacity_toet
from diagnostics.pump.levels import cluster_levels
from diagnostics.pump.piston import bench_frame, read_efficiency_map
from diagnostics.real.profile import plateau_table
from diagnostics.real.zema import load_1hz, read_records
from sim.rigs import load_rig, load_rig_document
from tests.real_slices import v32hl56_slice, zema_span_slice


@pytest.fixture(scope="module")
def settings() -> list:
    data = read_efficiency_map(v32hl56_slice())
    idx, levels = cluster_levels(data.D, field="Displacement")
    return [data.subset(idx == k) for k in range(levels.size)]


def test_the_stored_pump_is_read_back_as_the_bench_characterised_it(settings: list) -> None:
    """The rig loader reads the document's Vp [m³/rev] as Toet's capacity [m³/rad] and its
    Rlp as the least-squares laminar leak: the stored pump's flow balance leaves a residual
    orthogonal to Δp (the normal equation of that fit)."""
    bench = bench_from_frame(bench_frame(settings[0], THETA))
    values = load_rig(stored_pump(bench, "slice")).values()
    assert values["pump.Vp"] == pytest.approx(derived_capacity_toet(bench).D, rel=1e-12)
    dp = bench.p_out - bench.p_in
    r = bench.omega * values["pump.Vp"] - bench.q - dp / values["pump.Rlp"]
    assert abs(np.sum(r * dp)) < 1e-9 * np.sum(np.abs(bench.q * dp))
    assert 1e10 < values["pump.Rlp"] < 1e13  # a piston pump's leak, not a unit slip


def test_the_workflow_names_a_loss_growing_with_pressure_times_speed_and_flags_its_size(
        settings: list) -> None:
    """Measured data nobody here wrote: at 23.2 and 56.9 cm³/rev the flow loss has a term
    ∝ Δp·ω that the laminar leak cannot take (held-out gap 6-7 l/min); the workflow names
    the library's entry with that signature, shrinks the held-out gap more than 5×, and
    marks its coefficient as outside the plausible range of oil compression (paper 000
    eq. 6: ≤ 2e-9 1/Pa) — it is not that effect alone (module docstring of the study)."""
    for sub in settings:
        bench = bench_from_frame(bench_frame(sub, THETA))
        d = discover_steady(stored_pump(bench, "slice"), bench, bootstrap=0)
        assert d.verdict in ("named", "partially explained"), d.message
        comp = next(n for n in d.named if n.name == "pump_compressibility_loss")
        assert comp.value > comp.plausible_range[1] and not comp.plausible
        assert comp.interval[0] > 0.0 and comp.interval[1] > comp.interval[0]
        assert d.gap_before[0].rmse > 5.0 * d.gap_after[0].rmse
        # the augmented rig carries the effect and the re-fitted pump
        pump = d.rig_document["components"]["pump"]["parameters"]
        assert "re-fitted" in pump["Rlp"]["source"]


def test_the_loss_does_not_scale_with_the_displacement(settings: list) -> None:
    """Compression of the displaced oil alone (the library's entry) would make the
    absolute Δp·ω coefficient proportional to the displacement (×2.5 from 23.2 to
    56.9 cm³/rev); measured, it grows by a third, and a fifth of it or less reaches the
    case drain (compression loses no oil to the case)."""
    data = read_efficiency_map(v32hl56_slice())
    idx, levels = cluster_levels(data.D, field="Displacement")
    a = cross_settings(data, idx, levels.size)
    lo, hi = a["a_m3_per_rad_Pa"]
    assert a["D_m3_per_rad"][1] / a["D_m3_per_rad"][0] > 2.4
    assert 1.0 < hi / lo < 1.6
    assert all(0.0 < s < 0.3 for s in a["drain_share"])


def test_the_zema_plateaus_show_a_leak_that_grows_as_the_oil_thins() -> None:
    """The span slice's healthy and most-leaking pumps (18 cycles each, 35-57 °C): the
    stored pump's constant leak misses the plateau flows by 20-40 σ at the hottest fifth;
    the workflow names a leak ∝ 1/μ — the viscous slip P/μ or, over these 140-166 bar where
    the two columns differ by ±8 %, the deforming clearance P²/μ — and the gap shrinks, also
    against the pump's own leak re-fitted alone.  (The 18-cycle slice's 6 healthy cycles span
    35-46 °C: there the effect left 12.3 σ held out against 12.9 σ for the re-fit alone,
    and is no longer named.)"""
    data, labels = load_1hz(zema_span_slice(), None,
                            sensors=("PS1", "PS2", "FS1", "EPS1", "TS1"))
    table = plateau_table(read_records(data), relaxation=RELAXATION)
    doc = load_rig_document(ZEMA_RIG)
    leak = np.asarray(labels.leakage)
    for cls in (0.0, 2.0):
        bench = table.bench(1500.0 * math.pi / 30.0, leak == cls)
        d = discover_steady(doc, bench, bootstrap=0)
        assert d.verdict == "named", d.message
        assert d.named[0].name in ("viscous_pump_slip", "pump_clearance_pressure")
        assert d.gap_before[0].rmse > 2.0 * d.gap_after[0].rmse
        assert d.gap_before[0].rmse > 10.0 * d.traces["sigma"]
        assert d.traces["gap_alone"][0].rmse > 2.0 * d.gap_after[0].rmse
