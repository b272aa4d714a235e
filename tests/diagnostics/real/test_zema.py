"""The ZeMA adapter and the leakage estimate on a slice of the real data (tests/real_slices.py)."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from diagnostics.pump.field_record import FieldRecord
from diagnostics.pump.field_slip import plateaus
from diagnostics.real.leakage import (
    change_points,
    cycle_point,
    leakage_estimates,
    record_plateaus,
    score_leakage,
    spearman_ceiling,
)
from diagnostics.real.zema import cycles_frame, load_1hz, read_records
from diagnostics.timeseries import read_series
from sim.errors import InputError
from tests.real_slices import zema_slice

SLICE = zema_slice()


@pytest.fixture(scope="module")
def zema():  # type: ignore[no-untyped-def]
    data, labels = load_1hz(SLICE)
    return data, labels, read_records(data)


def test_import_units_rate_and_marking(zema) -> None:  # type: ignore[no-untyped-def]
    data, labels, recs = zema
    assert len(recs) == 18 == labels.leakage.size
    r = recs[0]
    assert r.measured and r.sample_rate == pytest.approx(1.0)
    assert r.units == {"p_pump": "Pa", "p_work": "Pa", "q_work": "m^3/s", "motor_power": "W",
                       "oil_temperature": "degC"}
    # bar → Pa and l/min → m³/s, against the file's own numbers
    assert r.channel("p_pump")[3] == pytest.approx(data.sensors["PS1"][0, 3] * 1e5)
    assert r.channel("q_work")[15] == pytest.approx(data.sensors["FS1"][0, 15] / 60000.0)
    # the rig's relief plateau is about 191 bar with no working flow (SOURCE.md)
    assert 185e5 < r.channel("p_pump")[4] < 195e5
    assert abs(r.channel("q_work")[4]) < 1e-6


def test_plateaus_follow_the_record_rate(zema) -> None:  # type: ignore[no-untyped-def]
    _, _, recs = zema
    plats = record_plateaus(recs[0])
    # relief plateau + the five working plateaus (146/156/166/156/151 bar) of the load cycle
    assert len(plats) == 6
    pt = cycle_point(recs[0])
    assert 140e5 < pt.pressure < 170e5 and pt.flow > 1e-4
    # the 30 ms tuned defaults of the field-record detector warn on a 1 Hz record
    rec = FieldRecord(recs[0].t, recs[0].channel("p_pump"), recs[0].channel("oil_temperature"),
                      np.abs(recs[0].channel("q_work")) + 1e-6, 150.0)
    assert rec.simulated is False
    with pytest.warns(UserWarning, match="too coarse"):
        plateaus(rec)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plateaus(rec, min_duration=6.0, window=5, settle=1.0, max_rate=2e5)


def test_estimate_orders_leakage_classes_on_the_slice(zema) -> None:  # type: ignore[no-untyped-def]
    _, labels, recs = zema
    est = leakage_estimates([cycle_point(r) for r in recs])
    med = [float(np.median(est[labels.leakage == c])) for c in (0, 1, 2)]
    assert med[0] < med[1] < med[2]
    s = score_leakage(est, labels.leakage, labels.cooler, labels.accumulator)
    assert s.auroc_01 == 1.0 and s.auroc_12 == 1.0
    assert s.fraction > 0.9


def test_table_without_time_needs_a_sample_rate(zema) -> None:  # type: ignore[no-untyped-def]
    data, _, _ = zema
    frame = cycles_frame(data)
    cmap = {"PS1": ("p_pump", "bar")}
    with pytest.raises(InputError) as err:
        read_series(frame[["record", "PS1"]], column_map=cmap)
    assert err.value.field == "t"
    with pytest.raises(InputError) as err:
        read_series(frame[["record", "PS1"]], column_map=cmap, sample_rate=-1.0)
    assert err.value.field == "sample_rate"
    recs = read_series(frame[["record", "PS1"]], column_map=cmap, sample_rate=100.0)
    assert recs[0].t[1] == pytest.approx(0.01) and recs[0].duration == pytest.approx(0.59)
    # a time column wins over the sample rate
    timed = pd.DataFrame({"t [s]": [0.0, 0.5, 1.5], "p [bar]": [1.0, 2.0, 3.0]})
    assert read_series(timed, sample_rate=1.0)[0].t[2] == 1.5


def test_bad_cycle_number_is_refused() -> None:
    with pytest.raises(InputError) as err:
        load_1hz(SLICE, cycles=[0])
    assert err.value.field == "cycles"


def test_change_points_find_a_step_and_not_noise() -> None:
    rng = np.random.default_rng(3)
    x = np.concatenate([np.zeros(100), np.full(80, 1.0)]) + rng.normal(0, 0.2, 180)
    cps = change_points(x)
    assert len(cps) == 1 and abs(cps[0] - 100) <= 2
    assert change_points(rng.normal(0, 1.0, 300)) == []


def test_spearman_ceiling_by_hand() -> None:
    # ranks with ties [1.5, 1.5, 3.5, 3.5] against [1, 2, 3, 4]: 4 / (2·√5)
    assert spearman_ceiling([0, 0, 1, 1]) == pytest.approx(4.0 / (2.0 * np.sqrt(5.0)))


def test_native_rate_record_gives_the_same_cycle_point_as_its_1hz_means() -> None:
    from diagnostics.real.zema import ZemaCycles, read_fullres

    (rec,) = read_fullres(SLICE / "fullres_cycle1092.csv", [1092], duration=30.0)
    assert rec.name == "cycle-1092" and rec.measured
    assert rec.sample_rate == pytest.approx(100.0) and len(rec) == 3000
    # the 10 Hz flowmeter is held between its readings
    q = rec.channel("q_work")
    assert np.all(q.reshape(300, 10) == q.reshape(300, 10)[:, :1])
    fast = cycle_point(rec)
    # the same cycle as 1-second block means, through the 1 Hz path
    blocks = {s: rec.channels[c].reshape(30, 100).mean(axis=1)[None, :] for s, c in
              (("PS1", "p_pump"), ("FS1", "q_work"), ("TS1", "oil_temperature"))}
    unit_back = {"PS1": 1e-5, "FS1": 6e4, "TS1": 1.0}
    slow_data = ZemaCycles(np.array([1092]), {k: v * unit_back[k] for k, v in blocks.items()},
                           1.0)
    (slow_rec,) = read_records(slow_data)
    slow = cycle_point(slow_rec)
    assert fast.pressure == pytest.approx(slow.pressure, rel=5e-3)
    assert fast.flow == pytest.approx(slow.flow, rel=5e-3)
    # the field-record detector picks a window for 100 Hz itself and does not warn
    fr = FieldRecord(rec.t, rec.channel("p_pump"), rec.channel("oil_temperature"),
                     np.abs(q) + 1e-6, 150.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(plateaus(fr)) >= 2
