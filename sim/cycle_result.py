"""What a cycle run returns: phase summaries, the solver's report and the cycle result.

Results of :func:`sim.cycle.run_cycle` (paper 002 §3): the phase averages a rig reads with its
terminal switches and meters (keys and units :data:`SUMMARY_UNITS`), how the run was integrated
and the error it reached, and the optional time series.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import pandas as pd

__all__ = ["SUMMARY_UNITS", "VACUUM_GAUGE", "CycleResult", "PhaseSummary", "SolverReport"]

#: Vacuum as a gauge pressure [Pa]: −1 bar; below it a pressure is impossible (the model
#: has no cavitation) and a reading is refused (:mod:`diagnostics.measurement`).
VACUUM_GAUGE = -1.0e5

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

    def notes(self) -> list[str]:
        """What a reader of the result must know that its numbers do not say (``/simulate``
        answers them; a library user met a chamber at −15.7 bar gauge without a word).

        * A stroke that did not reach its end within the phase's time limit: the piston
          stalled on a load it cannot push, or crept; its averages are the settled state
          (the last half of the phase, :mod:`sim.phase_reading`), and a return stroke after
          a stalled working stroke starts where the piston stopped: it is not a stroke.
        * A gauge pressure below vacuum (:data:`VACUUM_GAUGE`, −1 bar) in a phase average
          or anywhere in the phase (each phase's lowest pressure is kept whether or not the
          time series was asked for).  The bond-graph model has no cavitation (the oil's
          pressure may fall without bound), so an overrunning load, or the switch-over of a
          transient, can drive a chamber to pressures oil cannot hold; the numbers there
          are reported, not physical.
        """
        notes: list[str] = []
        if not self.working.completed:
            notes.append(
                "the working stroke did not reach its end"
                f"{self._within(self.working['duration'])} "
                f"(creep speed {self.working['speed']:.3g} m/s): the piston stalled on a load "
                "it cannot push, or crept; its averages are the settled state (the last half "
                "of the phase), and the return stroke starts where the piston stopped, so its "
                "averages and the velocity ratio are not those of a stroke")
        if not self.return_.completed:
            notes.append(
                "the return stroke did not reach its end"
                f"{self._within(self.return_['duration'])} "
                f"(creep speed {self.return_['speed']:.3g} m/s): the piston stalled or crept; "
                "its averages are the settled state (the last half of the phase)")
        lows: dict[str, float] = {}
        for phase in (self.working, self.return_):
            # a transient's lowest pressures (every point the series has, and the solver's
            # steps when none was asked for); the steady path's phase averages
            found = ({f"{name} [Pa]": v for name, v in phase.lowest.items()} if phase.lowest
                     else {f"{phase.phase}.{k} [Pa]": v for k, v in phase.values.items()
                           if SUMMARY_UNITS.get(k) == "Pa"})
            for key, value in found.items():
                if math.isfinite(value) and value < VACUUM_GAUGE:
                    lows[key] = min(value, lows.get(key, value))
        if lows:
            notes.append("below vacuum (-1 bar gauge), where the model has no cavitation and "
                         "the oil's pressure is not physical: " + ", ".join(
                             f"{name.removesuffix(' [Pa]')} reaches {value / 1e5:.4g} bar "
                             f"gauge ({value:.4g} Pa)" for name, value in lows.items()))
        return notes

    def _within(self, duration: float) -> str:
        """" in 2.5 s" for a transient's phase (the time it ran); nothing for the steady
        path, whose duration is the whole stroke's time at its creep, infinite for a stall
        (it read "in inf s": a rig author's pass)."""
        return f" in {duration:.4g} s" if self.solver is not None and math.isfinite(duration) \
            else ""

    def summary(self) -> dict[str, float]:
        """Flat summary, keys ``phase.quantity [unit]`` plus ``velocity_ratio [-]``."""
        out: dict[str, float] = {}
        for ph in (self.working, self.return_):
            for k, v in ph.values.items():
                out[f"{ph.phase}.{k} [{SUMMARY_UNITS[k]}]"] = v
        out["velocity_ratio [-]"] = self.velocity_ratio
        return out
