"""Named fault scenarios of the paper-002 rig, as parameter overrides.

A scenario is a rig plus overrides plus an operating condition.  The named faults of the
project brief, with the nominal values they start from:

==================  ====================================  =====================================
name                override                              physical meaning
==================  ====================================  =====================================
``healthy``         none                                  nominal clearances
``worn_piston``     ``cylinder.cc`` × 120/83               worn piston seal (paper 002 Table 2)
``worn_spool``      ``valve.cv`` × 60/34                   worn valve spool (paper 002 Table 3)
``worn_pump``       ``pump.Rlp`` ÷ 3                       pump internal leakage ×3
``relief_drift``    ``relief.Pset`` × 0.9                  relief setting −10 %
==================  ====================================  =====================================

Every fault is a wear of the rig it is run on: the clearances grow by the paper's ratios
(83 → 120 µm, 34 → 60 µm on the paper-002 rig, whose values they are exactly; leakage
×3.0 and ×5.5 at a given Δp, eqs. 19, 23), as the pump and relief faults scale theirs.
Absolute clearances set a "worn piston" of 64× the leakage on a rig with a 30 µm seal and
a tighter one, less leakage, on a rig of 130 µm (a rig author's pass).
"""

from __future__ import annotations

from sim.errors import InputError
from sim.rigs.assembly import Rig

__all__ = ["FAULTS", "FAULT_SUMMARY", "fault_help", "fault_overrides"]

FAULTS: tuple[str, ...] = ("healthy", "worn_piston", "worn_spool", "worn_pump", "relief_drift")

#: what each named fault sets, in the words of the table above (help texts)
FAULT_SUMMARY: dict[str, str] = {
    "healthy": "no override",
    "worn_piston": "cylinder.cc × 120/83, 120 µm on the paper rig",
    "worn_spool": "valve.cv × 60/34, 60 µm on the paper rig",
    "worn_pump": "pump.Rlp ÷ 3, leakage ×3",
    "relief_drift": "relief.Pset × 0.9",
}


def fault_help() -> str:
    """The named faults with what each sets, for a help text:
    ``"healthy (no override), worn_piston (cylinder.cc × 120/83, 120 µm on the paper rig), …"``."""
    return ", ".join(f"{name} ({FAULT_SUMMARY[name]})" for name in FAULTS)


def fault_overrides(rig: Rig, fault: str) -> dict[str, float]:
    """Overrides (``role.name`` → SI value) of the named fault on ``rig``."""
    base = rig.base
    table = {
        "healthy": {},
        "worn_piston": {"cylinder.cc": 120e-6 * (base["cylinder.cc"] / 83e-6)},
        "worn_spool": {"valve.cv": 60e-6 * (base["valve.cv"] / 34e-6)},
        "worn_pump": {"pump.Rlp": base["pump.Rlp"] / 3.0},
        "relief_drift": {"relief.Pset": base["relief.Pset"] * 0.9},
    }
    if fault not in table:
        raise InputError(f"unknown fault {fault!r} (known: {', '.join(FAULTS)})", field="fault")
    return dict(table[fault])
