"""Rig description files: the reference preset validates; bad files get named errors."""

from __future__ import annotations

import copy
import json
import math
from typing import Any

import numpy as np
import pytest

from sim.errors import ParameterError, RigFileError
from sim.rigs import (
    Condition,
    load_rig,
    load_rig_document,
    reference_rig,
    reference_rig_document,
    validate_rig_document,
)
from sim.rigs.circuits import CIRCUITS
from sim.steady import steady_cycle


def test_reference_document_validates_and_converts_units():
    spec = validate_rig_document(reference_rig_document())
    assert spec.name == "paper002-reference"
    assert spec.circuit is CIRCUITS["pump-valve-cylinder"]
    assert set(spec.components) == set(spec.circuit.roles)
    pump = spec.components["pump"][1]
    assert pump["speed"].value == pytest.approx(1600 * 2 * 3.141592653589793 / 60)
    assert pump["speed"].unit == "rpm"
    assert pump["Vp"].value == pytest.approx(1.75e-5 / (2 * 3.141592653589793))
    for _, params in spec.components.values():
        for q in params.values():
            assert q.source, "every parameter states its source"


@pytest.mark.parametrize(
    ("mutate", "field", "words"),
    [
        (lambda d: d["components"]["cylinder"]["parameters"].pop("cc"),
         "components.cylinder.parameters.cc", "missing"),
        (lambda d: d["components"]["cylinder"]["parameters"]["cc"].update(value=-5e-6),
         "components.cylinder.parameters.cc", "must be >"),
        (lambda d: d["components"]["cylinder"]["parameters"]["cc"].update(unit="bar"),
         "components.cylinder.parameters.cc.unit", "not a unit"),
        (lambda d: d["components"]["valve"]["parameters"].update(foo={"value": 1, "unit": "m"}),
         "components.valve.parameters.foo", "unknown parameter"),
        (lambda d: d["components"].pop("valve"), "components.valve", "missing component"),
        (lambda d: d["components"]["pump"].update(type="hose"), "components.pump.type", "takes"),
        (lambda d: d.update(schema="x"), "schema", "expected schema"),
        (lambda d: d["fluid"]["beta"].update(value="big"), "fluid.beta.value", "number"),
        (lambda d: d["fluid"]["beta"].update(value=float("nan")), "fluid.beta.value", "finite"),
        # a dimensionless bound reads "≤ 0.2, got", not "≤ 0.2 1, got"
        (lambda d: d.update(effects={"entrained_air": {"parameters": {"alpha": {
            "value": 0.5, "unit": "1"}}}}), "effects.entrained_air.parameters.alpha",
         "must be ≤ 0.2, got 0.5"),
    ],
)
def test_invalid_documents_name_the_field(mutate, field, words):
    doc = copy.deepcopy(reference_rig_document())
    mutate(doc)
    with pytest.raises(RigFileError) as exc:
        validate_rig_document(doc)
    assert exc.value.field == field
    assert words in exc.value.message


def test_units_of_the_same_dimension_are_accepted(tmp_path):
    doc = reference_rig_document()
    doc["components"]["cylinder"]["parameters"]["cc"] = {"value": 83, "unit": "µm", "source": "x"}
    doc["components"]["relief"]["parameters"]["Pset"] = {"value": 70, "unit": "bar", "source": "x"}
    path = tmp_path / "rig.json"
    path.write_text(json.dumps(doc))
    spec = validate_rig_document(load_rig_document(path))
    assert spec.components["cylinder"][1]["cc"].value == pytest.approx(83e-6)
    assert spec.components["relief"][1]["Pset"].value == pytest.approx(7.0e6)
    rig = load_rig(path)
    assert rig.base["cylinder.cc"] == pytest.approx(83e-6)


