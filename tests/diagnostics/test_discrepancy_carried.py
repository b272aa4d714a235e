"""Effects the rig carries are fitted again on the data (:mod:`diagnostics.discrepancy.
carried_check`): a stored effect the data do not hold is reported, not passed over as
"no effect" (a user pass: seal friction named by the workflow, then checked on cycles of
a rig without it, got "no effect: the gap is within the noise")."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from diagnostics.discrepancy import discover
from diagnostics.discrepancy.balances import balance_data
from diagnostics.discrepancy.carried_check import check_carried
from diagnostics.discrepancy.first_step import check_records
from diagnostics.discrepancy.signals import prepare
from diagnostics.discrepancy.synthetic import NOISE, synthesize
from sim.errors import InputError
from sim.rigs import load_rig, reference_rig_document
from sim.rigs.assembly import Condition

SPEED = 1600.0 * 2.0 * np.pi / 60.0
DESIGN = ((2100.0, 40.0, 0.8), (4200.0, 50.0, 0.9), (6300.0, 60.0, 1.0))
#: pressure-dependent seal friction [m²]: the size the user's run named (t = 14.5)
K_P = 3.0e-5


def _doc(k_p: float) -> dict:
    doc = reference_rig_document()
    if k_p:
        doc["effects"] = {"seal_friction_pressure": {"parameters": {
            "k_p": {"value": k_p, "unit": "m^2"}}}}
    return doc


def _records(k_p: float, seed: int, sigma: dict | None = None) -> list:
    rig = load_rig(_doc(k_p))
    rng = np.random.default_rng(seed)
    return [synthesize(rig, Condition(load=L, oil_temperature=T, pump_speed=w * SPEED),
                       rng=rng, name=f"L{L:.0f}", sigma=sigma) for L, T, w in DESIGN]


@pytest.mark.parametrize(("truth", "held"), [(0.0, 0.0), (K_P, 1.0)])
def test_the_carried_effect_is_fitted_again_on_noise_free_data(truth: float,
                                                               held: float) -> None:
    rig = load_rig(_doc(K_P))  # carries the effect; the data have it or not
    zero = dict.fromkeys(NOISE, 0.0)
    data = balance_data(prepare(_records(truth, 0, zero), rig), rig.values())
    (check,) = check_carried(data)
    assert (check.effect, check.balance, check.stored) == (
        "seal_friction_pressure", "piston_force", K_P)
    assert check.held == pytest.approx(held, abs=0.05)
    assert check.outcome == ("not held" if held == 0.0 else "held")


def test_a_stored_effect_the_data_lack_is_not_no_effect() -> None:
    d = discover(_doc(K_P), _records(0.0, 7), bootstrap=10)
    assert d.verdict == "unexplained", d.message
    assert "the stored seal_friction_pressure" in d.message
    assert "is not in these data" in d.message
    (check,) = d.carried
    assert check.outcome == "not held"
    assert d.to_dict()["carried"][0]["outcome"] == "not held"


def test_a_stored_effect_the_data_hold_stays_no_effect() -> None:
    d = discover(_doc(K_P), _records(K_P, 7), bootstrap=10)
    assert d.verdict == "no effect", d.message
    assert [c.outcome for c in d.carried] == ["held"]
    # the report page says so (it said only "no effect": a discrepancy pass)
    from diagnostics.discrepancy.report import html_page

    page = html_page(d)
    assert "Effects the rig already carries, checked on these data" in page
    assert "<td>seal_friction_pressure</td>" in page and "<td>held</td>" in page


def test_records_with_other_channels_are_refused_before_any_job() -> None:
    """A held-out record without 'v' beside one with it made the job fail with an internal
    KeyError after its 202 (a fleet integrator's pass); check_records, which the HTTP
    route runs before it accepts a job, now refuses it."""
    a, b = _records(0.0, 1)[:2]
    # (a record with the position alone now has its speed derived from it: the flow)
    b = replace(b, channels={k: v for k, v in b.channels.items() if k != "Q_meter_C"},
                units={k: u for k, u in b.units.items() if k != "Q_meter_C"})
    with pytest.raises(InputError) as e:
        check_records(_doc(0.0), [a, b])
    assert e.value.field == "file" and "it lacks Q_meter_C" in e.value.message
