"""Pump parameter sets and loss maps: named quantities, each with its unit.

A *parameter set* holds scalar coefficients (displacement, slip coefficient Cs, ...; paper
000 eqs. 6-19); a *loss map* holds axes and gridded values (flow loss over pressure and
speed, ...).  The store keeps them as given; ``diagnostics`` interprets them.
"""

from __future__ import annotations

from functools import partial
from typing import Annotated, Literal

from pydantic import (
    AfterValidator,
    ConfigDict,
    Field,
    StringConstraints,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from app.schemas.common import (
    MAX_ID,
    FiniteFloat,
    Page,
    PublicModel,
    RequestModel,
    UploadForm,
    not_nullable,
    reject_null,
)
from app.schemas.times import Timestamp
from sim.units import UNITS

__all__ = [
    "PumpBenchForm",
    "PumpSetCreate",
    "PumpSetKind",
    "PumpSetList",
    "PumpSetPublic",
    "PumpSetUpdate",
    "Quantity",
]

PumpSetKind = Literal["parameters", "loss_map"]
Name = Annotated[
    str, StringConstraints(min_length=1, max_length=100, pattern=r"^[A-Za-z0-9][A-Za-z0-9._-]*$")
]
QuantityName = Annotated[
    str, StringConstraints(min_length=1, max_length=64, pattern=r"^[A-Za-z][A-Za-z0-9_]*$")
]
Value = FiniteFloat | list[FiniteFloat] | list[list[FiniteFloat]]


def _rectangular(value: Value) -> Value:
    if isinstance(value, list) and value and isinstance(value[0], list):
        widths = {len(row) for row in value if isinstance(row, list)}
        if len(widths) != 1:
            raise ValueError("a 2-D value must be rectangular (rows of equal length)")
    return value


#: what a pump set's quantity may be written in: a unit :mod:`sim.units` knows, or ``SI``
#: (a fitted surface's coefficients, each in the SI unit of its term)
KNOWN_UNITS = frozenset({u for units in UNITS.values() for u in units} | {"SI"})


def _known_unit(unit: str) -> str:
    if unit not in KNOWN_UNITS:
        raise PydanticCustomError(
            "unknown_unit", "unknown unit {unit}: write it as hydrodiag's units are (Pa, bar, "
            "m^3/rad, cm^3/rev, m^3/s, L/min, rad/s, rpm, N*m, degC, 1 for dimensionless, SI "
            "for a surface's coefficients)", {"unit": repr(unit)})
    return unit


class Quantity(RequestModel):
    """A value (scalar, 1-D or 2-D array) with its unit."""

    value: Annotated[Value, AfterValidator(_rectangular)] = Field(
        description="Number, list or list of rows (a map), in the stated unit [unit]",
        examples=[1.47e-5, [0.0, 5.0e6, 1.0e7]],
    )
    unit: Annotated[str, StringConstraints(min_length=1, max_length=32),
                    AfterValidator(_known_unit)] = Field(
        description="Unit of the value, one hydrodiag knows (sim.units), '1' for "
        "dimensionless, 'SI' for a fitted surface's coefficients [-]",
        examples=["m^3/rev", "Pa", "1"],
    )
    description: Annotated[str, StringConstraints(max_length=500)] | None = Field(
        default=None,
        description="What the quantity is [-]",
        examples=["slip coefficient Cs, paper 000 eq. 6"],
    )


_QUANTITIES_EXAMPLE = {
    "displacement": {"value": 1.47e-5, "unit": "m^3/rev", "description": "derived capacity"},
    "Cs": {"value": 2.1e-9, "unit": "1", "description": "slip coefficient, eq. 6"},
}

_name = partial(
    Field, description="Unique name of the set [-]", examples=["gear-14.7cc-tellus46"]
)
_kind = partial(
    Field, description="'parameters' (coefficients) or 'loss_map' (gridded values) [-]",
    examples=["parameters"],
)
_rig_id = partial(
    Field, ge=1, le=MAX_ID, description="Rig the pump belongs to; null for a pump on its own [-]",
    examples=[1],
)
_pump = partial(
    Field, description="Pump model and size [-]",
    examples=["external gear pump, 14.7 cm³/rev"],
)
_source = partial(
    Field, description="Where the numbers come from [-]",
    examples=["paper 000, ISO 4409 bench test at 22 and 60 °C"],
)
_quantities = partial(
    Field, min_length=1, max_length=500,
    description="Named quantities, each {value, unit, description} [-]",
    examples=[_QUANTITIES_EXAMPLE],
)
PumpLabel = Annotated[str, StringConstraints(min_length=1, max_length=200)]
SourceNote = Annotated[str, StringConstraints(max_length=2000)]


#: quantities that are a size of something: a displacement, a density, a bulk modulus must
#: be positive, a standard error not negative (PATCH stored a negative D: a user pass)
_POSITIVE = ("D", "D_per_rev", "displacement", "rho", "beta_ef")
#: paper 000's loss coefficients given as one number (eqs. 6, 16: a slip or friction
#: coefficient below zero makes the pump deliver or turn for nothing; a pump maker's pass
#: stored Cs = −5)
_NOT_NEGATIVE = ("D_std", "Cs", "Cst", "Cv", "Cf")


def _check_physical(quantities: dict[str, Quantity] | None) -> dict[str, Quantity] | None:
    for name, q in (quantities or {}).items():
        value = q.value
        if not isinstance(value, int | float):
            continue
        if name in _POSITIVE and not value > 0:
            raise PydanticCustomError("not_positive", "quantities.{name}: must be > 0, got "
                                      "{value}", {"name": name, "value": value})
        if name in _NOT_NEGATIVE and value < 0:
            raise PydanticCustomError("negative", "quantities.{name}: must be ≥ 0, got "
                                      "{value}", {"name": name, "value": value})
    return quantities


class PumpSetCreate(RequestModel):
    """A new pump parameter set or loss map."""

    name: Name = _name()
    kind: PumpSetKind = _kind()
    rig_id: int | None = _rig_id(default=None)
    pump: PumpLabel = _pump()
    source: SourceNote | None = _source(default=None)
    quantities: dict[QuantityName, Quantity] = _quantities()

    _physical = field_validator("quantities")(_check_physical)


_NOT_NULL = ("name", "kind", "pump", "quantities")



class PumpSetUpdate(RequestModel):
    """Changes to a pump set; fields left out stay; ``quantities`` replace all of them.

    ``rig_id`` and ``source`` may be set to null (detach from the rig, drop the note).
    """

    name: Name | None = _name(default=None)
    kind: PumpSetKind | None = _kind(default=None)
    rig_id: int | None = _rig_id(default=None)
    pump: PumpLabel | None = _pump(default=None)
    source: SourceNote | None = _source(default=None)
    quantities: dict[QuantityName, Quantity] | None = _quantities(default=None)

    model_config = ConfigDict(json_schema_extra=not_nullable(*_NOT_NULL))

    _not_null = field_validator(*_NOT_NULL)(reject_null)
    _physical = field_validator("quantities")(_check_physical)


class StoredQuantity(PublicModel):
    """A stored quantity as it was written (a set stored before units were checked reads
    back as it is, not as an error)."""

    value: Value = Field(description="Number, list or list of rows (a map), in the stated "
                         "unit [unit]", examples=[1.47e-5])
    unit: str = Field(description="Unit of the value [-]", examples=["m^3/rev"])
    description: str | None = Field(default=None, description="What the quantity is [-]",
                                    examples=["derived capacity"])


class PumpSetPublic(PublicModel):
    """A stored pump set."""

    id: int = Field(description="Pump set identifier [-]", examples=[1])
    name: str = _name()
    kind: PumpSetKind = _kind()
    rig_id: int | None = _rig_id()
    pump: str = _pump()
    source: str | None = _source()
    quantities: dict[str, StoredQuantity] = _quantities()
    created_at: Timestamp
    updated_at: Timestamp


class PumpSetList(Page[PumpSetPublic]):
    """A page of pump sets."""


#: the lowest oil viscosity a bench form takes [m²/s]: 2 cSt, where ASTM D341's Walther law
#: starts to hold (a hydraulic oil's data sheet gives 2-700 cSt); 4.6e-11 typed as "46 cSt
#: in m²/s" crashed the law (a verification pass)
OIL_NU_MIN = 2e-6


class PumpBenchForm(UploadForm):
    """Form fields sent with a bench CSV (``POST /pump-sets/bench``).

    The file part is let through and other unknown fields refused
    (:class:`~app.schemas.common.UploadForm`).
    """

    name: Name = _name()
    pump: PumpLabel = _pump()
    rig_id: int | None = Field(default=None, ge=1, le=MAX_ID,
                               description="Rig the pump belongs to [-]",
                               examples=[1])
    source: SourceNote | None = _source(default=None)
    displacement_m3_rad: FiniteFloat | None = Field(
        default=None, gt=0,
        description="Derived capacity D when known; from the data (Toet method) when "
        "left out [m³/rad]",
        examples=[2.34e-6],
    )
    displacement_std_m3_rad: FiniteFloat = Field(
        default=0.0, ge=0, description="Standard error of a given D [m³/rad]", examples=[0.0],
    )
    oil_nu40_m2_s: FiniteFloat | None = Field(
        default=None, ge=OIL_NU_MIN, le=1e-2,
        description="Kinematic viscosity of the bench's oil at 40 °C, from its data sheet, "
        "with oil_nu100_m2_s; left out: the default ISO VG 46 HM oil (46 cSt) [m²/s]. Cs and "
        "Cv scale with the viscosity assumed: an HV VG 46 (≈ 8 cSt at 100 °C) read with the "
        "default's 6.8 cSt gives Cs 14 % and Cv 17 % low from runs at 22 and 60 °C",
        examples=[4.6e-5],
    )
    oil_nu100_m2_s: FiniteFloat | None = Field(
        default=None, ge=OIL_NU_MIN, le=1e-2,
        description="Kinematic viscosity of the bench's oil at 100 °C, with oil_nu40_m2_s; "
        "left out: the default oil's 6.8 cSt [m²/s]",
        examples=[8.2e-6],
    )
    oil_rho15_kg_m3: FiniteFloat | None = Field(
        default=None, ge=600, le=1500,
        description="Density of the bench's oil at 15 °C; left out: 879 [kg/m³]",
        examples=[872.0],
    )

    @model_validator(mode="after")
    def _oil_pair(self) -> PumpBenchForm:
        given = (self.oil_nu40_m2_s is not None, self.oil_nu100_m2_s is not None)
        if given[0] != given[1]:
            missing = "oil_nu100_m2_s" if given[0] else "oil_nu40_m2_s"
            raise PydanticCustomError(
                "oil_pair", "an oil's viscosity needs both data-sheet points, at 40 and "
                "100 °C", {"unknown_field": missing})
        if (self.oil_nu40_m2_s is not None and self.oil_nu100_m2_s is not None
                and not self.oil_nu100_m2_s < self.oil_nu40_m2_s):
            raise PydanticCustomError(
                "oil_pair", "an oil is thinner at 100 °C than at 40 °C",
                {"unknown_field": "oil_nu100_m2_s"})
        return self