def test_unreadable_file_is_a_rig_file_error(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("components: [unclosed")
    with pytest.raises(RigFileError):
        load_rig_document(bad)
    with pytest.raises(RigFileError):
        load_rig_document(tmp_path / "absent.yaml")


def test_an_unknown_circuit_is_named():
    doc = copy.deepcopy(reference_rig_document())
    doc["circuit"] = "pump-only"
    with pytest.raises(RigFileError) as exc:
        validate_rig_document(doc)
    assert exc.value.field == "circuit"
    assert "pump-valve-cylinder" in exc.value.message


def test_a_strict_document_knows_every_key_and_keeps_its_bounds():
    """``strict`` (a document being stored) refuses keys the schema does not know and
    values past a plausibility bound; without it (a stored document read back) the same
    document loads, so one stored before these checks still works."""
    for mutate, field in [
        (lambda d: d.update(colour="red"), "colour"),
        (lambda d: d["fluid"]["beta"].update(note="x"), "fluid.beta.note"),
        # 3 mm: within the bore's radius, past the 2 mm plausibility bound
        (lambda d: d["components"]["cylinder"]["parameters"]["cc"].update(value=0.003),
         "components.cylinder.parameters.cc"),
    ]:
        doc = copy.deepcopy(reference_rig_document())
        mutate(doc)
        with pytest.raises(RigFileError) as exc:
            validate_rig_document(doc, strict=True)
        assert exc.value.field == field
        validate_rig_document(doc)
        load_rig(doc)
    validate_rig_document(reference_rig_document(), strict=True)
    for circuit in CIRCUITS.values():
        for role in circuit.roles:
            for relation in circuit.relations(role):  # each relation holds on its defaults
                assert circuit.parameter(role, relation.name) is not None


@pytest.mark.parametrize(("name", "value", "text"), [
    ("cc", 0.031, "the radial clearance must be less than the bore's radius"),
    ("rod2", 0.06, "the chamber-2 rod must be thinner than the bore"),
    ("rod1", 0.07, "the chamber-1 rod must be thinner than the bore")])
def test_a_broken_geometry_is_refused_on_every_read(name: str, value: float, text: str) -> None:
    """A 70 mm rod in the bore compiled from a document (``load_rig(doc)``, non-strict)
    with A1 < 0, and ``run_cycle`` answered a "stall" (a library user's pass): the
    geometric relations are checked strict or not, with the message an override gets."""
    doc = copy.deepcopy(reference_rig_document())
    doc["components"]["cylinder"]["parameters"][name].update(value=value)
    for strict in (False, True):  # strictly, a plausibility bound may be named first
        with pytest.raises(RigFileError) as exc:
            load_rig(doc, strict=strict)
        assert exc.value.field == f"components.cylinder.parameters.{name}"
    with pytest.raises(RigFileError) as exc:
        load_rig(doc)
    assert exc.value.message == text
    if name != "cc":  # 31 mm is past the clearance's 2 mm bound too, named first there
        with pytest.raises(ParameterError) as exc:
            reference_rig().values({f"cylinder.{name}": value})
        assert exc.value.message == f"{text} (with the overrides given)"


def test_a_pump_speed_in_rpm_is_refused_with_the_unit_named() -> None:
    """condition.pump_speed is in rad/s; 1450 meant as rpm passed the 2000 rad/s ceiling
    and ran the paper-002 pump 9 times too fast (a user pass)."""
    rig = reference_rig()
    stated = rig.values()["pump.speed"]  # 1600 rpm
    rig.values(condition=Condition(load=2100.0, oil_temperature=40.0,
                                   pump_speed=2.0 * stated))  # an overspeed test: allowed
    with pytest.raises(ParameterError) as e:
        rig.values(condition=Condition(load=2100.0, oil_temperature=40.0, pump_speed=1450.0))
    assert e.value.field == "condition.pump_speed"
    assert "in rad/s" in e.value.message and "(1600 rpm)" in e.value.message
    # the same number as an override of the pump's own speed passed unchecked
    rig.values({"pump.speed": 2.0 * stated})
    with pytest.raises(ParameterError) as e:
        rig.values({"pump.speed": 1450.0})
    assert e.value.field == "overrides.pump.speed" and "(1600 rpm)" in e.value.message


def test_a_displacement_per_revolution_is_refused_as_an_override() -> None:
    """The rig file and the papers give Vp per revolution; an override is per radian, and
    1.75e-5 ran the pump 2π times too large, the piston at 1.37 m/s (a library user's
    pass).  A larger pump, up to three times the rig's, stays a valid question."""
    rig = reference_rig()
    stated = rig.values()["pump.Vp"]
    assert pytest.approx(stated * 2 * math.pi) == 17.5e-6
    rig.values({"pump.Vp": 2.0 * stated})
    with pytest.raises(ParameterError) as e:
        rig.values({"pump.Vp": 17.5e-6})
    assert e.value.field == "overrides.pump.Vp"
    assert "(17.5 cm³/rev)" in e.value.message and "m³/rev ÷ 2π" in e.value.message


def test_a_rig_reads_in_one_line() -> None:
    """The generated repr printed the compiled equations: 62 kB in a notebook."""
    shown = repr(reference_rig())
    assert "\n" not in shown and len(shown) < 200 and "paper002-reference" in shown


def test_a_bound_broken_in_another_unit_is_said_as_written() -> None:
    doc = reference_rig_document()
    doc["components"]["pump"]["parameters"]["Vp"]["value"] = 0.0  # the file's m³/rev
    with pytest.raises(RigFileError) as e:
        load_rig(doc)
    assert e.value.field == "components.pump.parameters.Vp"
    assert "> 0 m^3/rad" in e.value.message and "(written 0 m^3/rev)" in e.value.message


@pytest.mark.parametrize(("role", "name", "value"), [
    ("double_acting_cylinder", "bore", 63.0), ("double_acting_cylinder", "stroke", 400.0),
    ("double_acting_cylinder", "cc", 0.01), ("directional_valve_4_2", "Dv", 12.5),
    ("fixed_displacement_pump", "Vp", 0.0175), ("relief_valve", "Pset", 1e9),
    ("relief_valve", "Pset", 5e4), ("fixed_displacement_pump", "speed", 1600.0)])
def test_a_value_past_anything_built_is_refused_when_stored_and_still_read_back(
        role: str, name: str, value: float) -> None:
    """A bore of 63 "m", a 10 mm clearance, a 10,000 bar relief, a 0.5 bar relief (below the
    supply line's drop: the rig could not extend) were stored, and the bore made /simulate
    answer 500 (an engineer's pass); a stored document read back keeps loading.  The slip
    named is one of the parameter's unit (a speed's is rpm, not "mm written as m")."""
    doc = copy.deepcopy(reference_rig_document())
    comps = doc["components"]
    key = next(k for k, c in comps.items() if c["type"] == role)
    comps[key]["parameters"][name]["value"] = value
    if name == "speed":   # the document states it in rpm: 1600 rpm typed as rad/s
        comps[key]["parameters"][name]["unit"] = "rad/s"
    with pytest.raises(RigFileError) as exc:
        validate_rig_document(doc, strict=True)
    assert exc.value.field == f"components.{key}.parameters.{name}"
    assert "unit slip" in exc.value.message
    slip = {"speed": "rpm written as rad/s", "Vp": "written as m³/rad",
            "bore": "mm written as m"}.get(name)
    assert slip is None or slip in exc.value.message, exc.value.message
    validate_rig_document(doc)


def test_a_clearance_in_m_for_um_is_named_a_unit_slip_before_the_geometry() -> None:
    """``cylinder.cc = 30`` (µm typed as m) broke the geometric relation first ("less than
    the bore's radius") and never reached the bound that names the unit slip."""
    from sim.errors import ParameterError
    from sim.rigs import reference_rig
    from sim.steady import steady_cycle

    with pytest.raises(ParameterError) as exc:
        steady_cycle(reference_rig(), {"cylinder.cc": 30.0})
    assert "likely a unit slip" in exc.value.message and exc.value.field == "overrides.cylinder.cc"


def test_a_file_is_loaded_with_the_checks_of_storing_it(tmp_path) -> None:
    """load_rig(path), the validator the reference file names, took a 70 mm rod in a 63 mm
    bore that rigs add refuses, and simulated it with a negative annulus (a rig author's
    pass); a document (a stored one) still loads without the storing checks, though not
    with a broken geometry, which no model of it can simulate (a library user's pass)."""
    import yaml

    from sim.rigs import load_rig

    doc = copy.deepcopy(reference_rig_document())
    doc["components"]["cylinder"]["parameters"]["rod2"] = {"value": 70.0, "unit": "mm"}
    doc["components"]["cylinder"]["parameters"]["bore"] = {"value": 63.0, "unit": "mm"}
    path = tmp_path / "rod.yaml"
    path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    with pytest.raises(RigFileError) as exc:
        load_rig(path)
    assert exc.value.field == "components.cylinder.parameters.rod2"
    with pytest.raises(RigFileError) as exc:
        load_rig(doc)  # the geometry on every read
    assert exc.value.field == "components.cylinder.parameters.rod2"
    doc = copy.deepcopy(reference_rig_document()) | {"colour": "red"}
    path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    with pytest.raises(RigFileError) as exc:
        load_rig(path)
    assert exc.value.field == "colour"
    load_rig(doc)  # a stored document is read back without the storing checks


def test_the_rig_file_pages_example_is_stored_and_runs_as_it_says() -> None:
    """docs/rig-files.md's complete example passes the storing checks and its steady cycle
    gives what the page states (0.19 m/s, P1 = 34 bar at 10 kN, ratio 0.66)."""
    import re
    from pathlib import Path

    from sim.steady import steady_cycle
    from sim.yaml_loader import load_yaml

    page = (Path(__file__).resolve().parents[3] / "docs" / "rig-files.md").read_text()
    found = re.search(r"```yaml\n(schema: hydrodiag\.rig/1.*?)```", page, re.S)
    assert found is not None
    doc = load_yaml(found.group(1))
    validate_rig_document(doc, strict=True)
    result = steady_cycle(load_rig(doc))
    assert result.working["speed"] == pytest.approx(0.19, abs=0.005)
    assert result.working["P1"] / 1e5 == pytest.approx(34.0, abs=0.5)
    assert result.velocity_ratio == pytest.approx(0.66, abs=0.005)


@pytest.mark.parametrize(("overrides", "condition", "field"), [
    ({"valve.cv": np.array([60e-6])}, None, "overrides.valve.cv"),
    ({"valve.cv": None}, None, "overrides.valve.cv"),
    ({"valve.cv": "60 um"}, None, "overrides.valve.cv"),
    (None, Condition(load=np.array([2100.0, 4200.0])), "condition.force"),  # type: ignore[arg-type]
    (None, {"load": 4200.0}, "condition"),
    ([("valve.cv", 6e-5)], None, "overrides"),
])
def test_a_value_of_the_wrong_kind_is_a_parameter_error_naming_it(
        overrides: Any, condition: Any, field: str) -> None:
    """An array, None, a string, a dict for the condition or a list of pairs raised bare
    TypeError, ValueError or AttributeError naming nothing (a library user's pass)."""
    with pytest.raises(ParameterError) as caught:
        steady_cycle(reference_rig(), overrides, condition)
    assert caught.value.field == field
    # a 0-d array or a numpy float is a number
    steady_cycle(reference_rig(), {"valve.cv": np.array(6e-5)})
    steady_cycle(reference_rig(), {"valve.cv": np.float64(6e-5)})
