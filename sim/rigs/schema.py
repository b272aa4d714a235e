"""Rig description files: validation and the in-memory :class:`RigSpec`.

A rig file (YAML or JSON) names the circuit, the fluid and every component with every
parameter as ``{value, unit, source}``.  Validation is strict, because a rig file is the
engineer's statement of the machine: a missing parameter, an unknown one, a unit of the
wrong dimension or a value outside the physical bounds is an error that names the field
(:class:`~sim.errors.RigFileError`).  Units are converted to SI on reading.

The file names its circuit (``circuit:``, default ``pump-valve-cylinder``, paper 002
Figure 1); the circuit (:mod:`sim.rigs.circuits`) fixes the roles the file must fill and
the component type of each.  Each role takes one component.

An optional ``effects:`` section adds named effects of the library
(:mod:`sim.components.effects`) to the circuit's bond graph: effect name →
``{parameters: {name: {value, unit, source}}}``; parameters left out keep their defaults
(a strength of 0 is the base rig).  The discrepancy workflow writes this section.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from sim.errors import ParameterError, RigFileError
from sim.fluid import FLUID_PARAMETERS, Fluid
from sim.params import Param, broken_relation
from sim.rigs.circuits import CIRCUITS, COMPONENT_TYPES, DEFAULT_CIRCUIT, Circuit, get_circuit
from sim.units import to_si, unit_suffix

__all__ = ["CIRCUITS", "COMPONENT_TYPES", "SCHEMA", "RigSpec", "validate_rig_document"]

SCHEMA = "hydrodiag.rig/1"


@dataclass
class Quantity:
    """A parameter value in SI with the unit it was written in and its source."""

    value: float
    unit: str
    source: str = ""


@dataclass
class RigSpec:
    """A validated rig description (all values SI).

    Attributes
    ----------
    name
        Short identifier (``paper002-reference``).
    title, description
        Free text.
    fluid
        Fluid parameters by name (see :data:`sim.fluid.FLUID_PARAMETERS`).
    components
        Role → (type, parameter name → :class:`Quantity`).
    condition
        Default operating condition (load force [N], back-pressure [Pa], oil temperature [°C]).
    circuit
        The circuit the file names (:mod:`sim.rigs.circuits`); default ``pump-valve-cylinder``.
    effects
        Library effect name → parameter name → :class:`Quantity` (the ``effects:`` section;
        parameters not given keep their declared defaults).
    document
        The document as given (kept for storage and round trips).
    """

    name: str
    title: str
    description: str
    fluid: dict[str, Quantity]
    components: dict[str, tuple[str, dict[str, Quantity]]]
    condition: dict[str, Quantity]
    document: dict[str, Any] = field(repr=False, default_factory=dict)
    circuit: Circuit = field(default_factory=lambda: CIRCUITS[DEFAULT_CIRCUIT])
    effects: dict[str, dict[str, Quantity]] = field(default_factory=dict)

    def values(self) -> dict[str, float]:
        """All component and effect parameters as ``role.name`` / ``effect.name → SI value``."""
        out = {f"{role}.{k}": q.value for role, (_, ps) in self.components.items()
               for k, q in ps.items()}
        out.update({f"{eff}.{k}": q.value for eff, ps in self.effects.items()
                    for k, q in ps.items()})
        return out

    def fluid_model(self) -> Fluid:
        """The oil of the ``fluid:`` section (SI values) as the simulation uses it."""
        return Fluid(**{k: q.value for k, q in self.fluid.items()})

    @property
    def effect_types(self) -> tuple[str, ...]:
        """Names of the effects of the ``effects:`` section, sorted (the model cache key)."""
        return tuple(sorted(self.effects))

    def to_document(self) -> dict[str, Any]:
        """The rig document (as given, validated)."""
        return dict(self.document)


def _quantity(raw: Any, decl: Param, field_path: str) -> Quantity:
    if not isinstance(raw, Mapping):
        raise RigFileError("expected a mapping {value, unit, source}", field=field_path)
    if "value" not in raw:
        raise RigFileError("missing 'value'", field=f"{field_path}.value")
    if "unit" not in raw:
        raise RigFileError(f"missing 'unit' (expected {decl.unit})", field=f"{field_path}.unit")
    value = raw["value"]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise RigFileError(f"value must be a number, got {value!r}", field=f"{field_path}.value")
    if not math.isfinite(float(value)):
        raise RigFileError("value must be finite", field=f"{field_path}.value")
    try:
        si = to_si(float(value), str(raw["unit"]), decl.unit, field=f"{field_path}.unit")
    except ParameterError as exc:
        raise RigFileError(exc.message, field=exc.field) from None
    try:
        check_bounds(si, decl, field_path)
    except RigFileError as exc:
        if str(raw["unit"]) == decl.unit:
            raise
        # the bound is in SI; say the value as the document wrote it too (a user pass
        # read "> 0 m^3/rad" for a Vp their file states in m³/rev)
        raise RigFileError(f"{exc.message} (written {float(value):g} {raw['unit']})",
                           field=exc.field) from None
    return Quantity(si, str(raw["unit"]), str(raw.get("source", "")))


def check_bounds(value: float, decl: Param, field_path: str) -> None:
    """Raise :class:`RigFileError` if ``value`` [SI] is outside ``decl``'s bounds."""
    lo, hi = decl.lower, decl.upper
    unit = unit_suffix(decl.unit)
    if not math.isfinite(value):
        # every comparison with NaN is false: a NaN load ran the solver from its last
        # guess and returned that operating point (a library user's pass)
        raise RigFileError(f"{decl.description} must be a finite number (in{unit or ' 1'}), "
                           f"got {value}", field=field_path)
    if lo is not None and (value < lo or (value == lo and not decl.lower_inclusive)):
        rel = "≥" if decl.lower_inclusive else ">"
        raise RigFileError(f"{decl.description} must be {rel} {lo:g}{unit}, got {value:g}",
                           field=field_path)
    if hi is not None and value > hi:
        raise RigFileError(f"{decl.description} must be ≤ {hi:g}{unit}, got {value:g}",
                           field=field_path)


