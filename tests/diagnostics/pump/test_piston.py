"""Piston-pump loss models and the single-temperature mode on a slice of the V32HL56 map."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from diagnostics.pump import bench_from_frame, derived_capacity_toet, parameterise
from diagnostics.pump.compare import s_difference
from diagnostics.pump.levels import cluster_levels
from diagnostics.pump.piston import (
    FLOW_LOSS_TERMS,
    TORQUE_LOSS_TERMS,
    PistonMap,
    bench_frame,
    fit_losses,
    held_out_speed,
    read_efficiency_map,
)
from sim.errors import InputError
from tests.real_slices import v32hl56_slice

SLICE = v32hl56_slice()


@pytest.fixture(scope="module")
def big() -> tuple[PistonMap, float]:
    """The 57 cm³/rev setting (9 speeds × 12 pressures) and its displacement [m³/rad]."""
    m = read_efficiency_map(SLICE)
    idx, lev = cluster_levels(m.D, field="D")
    k = int(np.argmax(lev))
    return m.subset(idx == k), float(lev[k])


def test_units_follow_the_files_own_identities() -> None:
    m = read_efficiency_map(SLICE)
    raw = pd.read_csv(SLICE)
    # PowerIn [kW] = ω·T and PowerOut [kW] = Δp·q, in SI
    assert np.allclose(m.omega * m.torque, raw["PowerIn"] * 1e3, rtol=1e-9)
    assert np.allclose(m.dp * m.q, raw["PowerOut"] * 1e3, rtol=1e-9)
    # Etav [%] = q/(D·ω)
    assert np.allclose(m.q / (m.D * m.omega), raw["Etav"] / 100.0, rtol=1e-9)
    assert m.q_drain is not None and np.all(m.q_drain > 0)


def test_single_temperature_gives_the_capacity_not_a_refusal(big) -> None:  # type: ignore[no-untyped-def]
    data, D = big
    bench = bench_from_frame(bench_frame(data, theta=50.0))
    result = parameterise(bench)
    assert result.fits == {} and result.points is None
    assert "not identifiable" in result.not_identifiable
    # the Toet capacity lies just above the set displacement (leakage-free flow per radian)
    assert 1.0 < result.D / D < 1.015
    assert derived_capacity_toet(bench).D == result.D
    with pytest.raises(InputError) as err:
        result.pump()
    assert err.value.field == "theta"


def test_one_map_labelled_at_two_temperatures_is_refused(big) -> None:  # type: ignore[no-untyped-def]
    data, _ = big
    twice = pd.concat([bench_frame(data, 40.0), bench_frame(data, 60.0)], ignore_index=True)
    with pytest.raises(InputError) as err:
        parameterise(bench_from_frame(twice))
    assert err.value.field == "theta" and "identical" in err.value.message


def test_loss_models_have_physical_signs_and_explain_the_data(big) -> None:  # type: ignore[no-untyped-def]
    data, D = big
    flow, torque = fit_losses(data, D)
    for fit, library in ((flow, FLOW_LOSS_TERMS), (torque, TORQUE_LOSS_TERMS)):
        signs = {t.name: t.sign for t in library}
        for name, c in zip(fit.terms, fit.coef, strict=True):
            assert signs[name] == 0 or c >= 0, (fit.kind, name, c)
    # the speed-dependent leakage term is chosen: the drain flow of a piston pump grows with ω
    assert "dp*omega" in flow.terms
    res = data.q - (D * data.omega - flow.loss(data.dp, data.omega))
    assert math.sqrt(float(np.mean(res**2))) < 0.01 * float(np.max(data.q))


@pytest.mark.parametrize("setting", [0, 1])
def test_every_setting_of_the_slice_gets_physical_signs(setting: int) -> None:
    m = read_efficiency_map(SLICE)
    idx, lev = cluster_levels(m.D, field="D")
    sub, D = m.subset(idx == setting), float(lev[setting])
    h = held_out_speed(sub, D)
    for fit, library in ((h.flow, FLOW_LOSS_TERMS), (h.torque, TORQUE_LOSS_TERMS)):
        signs = {t.name: t.sign for t in library}
        assert all(signs[n] == 0 or c >= 0 for n, c in zip(fit.terms, fit.coef, strict=True))
    # the losses the model predicts are losses: less flow than D·ω, more torque than D·Δp
    assert np.all(h.flow.loss(sub.dp, sub.omega) > 0)
    assert np.all(h.torque.loss(sub.dp, sub.omega) > 0)
    # the flow loss at 4,500 rpm is about 3× that at 1,000 rpm at 200 bar (eq. 6 has no ω)
    dp = np.array([2e7])
    ratio = h.flow.loss(dp, np.array([4500 * np.pi / 30]))[0] / h.flow.loss(
        dp, np.array([1000 * np.pi / 30]))[0]
    assert 2.5 < ratio < 3.6


def test_held_out_speed_scores_both_models(big) -> None:  # type: ignore[no-untyped-def]
    data, D = big
    h = held_out_speed(data, D)
    assert h.speeds == 9
    assert 0 < h.flow_S < 1.0 and 0 < h.flow_S_quadratic < 1.0
    assert h.flow_R2 > 0.999 and h.torque_R2 > 0.999
    # the speed-dependent family predicts an unseen speed of the full-stroke setting within
    # 0.3 % of its largest flow, and better than a quadratic in (Δp, n) on the same split
    assert h.flow_S < 0.3 and h.flow_S < h.flow_S_quadratic
    # the held-out predictions are kept, and S is their rms error over the setting's max flow
    res = data.q - h.flow_pred
    assert math.isclose(100 * math.sqrt(float(np.mean(res**2))) / h.flow_full, h.flow_S)
    assert h.flow_full == float(np.max(data.q)) and h.torque_pred.shape == data.torque.shape
    # the quadratic's held-out predictions are kept too, and give its S
    resq = data.torque - h.torque_pred_quadratic
    assert math.isclose(100 * math.sqrt(float(np.mean(resq**2))) / h.torque_full,
                        h.torque_S_quadratic)
    d = s_difference(data.q, h.flow_pred, h.flow_pred_quadratic, data.omega, h.flow_full)
    assert d.blocks == 9 and math.isclose(d.difference, h.flow_S - h.flow_S_quadratic)
    assert d.low <= d.difference <= d.high


def test_degenerate_maps_are_refused(big) -> None:  # type: ignore[no-untyped-def]
    data, D = big
    one_speed = data.subset(np.isclose(data.omega, data.omega[0], rtol=0.02))
    with pytest.raises(InputError) as err:
        fit_losses(one_speed, D)
    assert err.value.field == "Speed"
    with pytest.raises(InputError) as err:
        fit_losses(PistonMap(data.dp, data.omega, data.q, data.torque, data.D), D,
                   target="drain")
    assert err.value.field == "QDr"


def test_spring_loaded_film_friction_comes_back_from_a_synthetic_map() -> None:
    # torque loss of a known pump: Coulomb 2e-7 N·m/Pa (2 N·m at 100 bar), viscous
    # 5e-3 N·m·s, and a spring-loaded film 0.4 N·m·s^½ (√ω: 4 N·m at 100 rad/s)
    rng = np.random.default_rng(3)
    w = np.repeat(np.array([500.0, 1500.0, 2500.0, 3500.0, 4500.0]) * math.pi / 30, 8)
    dp = np.tile(np.linspace(5e6, 35e6, 8), 5)
    D = 30e-6 / (2 * math.pi)
    loss = 2e-7 * dp + 5e-3 * w + 0.4 * np.sqrt(w)
    torque = D * dp + loss + rng.normal(0.0, 0.005, dp.size)
    q = D * w * 0.98
    data = PistonMap(dp, w, q, torque, np.full(dp.size, D))
    _, fit = fit_losses(data, D)
    assert "sqrt(omega)" in fit.terms
    coef = dict(zip(fit.terms, fit.coef, strict=True))
    assert coef["sqrt(omega)"] == pytest.approx(0.4, rel=0.1)
    # the fitted loss reproduces the known one within the noise
    assert np.max(np.abs(fit.loss(dp, w) - loss)) < 0.02


def test_a_bench_csv_given_as_a_map_is_pointed_to_the_bench_reader() -> None:
    sample = Path(__file__).resolve().parents[3] / "docs" / "samples" / "bench_sample.csv"
    with pytest.raises(InputError) as e:
        read_efficiency_map(sample)
    assert "hydrodiag calibrate pump FILE" in e.value.message


def test_headers_that_state_their_units_are_read_in_them(tmp_path: Path) -> None:
    """``Deltap [MPa]`` as the help shows the columns was refused "Deltap: column missing"
    (a pump maker's pass); a header's unit is now read, and converted where it differs
    from the layout's; a unit of another quantity names the column."""
    frame = pd.read_csv(SLICE)
    bare = read_efficiency_map(SLICE)
    stated = frame.rename(columns={"Speed": "Speed [rpm]", "Deltap": "Deltap [bar]",
                                   "QOut": "QOut [l/min]", "Torque": "Torque [N*m]",
                                   "Displacement": "Displacement [cm³/rev]"})
    stated["Deltap [bar]"] = frame["Deltap"] * 10.0
    path = tmp_path / "stated.csv"
    stated.to_csv(path, index=False)
    read = read_efficiency_map(path)
    for name in ("dp", "omega", "q", "torque", "D"):
        np.testing.assert_allclose(getattr(read, name), getattr(bare, name), rtol=1e-12)
    stated.rename(columns={"Deltap [bar]": "Deltap [l/min]"}).to_csv(path, index=False)
    with pytest.raises(InputError) as e:
        read_efficiency_map(path)
    assert e.value.field == "Deltap" and "not a unit of this quantity" in e.value.message
