"""The sensors' noise, white or coloured: its σ from the records, a surrogate of it, and
the workflow's verdict on no-effect cycles whose noise a logger's filter coloured (a
modelling engineer's pass: AR(1) noise with φ = 0.9 read as ~3.5 σ on every channel and
the exact model was "unexplained")."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import lfilter

from diagnostics.discrepancy import discover
from diagnostics.discrepancy.noise import (
    Noise,
    ar1_noise,
    coloured_note,
    coloured_sigma,
    noise_model,
    noise_models,
    sigmas,
    with_noise,
)
from diagnostics.discrepancy.signals import noise_sigma
from diagnostics.discrepancy.synthetic import NOISE, synthesize
from diagnostics.timeseries import SeriesRecord
from sim.rigs import reference_rig, reference_rig_document
from sim.rigs.assembly import Condition

RATE = 1000.0




def _record(x: np.ndarray) -> SeriesRecord:
    t = np.arange(x.size) / RATE
    return SeriesRecord("r", t, {"P1": x}, {"P1": "Pa"})


def _smooth_signal(n: int) -> np.ndarray:
    """A pressure that steps and settles like a cycle's: 40 bar steady phases, a switch
    to 10 bar every 2 s with a 30 ms first-order settle [Pa]."""
    t = np.arange(n) / RATE
    level = np.where((t % 4.0) < 2.0, 4e6, 1e6)
    return lfilter([1 - math.exp(-1 / 30)], [1.0, -math.exp(-1 / 30)], level,
                   zi=np.array([4e6 * math.exp(-1 / 30)]))[0]


@pytest.mark.parametrize("phi", [0.5, 0.8, 0.9, 0.95])
def test_coloured_noise_reads_its_own_sigma(phi: float) -> None:
    """AR(1) noise of σ = 5 kPa on a stepping pressure: σ within 20 %, where the
    sample-to-sample estimate reads √((6 − 8φ + 2φ²)/6) of it (0.26 at φ = 0.9)."""
    rng = np.random.default_rng(1)
    x = _smooth_signal(16000) + ar1_noise(rng, 16000, 5e3, phi)
    m = noise_model(_record(x), "P1")
    assert m.coloured
    assert m.sigma == pytest.approx(5e3, rel=0.2)
    white = 5e3 * math.sqrt((6 - 8 * phi + 2 * phi ** 2) / 6)
    assert m.white == pytest.approx(white, rel=0.2)
    assert m.phi == pytest.approx(phi, abs=0.1)


def test_white_noise_keeps_the_sample_to_sample_estimate_exactly() -> None:
    rng = np.random.default_rng(2)
    x = _smooth_signal(16000) + rng.normal(0.0, 5e3, 16000)
    m = noise_model(_record(x), "P1")
    assert not m.coloured and m.phi == 0.0
    assert m.sigma == noise_sigma(x)  # white records are judged exactly as before
    assert m.sigma == pytest.approx(5e3, rel=0.05)


def test_mains_hum_counts_at_its_own_rms() -> None:
    """50 Hz hum of 3 kPa amplitude on 2 kPa AR(1) noise (φ = 0.9): σ² = 2² + 3²/2 kPa²."""
    rng = np.random.default_rng(3)
    t = np.arange(16000) / RATE
    x = _smooth_signal(16000) + ar1_noise(rng, 16000, 2e3, 0.9) + 3e3 * np.sin(2 * np.pi * 50 * t + 1.0)
    assert noise_model(_record(x), "P1").sigma == pytest.approx(math.hypot(2e3, 3e3 / math.sqrt(2)),
                                                                rel=0.2)


def test_a_record_too_short_for_the_lags_is_judged_white() -> None:
    x = np.random.default_rng(4).normal(0.0, 1.0, 100)
    assert coloured_sigma(x, 1e-3) == 0.0
    assert not noise_model(_record(x), "P1").coloured


def test_a_record_of_a_solvers_own_points_is_judged_white() -> None:
    """A /simulate export without a sample rate (steps 1e-10 s to 50 ms apart) had its
    20-40 ms "lags" counted in samples, spanning whole strokes: P1's noise read 0.86 bar on
    a noise-free cycle, and a worn spool's 15 % gap "no effect" (a maintenance planner's
    pass)."""
    from diagnostics.timeseries import series_from_frame
    from sim.cycle import run_cycle

    res = run_cycle(reference_rig(), {"valve.cv": 60e-6}, Condition(load=2100.0),
                    method="rodas4")
    assert res.timeseries is not None
    (record,) = series_from_frame(res.timeseries.drop(columns=["phase"]))
    assert record.sample_rate is None
    noise = noise_model(record, "P1")
    assert noise.phi == 0.0 and noise.sigma == noise.white < 1e3   # Pa: not 0.86 bar


def test_the_surrogate_has_the_stated_sigma_and_colour_and_is_seeded() -> None:
    rec = _record(np.zeros(40000))
    model = {"P1": Noise(5e3, 0.9, 1.3e3), "absent": Noise(1.0)}
    a = with_noise([rec], model, seed=7)[0].channels["P1"]
    b = with_noise([rec], model, seed=7)[0].channels["P1"]
    assert np.array_equal(a, b)
    assert float(np.std(a)) == pytest.approx(5e3, rel=0.1)
    assert float(np.corrcoef(a[1:], a[:-1])[0, 1]) == pytest.approx(0.9, abs=0.02)
    white = with_noise([rec], {"P1": Noise(5e3)}, seed=7)[0].channels["P1"]
    assert abs(float(np.corrcoef(white[1:], white[:-1])[0, 1])) < 0.02


def test_sigmas_never_divide_by_zero_on_a_channel_logged_without_noise() -> None:
    rec = _record(np.full(5000, 2e6))
    assert sigmas([rec], ["P1"])["P1"] == pytest.approx(1e-4 * 2e6)
    assert noise_models([rec], ["P1"])["P1"] == Noise(0.0, 0.0, 0.0)


def _coloured_cycles(seed: int, phi: float, hum: float = 0.0) -> list[SeriesRecord]:
    """The reference rig's cycles at three loads, noise-free, with AR(1) noise of the
    synthetic logger's σ per channel and 50 Hz hum of ``hum`` [Pa] on the pressures."""
    rig = reference_rig()
    rng = np.random.default_rng(seed)
    out = []
    for load, temp in ((2100.0, 40.0), (4200.0, 50.0), (6300.0, 60.0)):
        r = synthesize(rig, Condition(load=load, oil_temperature=temp), rng=rng,
                       name=f"L{load:.0f}", sigma=dict.fromkeys(NOISE, 0.0))
        ch = {c: x + ar1_noise(rng, x.size, NOISE[c], phi) if c in NOISE else x
              for c, x in r.channels.items()}
        if hum:
            ch = {c: x + hum * np.sin(2 * np.pi * 50 * r.t + rng.uniform(0, 2 * np.pi))
                  if c.startswith("P") else x for c, x in ch.items()}
        out.append(replace(r, channels=ch))
    return out


