"""Valve switching time and accumulator gas volume: hand calculations and real ZeMA slices."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from diagnostics.real.accumulator import (
    LoadStep,
    gas_volume,
    gas_volumes,
    step_volumes,
    upper_steps,
)
from diagnostics.real.scoring import score_classes
from diagnostics.real.switching import (
    crossing_time,
    step_time,
    switching_lags,
    switching_times,
)
from diagnostics.real.zema import ZemaCycles, load_1hz, read_fullres, read_records
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError, MeasurementError
from tests.real_slices import zema_program_slice, zema_slice

BAR = 1.0e5
LPM = 1.0 / 60000.0


def _record(t: np.ndarray, p: np.ndarray, q: np.ndarray | None = None,
            theta: float = 40.0) -> SeriesRecord:
    ch = {"p_pump": p, "oil_temperature": np.full(t.size, theta)}
    units = {"p_pump": "Pa", "oil_temperature": "degC"}
    if q is not None:
        ch["q_work"] = q
        units["q_work"] = "m^3/s"
    return SeriesRecord("synthetic", t, ch, units)


def _block_means(rec: SeriesRecord, per: int) -> SeriesRecord:
    n = len(rec) // per
    ch = {k: v[:n * per].reshape(n, per).mean(axis=1) for k, v in rec.channels.items()}
    return SeriesRecord(rec.name, np.arange(n, dtype=np.float64), ch, dict(rec.units))


@pytest.fixture(scope="module")
def program():  # type: ignore[no-untyped-def]
    data, labels = load_1hz(zema_program_slice())
    return labels, read_records(data)


# --- valve switching time -------------------------------------------------------------------

def test_step_time_of_an_ideal_step_and_a_ramp_by_hand() -> None:
    t = np.arange(3000) / 100.0
    step = np.where(t < 9.37, 190.0, 146.0) * BAR
    rec = _record(t, step)
    assert step_time(rec) == pytest.approx(9.37, abs=1e-9)
    # the 1-second block means of the same step carry the same time
    assert step_time(_block_means(rec, 100)) == pytest.approx(9.37, abs=1e-9)
    # a linear fall from 9.2 s to 9.6 s: its centre
    ramp = np.interp(t, [9.2, 9.6], [190.0, 146.0]) * BAR
    assert step_time(_record(t, ramp)) == pytest.approx(9.4, abs=0.006)


def test_step_time_refuses_a_record_without_a_step() -> None:
    t = np.arange(60, dtype=np.float64)
    with pytest.raises(MeasurementError) as err:
        step_time(_record(t, np.full(60, 150.0 * BAR)))
    assert err.value.field == "p_pump"
    assert math.isnan(switching_times([_record(t, np.full(60, 150.0 * BAR))])[0])
    with pytest.raises(InputError) as err2:
        step_time(_record(t, np.full(60, 150.0 * BAR)), during=(11.0, 9.0))
    assert err2.value.field == "during"


def test_raw_100hz_cycle_and_its_block_means_give_the_same_switching_time() -> None:
    (rec,) = read_fullres(zema_slice() / "fullres_cycle1092.csv", [1092], sensors=("PS1",),
                          duration=30.0)
    fast = step_time(rec)
    blocks = {"PS1": rec.channel("p_pump").reshape(30, 100).mean(axis=1)[None, :] / BAR}
    (slow,) = read_records(ZemaCycles(np.array([1092]), blocks, 1.0))
    assert step_time(slow) == pytest.approx(fast, abs=1e-9)
    # cycle 1092 has valve condition 80 %: it switches well after a second into the window
    assert 9.5 < fast < 10.5


def test_crossing_time_by_hand_and_on_a_raw_cycle() -> None:
    t = np.arange(3000) / 100.0
    ramp = np.interp(t, [9.2, 9.6], [0.0, 100.0]) * BAR
    rec = SeriesRecord("ramp", t, {"p_work": ramp}, {"p_work": "Pa"})
    assert crossing_time(rec, 5.0 * BAR) == pytest.approx(9.22, abs=1e-9)
    assert crossing_time(rec, 50.0 * BAR) == pytest.approx(9.4, abs=1e-9)
    with pytest.raises(MeasurementError):
        crossing_time(rec, 500.0 * BAR)
    with pytest.raises(MeasurementError):  # already above at the window's start
        crossing_time(rec, 5.0 * BAR, during=(9.5, 11.0))
    (raw,) = read_fullres(zema_slice() / "fullres_cycle1092.csv", [1092],
                          sensors=("PS1", "PS2"), duration=30.0)
    # the valve opens (PS2 rises through 5 bar) before the pump pressure has half fallen
    opening = crossing_time(raw, 5.0 * BAR)
    assert 9.0 < opening < step_time(raw) < 10.5


def test_switching_lag_orders_the_valve_classes_on_the_slice(program) -> None:  # type: ignore[no-untyped-def]
    labels, recs = program
    lag = switching_lags(switching_times(recs), quantile=0.0)
    assert np.nanmin(lag) == 0.0
    med = [float(np.median(lag[(labels.valve == v) & (labels.accumulator == 130)]))
           for v in (100, 90, 80, 73)]
    assert med[0] < med[1] < med[2] < med[3]
    sel = labels.accumulator == 130
    s = score_classes(lag[sel], labels.valve[sel], {}, decreasing=True)
    assert s.worst_auroc == 1.0 and s.fraction == pytest.approx(1.0)
    assert set(s.auroc) == {"100>90", "90>80", "80>73"}


def test_switching_lags_refuse_bad_input() -> None:
    with pytest.raises(InputError) as err:
        switching_lags([1.0, 2.0], quantile=1.0)
    assert err.value.field == "quantile"
    with pytest.raises(InputError):
        switching_lags([math.nan])


# --- accumulator gas volume -----------------------------------------------------------------

def test_polytropic_gas_volume_by_hand() -> None:
    v0, p0, n = 0.32e-3, 110.0 * BAR, 1.4

    def stored(pa: float, pb: float) -> float:  # V_gas(pa) − V_gas(pb)
        return float(v0 * (p0 / pa) ** (1 / n) - v0 * (p0 / pb) ** (1 / n))

    steps = [LoadStep(156 * BAR, 166 * BAR, stored(156 * BAR, 166 * BAR), 28.0),
             LoadStep(166 * BAR, 156 * BAR, stored(166 * BAR, 156 * BAR), 38.0)]
    assert steps[1].volume < 0 < steps[0].volume
    assert gas_volume(steps, n=n) == pytest.approx(v0 * (p0 / (150 * BAR)) ** (1 / n), rel=1e-12)
    # the pre-charge referred to 20 °C: a gas at 56.85 °C (330 K) reads larger by (T/T_ref)^(1/n)
    hot = gas_volume(steps, n=n, theta=330.0 - 273.15)
    assert hot == pytest.approx(gas_volume(steps, n=n) * (293.15 / 330.0) ** (1 / n), rel=1e-12)
    assert gas_volume(steps, n=n, theta=20.0) == pytest.approx(gas_volume(steps, n=n))
    with pytest.raises(MeasurementError):
        gas_volume([])
    with pytest.raises(InputError) as err:
        gas_volume(steps, n=0.0)
    assert err.value.field == "n"


def test_step_volume_is_the_flow_balance_of_the_transition() -> None:
    t = np.arange(40, dtype=np.float64)
    p = np.where(t < 19, 150.0, 160.0) * BAR
    p[19] = 155.0 * BAR
    q_ss = 8.0 - 0.01 * (p / BAR - 150.0)  # the pump's steady flow [l/min], linear in p
    q = q_ss.copy()
    q[19] -= 0.3  # 0.3 l/min for one second goes into the accumulator
    (st,) = step_volumes(_record(t, p, q * LPM))
    assert st.p_from == pytest.approx(150 * BAR) and st.p_to == pytest.approx(160 * BAR)
    assert st.volume == pytest.approx(0.3 * LPM * 1.0, rel=1e-9)


def test_gas_volume_orders_the_accumulator_classes_on_the_slice(program) -> None:  # type: ignore[no-untyped-def]
    labels, recs = program
    sel = labels.valve == 100
    vg = gas_volumes([r for r, s in zip(recs, sel, strict=True) if s])
    acc = labels.accumulator[sel]
    assert np.all(np.isfinite(vg))
    med = [float(np.median(vg[acc == a])) for a in (90, 100, 115, 130)]
    assert med[0] < med[1] < med[2] < med[3]
    # a few tenths of a litre of gas at 150 bar: an accumulator of the rig's size
    assert med[0] > 0.1e-3 and med[3] < 2.0e-3
    s = score_classes(vg, acc, {})
    assert s.worst_auroc == 1.0


def test_a_cycle_that_left_the_load_program_gets_no_gas_volume(program) -> None:  # type: ignore[no-untyped-def]
    _, recs = program
    r = recs[0]
    p, q = r.channel("p_pump").copy(), r.channel("q_work").copy()
    # the relief valve holds the middle of the cycle, as in cycles 344-691 of the campaign
    p[20:40], q[20:40] = 188.5 * BAR, 1.1 * LPM
    bad = SeriesRecord(r.name, r.t, dict(r.channels, p_pump=p, q_work=q), dict(r.units))
    assert len(step_volumes(bad)) < 4
    out = gas_volumes([r, bad])
    assert np.isfinite(out[0]) and math.isnan(out[1])


# --- scoring --------------------------------------------------------------------------------

def test_score_classes_by_hand() -> None:
    est = np.arange(1.0, 10.0)
    label = np.repeat([0.0, 1.0, 2.0], 3)
    other = np.array([0.0, 1.0, 2.0, 2.0, 1.0, 0.0, 0.0, 1.0, 2.0])
    s = score_classes(est, label, {"other": other})
    assert s.auroc == {"0<1": 1.0, "1<2": 1.0}
    assert s.fraction == pytest.approx(1.0)
    # inside each class of three, the estimate follows `other` up, down, up: ρ = +1, −1, +1
    assert s.within["other"] == pytest.approx((1.0, -1.0, 1.0))
    assert s.worst_confound == pytest.approx(1.0)
    s2 = score_classes(np.append(est, np.nan), np.append(label, 2.0), {})
    assert s2.n == 9
    with pytest.raises(InputError):
        score_classes(est, label[:3], {})


def test_upper_steps_are_those_between_the_upper_plateaus() -> None:
    # the ZeMA load program: plateaus 146, 156, 166, 156, 151 bar
    levels = [146.0, 156.0, 166.0, 156.2, 151.0]
    steps = [LoadStep(a * BAR, b * BAR, 1e-6, float(k)) for k, (a, b)
             in enumerate(itertools.pairwise(levels))]
    chosen = upper_steps(steps)
    assert [(s.p_from / BAR, s.p_to / BAR) for s in chosen] == [(156.0, 166.0), (166.0, 156.2)]
    # an even count of plateaus: the lower middle one bounds the upper half
    four = [LoadStep(a * BAR, b * BAR, 1e-6, 0.0) for a, b in [(140, 150), (150, 160), (160, 170)]]
    assert [s.p_from / BAR for s in upper_steps(four)] == [150.0, 160.0]
    assert upper_steps([]) == []


def test_step_volume_counts_against_the_settled_pump_line() -> None:
    # as above, but the first plateau still carries the gas's outflow after an earlier fall
    t = np.arange(40, dtype=np.float64)
    p = np.where(t < 19, 150.0, 160.0) * BAR
    p[19] = 155.0 * BAR
    q_ss = 8.0 - 0.01 * (p / BAR - 150.0)
    q = q_ss.copy()
    q[19] -= 0.3
    q[:18] += 0.08 * np.exp(-t[:18] / 2.0)  # decays within the first plateau
    rec = _record(t, p, q * LPM)
    (settled,) = step_volumes(rec, relaxation=2.0)
    (means,) = step_volumes(rec)
    # the plateau's settled flow is the pump's: the stored oil comes back exactly
    assert settled.volume == pytest.approx(0.3 * LPM, rel=1e-6)
    # its mean lifts the pump line at 150 bar and overstates the oil stored in the step
    assert means.volume > settled.volume * 1.01