def _parameter_block(raw: Any, decls: tuple[Param, ...], path: str, *, partial: bool,
                     strict: bool = False) -> dict[str, Quantity]:
    if not isinstance(raw, Mapping):
        raise RigFileError("expected a mapping of parameters", field=path)
    known = {d.name: d for d in decls}
    for key in raw:
        if key not in known:
            raise RigFileError(f"unknown parameter {key!r} (known: {', '.join(known)})",
                               field=f"{path}.{key}")
    out: dict[str, Quantity] = {}
    for d in decls:
        if d.name not in raw:
            if partial:
                continue
            raise RigFileError(f"missing parameter {d.name!r} ({d.description}, {d.unit})",
                               field=f"{path}.{d.name}")
        if strict and isinstance(raw[d.name], Mapping):
            _known_keys(raw[d.name], QUANTITY_KEYS, f"{path}.{d.name}")
        out[d.name] = _quantity(raw[d.name], d, f"{path}.{d.name}")
    return out


#: longest name and title of a stored rig [characters] (its store's columns)
NAME_LENGTH, TITLE_LENGTH = 100, 200
#: keys a rig document may have, at the top, in a component and in a parameter
DOCUMENT_KEYS = ("schema", "name", "title", "description", "circuit", "fluid", "components",
                 "condition", "effects")
COMPONENT_KEYS = ("type", "parameters")
QUANTITY_KEYS = ("value", "unit", "source")


