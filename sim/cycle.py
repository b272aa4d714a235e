"""The working + return cycle of a rig (paper 002 §3), transient.

Working phase: spool at N = +1 (P→A, B→T), the load acts, the piston extends from the
chamber-1 end stop until it reaches the stroke.  Return phase: spool at N = −1, no load
(eq. 52), the piston retracts to x = 0, starting from the state the working phase ended
in.  Each phase ends on an event (the piston reaching its end of stroke, as the rig's
terminal switches 24/25 do) or at ``t_max`` if the piston stalls.

Phase averages: the speed is ``stroke / duration`` (what a rig measures with its terminal
switches); pressures and flows are time averages over the middle 80 % of the stroke,
where the paper's meters are read (start-up and end-stop transients left out).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
import pandas as pd

from sim.errors import SimulationError
from sim.rigs.assembly import Condition, Rig

__all__ = ["PHASES", "SUMMARY_UNITS", "CycleResult", "PhaseSummary", "run_cycle"]

Arr = npt.NDArray[np.float64]

PHASES = ("working", "return")

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
    """Averages of one phase (keys and units: :data:`SUMMARY_UNITS`)."""

    phase: str
    values: dict[str, float]
    completed: bool

    def __getitem__(self, key: str) -> float:
        return self.values[key]


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
        Table with one row per accepted solver step and units in the column names
        (``None`` when not requested).
    steps
        Accepted solver steps of each phase.
    """

    working: PhaseSummary
    return_: PhaseSummary
    velocity_ratio: float
    timeseries: pd.DataFrame | None = None
    steps: dict[str, int] = field(default_factory=dict)

    def summary(self) -> dict[str, float]:
        """Flat summary, keys ``phase.quantity [unit]`` plus ``velocity_ratio [-]``."""
        out: dict[str, float] = {}
        for ph in (self.working, self.return_):
            for k, v in ph.values.items():
                out[f"{ph.phase}.{k} [{SUMMARY_UNITS[k]}]"] = v
        out["velocity_ratio [-]"] = self.velocity_ratio
        return out


def _phase_settings(rig: Rig, phase: str) -> dict[str, float]:
    stroke = rig.base["cylinder.stroke"]
    if phase == "working":
        return {"valve.N": 1.0, "cylinder.x_init": 0.0}
    return {"valve.N": -1.0, "load.force": 0.0, "load.back_pressure": 0.0,
            "cylinder.x_init": stroke}


def phase_params(rig: Rig, phase: str, overrides: Mapping[str, float] | None,
                 condition: Condition) -> Arr:
    """Parameter vector of one phase."""
    if phase not in PHASES:
        raise ValueError(f"unknown phase {phase!r}")
    return rig.params(overrides, condition, _phase_settings(rig, phase))


def _averages(rig: Rig, t: Arr, y: Arr, p: Arr) -> dict[str, float]:
    """Time averages of the outputs over the middle of the stroke (10-90 % of the travel).

    A meter on the rig is read while the piston moves steadily; the start-up transient
    (pressure build-up, flow reversal in the hoses) and the arrival at the end stop are
    left out, as a reader of the paper's traces does.  Falls back to the whole phase if
    the piston travelled too little to have a middle.
    """
    out = rig.model.outputs(t, y, p)
    x = y[:, rig.model.state_index("cylinder.x")]
    travel = np.abs(x - x[0])
    total = travel[-1]
    sel = (travel >= 0.1 * total) & (travel <= 0.9 * total)
    if total <= 0 or sel.sum() < 3:
        sel = np.ones(t.size, dtype=bool)
    ts = t[sel]
    span = ts[-1] - ts[0]
    res: dict[str, float] = {}
    for j, name in enumerate(rig.model.output_names):
        if name in SUMMARY_UNITS:
            col = out[sel, j]
            res[name] = float(np.trapezoid(col, ts) / span) if span > 0 else float(col[0])
    return res


def run_cycle(rig: Rig, overrides: Mapping[str, float] | None = None,
              condition: Condition | None = None, *, rtol: float = 1e-3,
              t_max: float | None = None, timeseries: bool = True) -> CycleResult:
    """Simulate one working + return cycle.

    Parameters
    ----------
    rig
        The rig.
    overrides
        Parameter overrides ``role.name → SI value`` (fault scenario).
    condition
        Operating condition (defaults: the rig file's).
    rtol
        Relative tolerance of the integrator.  1e-3 resolves the start-up and switching
        transients well enough that phase speeds agree with 1e-5 to those at 1e-5
        (``make bench`` prints the comparison).
    t_max
        Longest phase [s]; default 20× the stroke time at the pump's geometric flow.
    timeseries
        Whether to return the time series table.

    Raises
    ------
    SimulationError
        If the solver fails.
    """
    cond = condition if condition is not None else rig.default_condition()
    m = rig.model
    stroke = rig.base["cylinder.stroke"]
    y = None
    frames: list[pd.DataFrame] = []
    phases: list[PhaseSummary] = []
    steps: dict[str, int] = {}
    t0 = 0.0
    for phase in PHASES:
        p = phase_params(rig, phase, overrides, cond)
        if t_max is None:
            qp = p[m.param_index("pump.speed")] * p[m.param_index("pump.Vp")]
            area = min(p[m.param_index("cylinder.A1")], p[m.param_index("cylinder.A2")])
            t_lim = 20.0 * stroke * area / qp
        else:
            t_lim = t_max
        if y is None:
            y = m.initial_state(p)
        direction = 1.0 if phase == "working" else -1.0
        level = stroke if phase == "working" else 0.0
        res = m.integrate(y, p, t0 + t_lim, t0=t0, rtol=rtol,
                          event=("cylinder.x", level, direction))
        if not res.success:
            raise SimulationError(f"{phase} phase: integration failed (status {res.status}) "
                                  f"at t = {res.t[-1]:.4g} s")
        completed = res.status == 1
        values = _averages(rig, res.t, res.y, p)
        duration = float(res.t[-1] - res.t[0])
        travelled = abs(float(res.y[-1, m.state_index("cylinder.x")]
                              - res.y[0, m.state_index("cylinder.x")]))
        values["duration"] = duration
        values["speed"] = travelled / duration if duration > 0 else 0.0
        phases.append(PhaseSummary(phase, values, completed))
        steps[phase] = int(res.t.size)
        if timeseries:
            out = m.outputs(res.t, res.y, p)
            df = pd.DataFrame(out, columns=[f"{n} [{u}]" for n, u in
                                            zip(m.output_names, m.output_units, strict=True)])
            df.insert(0, "t [s]", res.t)
            df.insert(1, "phase", phase)
            frames.append(df if not frames else df.iloc[1:])  # first row = previous last
        y = res.y[-1].copy()
        t0 = float(res.t[-1])
    w, r = phases
    ratio = w["speed"] / r["speed"] if r["speed"] > 0 else float("nan")
    ts = pd.concat(frames, ignore_index=True) if timeseries else None
    return CycleResult(w, r, ratio, ts, steps)