@pytest.mark.parametrize(("phi", "hum"), [(0.9, 3e3), (0.6, 0.0)])
def test_no_effect_cycles_with_coloured_noise_give_no_effect(phi: float, hum: float) -> None:
    d = discover(reference_rig_document(), _coloured_cycles(5, phi, hum), bootstrap=10)
    assert d.verdict == "no effect", d.message
    assert d.named == []
    assert "sensor noise coloured on" in d.message and "P1" in d.message
    assert d.to_dict()["noise"]["P1"]["coloured"] is True
    from diagnostics.discrepancy.report import html_page

    page = html_page(d)
    assert "Sensor noise (read from the records)" in page and "coloured" in page


def test_a_hidden_effect_still_stands_out_of_coloured_noise() -> None:
    """Seal friction ∝ pressure (k_p 1.5e-5 m², the hidden-effect test of
    test_discrepancy.py) under AR(1) noise with φ = 0.9 of the same σ: still named."""
    rig_doc = reference_rig_document()
    rig_doc["effects"] = {"seal_friction_pressure": {"parameters": {
        "k_p": {"value": 1.5e-5, "unit": "m^2"}}}}
    from sim.rigs import load_rig

    rig = load_rig(rig_doc)
    rng = np.random.default_rng(6)
    recs = []
    for load, temp in ((2100.0, 40.0), (4200.0, 50.0), (6300.0, 60.0)):
        r = synthesize(rig, Condition(load=load, oil_temperature=temp), rng=rng,
                       name=f"L{load:.0f}", sigma=dict.fromkeys(NOISE, 0.0))
        recs.append(replace(r, channels={c: x + ar1_noise(rng, x.size, NOISE[c], 0.9)
                                         if c in NOISE else x for c, x in r.channels.items()}))
    d = discover(reference_rig_document(), recs, bootstrap=10)
    assert [n.name for n in d.named] == ["seal_friction_pressure"], d.message
    assert d.named[0].interval[0] <= 1.5e-5 <= d.named[0].interval[1]


def test_the_synthetic_loggers_coloured_noise_reads_as_coloured_with_its_hum() -> None:
    """The study's ``coloured`` kind: AR(1) φ = 0.9 of σ and 50 Hz hum of 0.6 σ on the
    pressures, so σ² = σ_P² (1 + 0.6²/2) there; the position and flows without hum."""
    rig = reference_rig()
    r = synthesize(rig, Condition(load=4200.0, oil_temperature=50.0),
                   rng=np.random.default_rng(8), noise="coloured")
    models = noise_models([r], ["P1", "Q_meter_B"])
    assert all(m.coloured for m in models.values())
    assert models["P1"].sigma == pytest.approx(NOISE["P1"] * math.sqrt(1 + 0.6 ** 2 / 2), rel=0.2)
    assert models["Q_meter_B"].sigma == pytest.approx(NOISE["Q_meter_B"], rel=0.2)
    assert models["P1"].phi == pytest.approx(0.9, abs=0.1)


def test_a_derived_speed_is_not_called_a_sensor() -> None:
    # σ 4.8× the white estimate on a v the workflow derived from x (a discrepancy pass
    # read "sensor noise coloured on v"); a coloured pressure stays a sensor's
    models = {"v": Noise(4.8e-3, 0.9, 1e-3), "P1": Noise(4e4, 0.9, 1e4), "P2": Noise(8e3)}
    note = coloured_note(models, derived={"v"})
    assert note.startswith("sensor noise coloured on P1 and noise coloured on v, derived")
    assert "(σ 4.0-4.8× the sample-to-sample estimate)" in note
    alone = coloured_note({"v": models["v"]}, derived={"v"})
    assert "sensor" not in alone and "derived from the position" in alone
    assert coloured_note({"P2": models["P2"]}) == ""