def _known_keys(raw: Mapping[str, Any], known: tuple[str, ...], path: str) -> None:
    """Refuse a key of ``raw`` not in ``known``, naming it and the close known one."""
    for key in raw:
        if key not in known:
            close = difflib.get_close_matches(str(key), known, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise RigFileError(f"unknown key {key!r} (known: {', '.join(known)}){hint}",
                               field=f"{path}.{key}" if path else str(key))


def validate_rig_document(doc: Mapping[str, Any], *, strict: bool = False) -> RigSpec:
    """Validate a rig document and convert it to SI.

    Parameters that break their component's geometry (a rod thicker than the bore, a
    clearance wider than the radius: :attr:`Circuit.relations`) are refused on every read:
    no model of them can be simulated (a negative annulus).  ``strict`` (a document being
    stored: ``POST``/``PUT /rigs``, ``hydrodiag rigs add``) also refuses keys the schema
    does not know (at the top, in a component, in a parameter) and values past a
    plausibility bound (:func:`sim.params.at_most`: a bore of 63 "m").  Documents already
    stored are read without it, so that one stored before a bound still loads.

    Raises
    ------
    RigFileError
        Naming the field and the reason.
    """
    if not isinstance(doc, Mapping):
        raise RigFileError("a rig document must be a mapping", field="")
    if strict:
        _known_keys(doc, DOCUMENT_KEYS, "")
    if doc.get("schema") != SCHEMA:
        raise RigFileError(f"expected schema {SCHEMA!r}, got {doc.get('schema')!r}",
                           field="schema")
    name = doc.get("name")
    if not isinstance(name, str) or not name.strip():
        raise RigFileError("a non-empty name is required", field="name")
    if strict:
        for key, most in (("name", NAME_LENGTH), ("title", TITLE_LENGTH)):
            text = doc.get(key, "")
            if not isinstance(text, str) or len(text.strip()) > most or not (
                    text.isprintable()):
                raise RigFileError(f"the {key} is text of at most {most} printable "
                                   "characters", field=key)
    circuit = get_circuit(doc.get("circuit", DEFAULT_CIRCUIT))
    fluid = _parameter_block(doc.get("fluid", {}), FLUID_PARAMETERS, "fluid", partial=False,
                             strict=strict)
    if strict:  # the oil's own checks, which every simulation of the rig would fail on
        try:
            Fluid(**{k: q.value for k, q in fluid.items()})
        except ParameterError as exc:
            raise RigFileError(exc.message, field=exc.field) from None
    comps_raw = doc.get("components")
    if not isinstance(comps_raw, Mapping):
        raise RigFileError("a mapping of components is required", field="components")
    for role in comps_raw:
        if role not in circuit.roles:
            raise RigFileError(f"unknown role {role!r} in circuit {circuit.name} "
                               f"(roles: {', '.join(circuit.roles)})", field=f"components.{role}")
    components: dict[str, tuple[str, dict[str, Quantity]]] = {}
    for role, ctype in circuit.roles.items():
        path = f"components.{role}"
        raw = comps_raw.get(role)
        if raw is None:
            raise RigFileError(f"missing component for role {role!r} ({ctype})", field=path)
        if not isinstance(raw, Mapping):
            raise RigFileError("expected a mapping {type, parameters}", field=path)
        if raw.get("type") != ctype:
            raise RigFileError(f"role {role!r} takes a {ctype!r}, got {raw.get('type')!r}",
                               field=f"{path}.type")
        if strict:
            _known_keys(raw, COMPONENT_KEYS, path)
        params = _parameter_block(raw.get("parameters", {}), COMPONENT_TYPES[ctype].PARAMETERS,
                                  f"{path}.parameters", partial=False, strict=strict)
        # the geometry (a rod thicker than the bore: a negative annulus) on every read, the
        # plausibility bounds only strictly: a 70 mm rod in a 63 mm bore compiled non-strict
        # and ran a "stall" with A1 < 0 (a library user's pass), where no stored document
        # can have been simulated right; a bound newer than a stored document is no such case
        relations = [r for r in circuit.relations(role) if strict or not r.bound]
        if broken := broken_relation(relations, {k: q.value for k, q in params.items()}):
            raise RigFileError(broken.text, field=f"{path}.parameters.{broken.name}")
        components[role] = (ctype, params)
    condition = _parameter_block(doc.get("condition", {}), circuit.condition, "condition",
                                 partial=True, strict=strict)
    effects = _effects_block(doc.get("effects", {}), circuit, strict=strict)
    return RigSpec(name.strip(), str(doc.get("title", "")), str(doc.get("description", "")),
                   fluid, components, condition, document=dict(doc), circuit=circuit,
                   effects=effects)


def _effects_block(raw: Any, circuit: Circuit, *, strict: bool = False
                   ) -> dict[str, dict[str, Quantity]]:
    """Validate the optional ``effects:`` section (module docstring)."""
    from sim.components.effects import get_effect

    if raw is None:
        return {}
    if not isinstance(raw, Mapping):
        raise RigFileError("expected a mapping effect name → {parameters}", field="effects")
    out: dict[str, dict[str, Quantity]] = {}
    for name, body in raw.items():
        path = f"effects.{name}"
        effect = get_effect(name, circuit.name, field=path)
        if not isinstance(body, Mapping):
            raise RigFileError("expected a mapping {parameters}", field=path)
        _known_keys(body, ("parameters",), path)
        out[str(name)] = _parameter_block(body.get("parameters", {}), effect.parameters,
                                          f"{path}.parameters", partial=True, strict=strict)
    return out
