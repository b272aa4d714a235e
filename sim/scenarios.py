"""Named fault scenarios of the paper-002 rig, as parameter overrides.

A scenario is a rig plus overrides plus an operating condition.  The named faults of the
project brief, with the nominal values they start from:

==================  ====================================  =====================================
name                override                              physical meaning
==================  ====================================  =====================================
``healthy``         none                                  nominal clearances
``worn_piston``     ``cylinder.cc`` = 120 µm (83 nominal)  worn piston seal (paper 002 Table 2)
``worn_spool``      ``valve.cv`` = 60 µm (34 nominal)      worn valve spool (paper 002 Table 3)
``worn_pump``       ``pump.Rlp`` ÷ 3                       pump internal leakage ×3
``relief_drift``    ``relief.Pset`` × 0.9                  relief setting −10 %
==================  ====================================  =====================================
"""

from __future__ import annotations

from sim.errors import InputError
from sim.rigs.assembly import Rig

__all__ = ["FAULTS", "FAULT_SUMMARY", "fault_help", "fault_overrides"]

FAULTS: tuple[str, ...] = ("healthy", "worn_piston", "worn_spool", "worn_pump", "relief_drift")

#: what each named fault sets, in the words of the table above (help texts)
FAULT_SUMMARY: dict[str, str] = {
    "healthy": "no override",
    "worn_piston": "cylinder.cc = 120 µm",
    "worn_spool": "valve.cv = 60 µm",
    "worn_pump": "pump.Rlp ÷ 3, leakage ×3",
    "relief_drift": "relief.Pset × 0.9",
}


def fault_help() -> str:
    """The named faults with what each sets, for a help text:
    ``"healthy (no override), worn_piston (cylinder.cc = 120 µm), …"``."""
    return ", ".join(f"{name} ({FAULT_SUMMARY[name]})" for name in FAULTS)


def fault_overrides(rig: Rig, fault: str) -> dict[str, float]:
    """Overrides (``role.name`` → SI value) of the named fault on ``rig``."""
    base = rig.base
    table = {
        "healthy": {},
        "worn_piston": {"cylinder.cc": 120e-6},
        "worn_spool": {"valve.cv": 60e-6},
        "worn_pump": {"pump.Rlp": base["pump.Rlp"] / 3.0},
        "relief_drift": {"relief.Pset": base["relief.Pset"] * 0.9},
    }
    if fault not in table:
        raise InputError(f"unknown fault {fault!r} (known: {', '.join(FAULTS)})", field="fault")
    return dict(table[fault])
