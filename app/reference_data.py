"""Reference data preloaded into an empty store: the paper-002 throttle equivalence tables.

Source: P. Athanasatos, D. Koulocheris, Th. Costopoulos, V. Spitas, "Experimental
Verification of Fault Predictions in High Pressure Hydraulic Systems", Modern Mechanical
Engineering 4 (2014) 67-81, §2.7, Tables 2 and 3, as repaired in ``shared/seeds/README.md``
(the copy lost its digits 1 and 3).  Measured with the load control valve at 10 bar
back-pressure (2.1 kN); the paper states no temperature, so the rig's default oil
temperature of 40 °C is used.

Table 3 (throttle I, bypassing the 4/2 valve) is legible with good confidence; its last
clearance (73 µm) follows from Qlv ∝ cv³.  Table 2 (throttle H, bypassing the cylinder)
is less certain and its last clearance is cut off in the copy: it is left empty.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["REFERENCE_CALIBRATIONS", "REFERENCE_RIG_NAME", "ReferenceTable"]

#: Name of the reference rig in ``sim.rigs.reference_rig_document()``.
REFERENCE_RIG_NAME = "paper002-reference"

_SOURCE = (
    "Athanasatos et al., Modern Mechanical Engineering 4 (2014) 67-81, §2.7, Table {table} "
    "(digits repaired per shared/seeds/README.md); 10 bar back-pressure; temperature not "
    "stated in the paper, rig default 40 °C assumed"
)
_OPENINGS_TURNS = (0.0, 0.5, 1.0, 1.5, 2.0)


@dataclass(frozen=True, slots=True)
class ReferenceTable:
    """One published equivalence table (units in the attribute names)."""

    throttle: str
    component: str
    back_pressure_pa: float
    temperature_c: float
    openings_turns: tuple[float, ...]
    bypass_flows_m3s: tuple[float, ...]
    clearances_m: tuple[float | None, ...]
    source: str


REFERENCE_CALIBRATIONS: tuple[ReferenceTable, ...] = (
    ReferenceTable(
        throttle="I",
        component="valve",
        back_pressure_pa=1.0e6,
        temperature_c=40.0,
        openings_turns=_OPENINGS_TURNS,
        bypass_flows_m3s=(8.6e-6, 1.30e-5, 2.70e-5, 5.40e-5, 8.70e-5),
        clearances_m=(34e-6, 37e-6, 49e-6, 62e-6, 73e-6),
        source=_SOURCE.format(table=3),
    ),
    ReferenceTable(
        throttle="H",
        component="cylinder",
        back_pressure_pa=1.0e6,
        temperature_c=40.0,
        openings_turns=_OPENINGS_TURNS,
        bypass_flows_m3s=(1.80e-5, 3.5e-5, 7.00e-5, 8.20e-5, 1.05e-4),
        clearances_m=(83e-6, 103e-6, 123e-6, 139e-6, None),
        source=_SOURCE.format(table=2),
    ),
)
