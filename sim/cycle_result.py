"""What a cycle run returns: phase summaries, the solver's report and the cycle result.

Results of :func:`sim.cycle.run_cycle` (paper 002 §3): the phase averages a rig reads with its
terminal switches and meters (keys and units :data:`SUMMARY_UNITS`), how the run was integrated
and the error it reached, and the optional time series.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pandas as pd

__all__ = ["SUMMARY_UNITS", "CycleResult", "PhaseSummary", "SolverReport"]

#: unit of each phase-summary field
SUMMARY_UNITS: dict[str, str] = {
    "duration": "s",
    "speed": "m/s",
    "P_pump": "Pa",
    "P_valve_P": "Pa",
    "P1": "Pa",
    "P2": "Pa",
    "Q_cyl_leak": "m^3/s",
    "Q_valve_leak": "m^3/s",
    "Q_pump_leak": "m^3/s",
    "Q_relief": "m^3/s",
    "Q_meter_B": "m^3/s",
    "Q_meter_C": "m^3/s",
    "Q_throttle_H": "m^3/s",
    "Q_throttle_I": "m^3/s",
    "F_friction": "N",
}


@dataclass
class PhaseSummary:
    """Averages of one phase (keys and units: :data:`SUMMARY_UNITS`).

    Attributes
    ----------
    phase
        ``"working"`` or ``"return"``.
    values
        The phase's readings: averages over the middle of a completed stroke's travel, or
        over the settled last half of a stroke that stalled or crept [SI].
    completed
        Whether the piston reached its end of stroke within the phase's time limit.
    lowest
        Lowest value of each pressure output over the whole phase, transients included
        [Pa] (empty for the steady path, which has no transient).
    """

    phase: str
    values: dict[str, float]
    completed: bool
    lowest: dict[str, float] = field(default_factory=dict)

    def __getitem__(self, key: str) -> float:
        return self.values[key]


@dataclass
class SolverReport:
    """Integration of a cycle: method, tolerance, work and the error reached.

    Attributes
    ----------
    method
        ``"rodas4"`` or ``"ros2"``.
    rtol
        Relative tolerance of the run whose result is returned [-].
    rejected
        Rejected steps, both phases [-].
    nfev
        Right-hand-side evaluations, both phases, Jacobians included (RODAS4) [-].
    error_sigma
        Estimated error per controlled output in units of its σ (maximum over the output
        times, :func:`sim.solver.noise.error_estimate`) [-]; ``None`` without estimate.
    target_sigma
        Error target per controlled output in units of its σ [-]; ``None`` without one.
    sigma
        σ of each controlled output [output unit].
    switch_time_error
        Estimated error of the working → return switch time [s].
    tries
        Tolerances tried by the noise-accurate mode before one met the targets [-].
    """

    method: str
    rtol: float
    rejected: int = 0
    nfev: int = 0
    error_sigma: dict[str, float] | None = None
    target_sigma: dict[str, float] | None = None
    sigma: dict[str, float] | None = None
    switch_time_error: float | None = None
    tries: int = 1


@dataclass
class CycleResult:
    """Result of :func:`run_cycle`.

    Attributes
    ----------
    working, return_
        Phase summaries.
    velocity_ratio
        Working-phase speed / return-phase speed [-] (paper 002 §3).
    timeseries
        Table with one row per accepted solver step, or per point of the sampling grid,
        and units in the column names (``None`` when not requested).
    steps
        Accepted solver steps of each phase.
    solver
        How the run was integrated and the error it reached.
    """

    working: PhaseSummary
    return_: PhaseSummary
    velocity_ratio: float
    timeseries: pd.DataFrame | None = None
    steps: dict[str, int] = field(default_factory=dict)
    solver: SolverReport | None = None

    def summary(self) -> dict[str, float]:
        """Flat summary, keys ``phase.quantity [unit]`` plus ``velocity_ratio [-]``."""
        out: dict[str, float] = {}
        for ph in (self.working, self.return_):
            for k, v in ph.values.items():
                out[f"{ph.phase}.{k} [{SUMMARY_UNITS[k]}]"] = v
        out["velocity_ratio [-]"] = self.velocity_ratio
        return out
