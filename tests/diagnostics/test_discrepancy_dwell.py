"""Dwell records (the stroke held at its stop, the pump flow over the relief valve) and the
relief balance that names a relief-valve override on them (issue 8, test design)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from diagnostics.discrepancy.balances import BalanceData, balance_data
from diagnostics.discrepancy.selection import select
from diagnostics.discrepancy.signals import prepare
from diagnostics.discrepancy.simulate import record_kind, simulate, simulate_record, timed_switch
from diagnostics.discrepancy.synthetic import DWELLS, NOISE, effect_peak, synthesize
from diagnostics.timeseries import SeriesRecord
from sim.cycle import run_cycle
from sim.rigs import load_rig, reference_rig, reference_rig_document
from sim.rigs.assembly import Condition, Rig

#: stated pump speed of the reference rig [rad/s]
SPEED = 1600.0 * 2.0 * math.pi / 60.0
ZERO = dict.fromkeys(NOISE, 0.0)
#: override strength of the tests [Pa·s²/m⁶]: ≈ 8 σ of pump pressure at the 16 L/min dwell
K_OV = 6e11


def _rig(k_ov: float = 0.0, overrides: dict[str, float] | None = None) -> Rig:
    doc: dict[str, Any] = reference_rig_document()
    if k_ov:
        doc["effects"] = {"relief_override": {"parameters": {"k_ov": {
            "value": k_ov, "unit": "Pa*s^2/m^6", "source": "test"}}}}
    return load_rig(doc)


def _dwells(rig: Rig, *, seed: int | None = None, overrides: dict[str, float] | None = None,
            design: tuple[tuple[float, float, float, float], ...] = DWELLS[:3]
            ) -> list[SeriesRecord]:
    rng = np.random.default_rng(0 if seed is None else seed)
    return [synthesize(rig, Condition(load=L, oil_temperature=T, pump_speed=f * SPEED), rng=rng,
                       name=f"dwell {f:.0%}", sigma=ZERO if seed is None else None, t_max=sw,
                       overrides=overrides)
            for L, T, f, sw in design]


def _relief(records: list[SeriesRecord]) -> BalanceData | None:
    rig = reference_rig()
    data = balance_data(prepare(records, rig), rig.values())
    return next((d for d in data if d.balance.name == "relief_flow"), None)


def _lstsq(d: BalanceData) -> dict[str, float]:
    cols = [*d.base.values(), *d.candidates.values()]
    X = np.column_stack(cols)
    scale = np.sqrt(np.mean(X ** 2, axis=0))
    coef, *_ = np.linalg.lstsq(X / scale, d.y, rcond=None)
    return dict(zip([*d.base, *d.candidates], coef / scale, strict=True))


def test_a_held_working_phase_dwells_at_the_stop_with_the_pump_flow_over_the_relief() -> None:
    rig = reference_rig()
    cond = Condition(load=4200.0, oil_temperature=40.0, pump_speed=SPEED)
    free = run_cycle(rig, None, cond, method="rodas4", sample_rate=2000.0)
    held = run_cycle(rig, None, cond, method="rodas4", sample_rate=2000.0, t_max=4.0, hold=True)
    assert free.working["duration"] < 3.0  # the end stop switches the free stroke
    assert held.working["duration"] == pytest.approx(4.0, abs=1e-9)
    ts = held.timeseries
    assert ts is not None
    dwell = ts[(ts["phase"] == "working") & (ts["t [s]"] > 3.2)]
    assert dwell["x [m]"].min() > 0.5 - 1e-3  # at the stop (contact compresses < 1 mm)
    # pump-outlet 0-junction at steady state (paper 002 eqs. 1-6): geometric flow = leak +
    # relief + flow to the valve, the relief on its eq.-6 line above the 70 bar setting
    v = rig.values()
    q_geo = SPEED * v["pump.Vp"]
    out = (dwell["Q_pump_leak [m^3/s]"] + dwell["Q_relief [m^3/s]"]
           + dwell["Q_meter_B [m^3/s]"]).to_numpy()
    assert np.max(np.abs(out - q_geo)) < 1e-3 * q_geo
    p = dwell["P_pump [Pa]"].to_numpy()
    q_rel = dwell["Q_relief [m^3/s]"].to_numpy()
    np.testing.assert_allclose(p - v["relief.Pset"], v["relief.Rrv"] * q_rel, rtol=1e-6)
    assert q_rel.mean() > 0.2 * q_geo  # ≈ 16 L/min of the 28 over the relief


def test_dwell_records_are_timed_and_re_simulated_with_the_same_switch() -> None:
    rig = reference_rig()
    rec = _dwells(rig, design=DWELLS[1:2])[0]
    assert record_kind(rec, rig) == "dwell"
    switch = timed_switch(rec, rig)
    assert switch == pytest.approx(DWELLS[1][3], abs=2e-3)
    table = simulate_record(rig, rec)
    work = table[table["phase"] == "working"]
    assert float(work["t [s]"].iloc[-1]) == pytest.approx(switch, abs=1e-3)
    full = synthesize(rig, Condition(load=2100.0, oil_temperature=40.0),
                      rng=np.random.default_rng(0), sigma=ZERO)
    assert record_kind(full, rig) == "full" and timed_switch(full, rig) is None


def test_a_spike_of_the_position_sensor_during_a_dwell_leaves_it_a_dwell() -> None:
    """Heavy-tailed position noise: one sample 2 mm off the stop late in the dwell made the
    dwell a full stroke (its arrival read after the spike), re-simulated as a stroke that
    switches at the stop; the stop is also found where the piston reached it."""
    import dataclasses

    from diagnostics.discrepancy.refit import residual_parts

    rig = reference_rig()
    rec = _dwells(rig, design=DWELLS[1:2])[0]
    work = np.flatnonzero(rec.phase == "working")
    x = rec.channels["x"].copy()
    x[work[-30]] -= 2e-3  # 30 ms before the switch, 1.5 s into the dwell
    spiked = dataclasses.replace(rec, channels={**rec.channels, "x": x})
    assert record_kind(spiked, rig) == "dwell"
    assert timed_switch(spiked, rig) == pytest.approx(timed_switch(rec, rig))
    channels = ["P1", "P_pump", "Q_meter_B"]
    sig = {"P1": 5e3, "P_pump": 5e3, "Q_meter_B": 8.3e-7}
    x = rec.channels["x"].copy()
    x[work[5]] = rig.base["cylinder.stroke"]  # and a spike to the stop early in the motion
    early = dataclasses.replace(rec, channels={**rec.channels, "x": x})
    clean = residual_parts(rig, [rec], channels, sig, {})
    for r in (spiked, early):  # compared where the unspiked record is, sample for sample
        parts = residual_parts(rig, [r], channels, sig, {})
        assert [c for c, _ in parts] == [c for c, _ in clean]
        for (_, a), (_, b) in zip(parts, clean, strict=True):
            np.testing.assert_allclose(a, b, atol=1e-9)


def test_the_relief_balance_is_exact_on_noise_free_dwells_with_the_override() -> None:
    d = _relief(_dwells(_rig(K_OV)))
    assert d is not None
    coef = _lstsq(d)
    assert coef["relief_override"] == pytest.approx(K_OV, rel=2e-3)
    # the relief's own setting and slope need no correction on the stated rig
    assert abs(coef["relief.Rrv"]) < 1e-3 / reference_rig().values()["relief.Rrv"]
    none = _lstsq(_relief(_dwells(_rig())) or d)
    assert abs(none["relief_override"]) < 1e-3 * K_OV


def test_without_a_dwell_there_is_no_relief_balance() -> None:
    rig = reference_rig()
    full = [synthesize(rig, Condition(load=L, oil_temperature=T), rng=np.random.default_rng(1),
                       sigma=ZERO) for L, T in ((2100.0, 40.0), (4200.0, 50.0))]
    assert _relief(full) is None


@pytest.mark.parametrize("seed", [3, 4])
def test_the_override_is_selected_on_noisy_dwells_and_nothing_without_it(seed: int) -> None:
    d = _relief(_dwells(_rig(K_OV), seed=seed))
    assert d is not None
    sel = select(d, bootstrap=5, seed=seed)
    assert sel.chosen is not None and [t.effect for t in sel.chosen.terms] == ["relief_override"]
    assert sel.chosen.terms[0].coefficient == pytest.approx(K_OV, rel=0.15)
    null = _relief(_dwells(_rig(), seed=seed))
    assert null is not None and select(null, bootstrap=5, seed=seed).chosen is None


def test_a_drifted_relief_setting_and_slope_are_not_named_as_an_override() -> None:
    # the balance re-fits the setting (a constant) and the slope (∝ Q) over three relief
    # flows: a 2 % higher setting and a 15 % steeper line leave no override
    drift = {"relief.Pset": 7.14e6, "relief.Rrv": 2.5e9 * 1.15}
    d = _relief(_dwells(_rig(), seed=5, overrides=drift))
    assert d is not None
    assert select(d, bootstrap=5, seed=5).chosen is None


def test_the_override_size_is_read_where_it_shows_the_dwell_pressure() -> None:
    L, T, f, sw = DWELLS[2]
    cond = Condition(load=L, oil_temperature=T, pump_speed=f * SPEED)
    peak, channel = effect_peak(simulate(_rig(K_OV), cond, None, sw),
                                simulate(reference_rig(), cond, None, sw))
    # k·Q² at ≈ 16 L/min: 6e11 × (2.7e-4)² ≈ 0.43 bar = 8.6 σ of the pump-pressure sensor
    assert channel in ("P_pump", "P1", "P_valve_P")
    assert 6.0 < peak < 12.0
    full = Condition(load=L, oil_temperature=T, pump_speed=f * SPEED)
    peak_full, _ = effect_peak(simulate(_rig(K_OV), full), simulate(reference_rig(), full))
    assert peak_full < 1e-3  # a stroke switched at its stop never opens the relief
