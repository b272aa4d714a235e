"""One run of a fault scenario on a stored rig, and its time series as JSON, CSV or Parquet.

Used by ``POST /simulate`` and ``hydrodiag simulate``.  A scenario is the rig, the
overrides of a named fault (:func:`sim.scenarios.fault_overrides`) with the caller's
overrides over them, and an operating condition whose missing fields take the rig
document's defaults.

CSV: the summary comes first as ``# key = value`` lines (``pandas.read_csv(...,
comment="#")`` skips them), then the table with units in the column names.  Parquet: the
same table; the summary, rig and scenario are JSON in the file's key-value metadata under
``hydrodiag``.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import pandas as pd
from sqlalchemy.orm import Session

from app.schemas.simulate import ConditionSpec, SimulateRequest, SimulationPublic
from app.services.rig_cache import ResolvedRig, RigCache
from app.settings import Settings
from diagnostics.measurement import MIN_PRESSURE_READING
from diagnostics.table_files import PARQUET_METADATA_KEY, table_bytes  # read back there
from diagnostics.timeseries import CONDITION_CHANNELS
from sim.components.effects import EFFECTS
from sim.cycle import CycleResult, phase_params, run_cycle, stall_guard
from sim.errors import InputError, ParameterError, SimulationError, SolverLimitError
from sim.rigs import Condition, Rig
from sim.scenarios import fault_overrides
from sim.solver.limits import SolverLimits
from sim.solver.noise import NoiseAccuracy
from sim.steady import steady_cycle

__all__ = [
    "PARQUET_METADATA_KEY",
    "SimulationOutcome",
    "condition_notes",
    "condition_of",
    "limits_of",
    "public_of",
    "run_scenario",
    "simulate",
    "summary_of",
    "timeseries_csv",
    "timeseries_parquet",
    "timeseries_table",
]

#: grid of a RODAS4 run whose time series is not asked for [Hz]
SUMMARY_SAMPLE_RATE = 1000.0
#: most rows of a time series answered as JSON [-]: encoding 200,000 rows held the server's
#: interpreter ~4 s on 2 busy cores, and at 2.9 M rows the worker was killed mid-answer,
#: the connection dropped without a word (an edge pass); CSV and Parquet take up to the
#: ``sim_max_rows`` setting
JSON_MAX_ROWS = 100_000
#: the default of the ``sim_max_rows`` setting [-]
DEFAULT_MAX_ROWS = 1_000_000

#: sim's name of each condition field in error paths → the request's.
_CONDITION_FIELDS = {"condition.force": "condition.load"}


@dataclass
class SimulationOutcome:
    """A run and what it was run with."""

    resolved: ResolvedRig
    fault: str | None
    overrides: dict[str, float]
    condition: Condition
    method: str
    result: CycleResult

    def header(self) -> dict[str, Any]:
        """Rig, scenario and summary, JSON-ready (the CSV header, the Parquet metadata)."""
        return {
            "rig_id": self.resolved.rig_id, "rig_version": self.resolved.version,
            "rig": self.resolved.name, "fault": self.fault, "overrides": self.overrides,
            "condition": condition_dict(self.condition), "method": self.method,
            "summary": summary_of(self.result), "solver": _solver_public(self.result),
            "notes": self.notes(),
        }

    def condition_used(self) -> dict[str, float | None]:
        """The condition as run (:func:`condition_dict`), the pump speed the rig's or an
        override's where the condition gave none: the JSON answer's echo.  A file's
        header and condition columns keep the condition as given: a record read from it
        states a pump speed only where one was stated (a stated speed is a reading the
        diagnosis takes as measured)."""
        speed = self.overrides.get("pump.speed", self.resolved.rig.values().get("pump.speed"))
        return condition_dict(self.condition, speed)

    def notes(self) -> list[str]:
        """The result's physics notes, then the condition's (:func:`condition_notes`), then
        the error estimate's reach (:func:`estimate_note`)."""
        return [*self.result.notes(),
                *condition_notes(self.condition, self.resolved.rig.values()),
                *estimate_note(self.result)]


#: loosest tolerance at which the companion run's error estimate was found to hold [-]
ESTIMATE_RTOL = 1e-4


def estimate_note(result: CycleResult) -> list[str]:
    """A note when a run's error was estimated at a tolerance looser than
    :data:`ESTIMATE_RTOL`: the companion estimate assumes the error scales with the
    tolerance, which holds near the noise-accurate tolerances; at rtol 1e-3 it read P1
    0.28 σ where a converged run shows 0.73 σ, and a switch time 12× too good (a modelling
    engineer's pass)."""
    rep = result.solver
    if rep is None or rep.error_sigma is None or rep.rtol <= ESTIMATE_RTOL:
        return []
    return [f"the error estimate at rtol {rep.rtol:.3g} is optimistic: it assumes the error "
            f"scales with the tolerance, which holds at rtol ≤ {ESTIMATE_RTOL:g} (at 1e-3 it "
            "read a pressure's error 2.6× too small); leave rtol out for a noise-accurate run"]


def condition_notes(condition: Condition, values: Mapping[str, float]) -> list[str]:
    """Notes on a condition that looks like a unit slip, run as given: a load above zero
    but below a tenth of the seal's Coulomb friction ``cylinder.Fu`` [N] (paper 002 eqs.
    37, 51; kN typed as N: a 4.2
    N load ran without a word; a load of 100 N beside 136 N of friction is a light load,
    not a slip), a back-pressure above zero but below 0.1 bar (bar typed as Pa); a
    simulation engineer's pass."""
    notes = []
    friction = values.get("cylinder.Fu")
    if friction is not None and 0.0 < condition.load < 0.1 * friction:
        notes.append(f"a load of {condition.load:.4g} N is below a tenth of the seal's Coulomb "
                     f"friction ({friction:.4g} N): if it is in kN, give "
                     f"{condition.load * 1e3:.4g} N")
    if 0.0 < condition.back_pressure < MIN_PRESSURE_READING:
        notes.append(f"a back-pressure of {condition.back_pressure:.4g} Pa is below 0.1 bar: "
                     f"if it is in bar, give {condition.back_pressure * 1e5:.4g} Pa")
    # a rig version carrying a stated-condition correction (the discrepancy workflow's
    # load_scale, speed_offset) runs the condition corrected: say so, or the echoed
    # condition reads as the one applied (a stated-condition pass)
    stated = condition_dict(condition)
    for name, effect in EFFECTS.items():
        if effect.entry.stated is not None and any(k.startswith(f"{name}.") for k in values):
            note = effect.entry.stated(stated, values)
            if note is not None:
                notes.append(note)
    return notes


def condition_of(rig: Rig, spec: ConditionSpec) -> Condition:
    """The condition of ``spec``, with the rig document's defaults where it has none."""
    base = rig.default_condition()
    return Condition(
        load=base.load if spec.load is None else spec.load,
        back_pressure=base.back_pressure if spec.back_pressure is None else spec.back_pressure,
        oil_temperature=(base.oil_temperature if spec.oil_temperature is None
                         else spec.oil_temperature),
        pump_speed=spec.pump_speed,
    )


def condition_dict(condition: Condition, speed: float | None = None
                   ) -> dict[str, float | None]:
    """A condition as JSON: load [N], back_pressure [Pa], oil_temperature [°C],
    pump_speed [rad/s]; ``speed``: the pump speed it ran at where the condition left it to
    the rig (an answer's echo said "pump_speed": null; a user pass)."""
    return {"load": condition.load, "back_pressure": condition.back_pressure,
            "oil_temperature": condition.oil_temperature,
            "pump_speed": speed if condition.pump_speed is None else condition.pump_speed}


def summary_of(result: CycleResult) -> dict[str, float | None]:
    """The flat summary with ``None`` where a value is not finite (a stalled phase)."""
    return {k: (float(v) if math.isfinite(v) else None) for k, v in result.summary().items()}


def run_scenario(rig: Rig, overrides: dict[str, float], condition: Condition, *,
                 method: str, timeseries: bool = False, rtol: float | None = None,
                 solver: str = "rodas4", sample_rate: float | None = None,
                 accuracy: NoiseAccuracy | None = None,
                 limits: SolverLimits | None = None) -> CycleResult:
    """Run one scenario by the transient or the steady path.

    The transient is noise-accurate unless ``rtol`` is given (see
    :func:`sim.cycle.run_cycle`); ``limits`` bound its work.

    Raises
    ------
    ParameterError
        An override or the condition is out of bounds (``field`` as in the request).
    SolverLimitError
        The transient needs more than ``limits`` allow.
    InputError
        The steady path finds no operating point (``field`` ``method``).
    SimulationError
        The solver failed.
    """
    try:
        if method == "steady":
            try:
                return steady_cycle(rig, overrides, condition)
            except SimulationError as exc:
                # a property of the rig and the condition, not a failure of the service: a
                # rig stored with a 63 "m" bore answered 500 (an engineer's pass)
                raise InputError(f"{exc.message}: the steady path finds no operating point "
                                 "of this rig at this condition; method 'transient' shows "
                                 "what it does, and the rig's parameters (units) are worth a "
                                 "check", field="method") from None
        return run_cycle(rig, overrides, condition, rtol=rtol, method=solver,
                         accuracy=accuracy, sample_rate=sample_rate, timeseries=timeseries,
                         limits=limits)
    except ParameterError as exc:
        field = _CONDITION_FIELDS.get(exc.field or "", exc.field)
        raise ParameterError(exc.message, field=field) from None


def limits_of(settings: Settings) -> SolverLimits:
    """The solver limits of ``settings`` (``sim_max_steps``, ``sim_max_time``,
    ``sim_wall_clock``)."""
    return SolverLimits(max_steps=settings.sim_max_steps, max_sim_time=settings.sim_max_time,
                        wall_clock=settings.sim_wall_clock)


def _row_cap(request: SimulateRequest, max_rows: int) -> int:
    return min(max_rows, JSON_MAX_ROWS) if request.timeseries == "json" else max_rows


def _too_many_rows(rows: float, request: SimulateRequest, max_rows: int, *,
                   expected: bool) -> InputError:
    cap = _row_cap(request, max_rows)
    where = ("a JSON time series holds at most "
             f"{JSON_MAX_ROWS:,}; CSV or Parquet up to {max_rows:,} (HYDRODIAG_SIM_MAX_ROWS)"
             if request.timeseries == "json" and cap < max_rows
             else f"the service's limit is {cap:,} (HYDRODIAG_SIM_MAX_ROWS)")
    return InputError(f"this run's time series {'would have' if expected else 'has'} about "
                      f"{rows:,.0f} rows at {request.sample_rate:g} Hz: {where}; a lower "
                      "sample_rate takes fewer", field="sample_rate")


def _check_grid(rig: Rig, overrides: Mapping[str, float], condition: Condition,
                request: SimulateRequest, max_rows: int, limits: SolverLimits | None) -> None:
    """Refuse, before the run, a sampling grid with more rows than the cap: the steady
    path's stroke times (milliseconds to find) give the rows; a stalled stroke runs until
    the simulated-time limit.  A rig the steady path cannot solve is checked after the run.
    """
    if request.sample_rate is None or request.method != "transient":
        return
    try:
        steady = steady_cycle(rig, dict(overrides), condition)
    except (SimulationError, ParameterError):
        return
    longest = (limits or SolverLimits()).max_sim_time
    # a stalled or creeping stroke runs to its stall guard (20× its stroke time at the
    # pump's flow), not to the simulated-time limit: a stall counted 600 s and refused a
    # 2 kHz run as 1.2 M rows where it has 91 k (a verification pass)
    span = sum(min(float(phase["duration"]),
                   stall_guard(rig, phase_params(rig, name, overrides, condition),
                               phase=name), longest)
               for name, phase in (("working", steady.working), ("return", steady.return_)))
    rows = request.sample_rate * span
    if rows > _row_cap(request, max_rows):
        raise _too_many_rows(rows, request, max_rows, expected=True)


def _blamed_right(exc: InputError, request: SimulateRequest, from_fault: set[str]
                  ) -> InputError:
    """``exc`` naming what the request sent: a bound broken by the named fault's scaling is
    the ``fault``'s (it named ``overrides.cylinder.cc`` "with the overrides given" where none
    was sent), and a step below round-off under the tolerance chosen for a noise target is
    that target's (it named ``rtol``, not sent either; an edge pass)."""
    key = (exc.field or "").removeprefix("overrides.")
    if exc.field and exc.field.startswith("overrides.") and key in from_fault:
        return type(exc)(f"the fault {request.fault!r} scales {key} past its bounds on this "
                         f"rig: {exc.message.removesuffix(' (with the overrides given)')}",
                         field="fault")
    if isinstance(exc, SolverLimitError) and exc.field == "rtol" and request.rtol is None:
        targets = ([f"noise.{k}" for k in request.noise]
                   + [f"noise_fraction.{k}" for k in request.noise_fraction])
        if targets:
            return SolverLimitError(f"{exc.message}: the tolerance was chosen to meet "
                                    f"{', '.join(targets)}, which asks more than the solver "
                                    "can give; a looser target runs", field=targets[0])
    return exc


def simulate(session: Session, rigs: RigCache, request: SimulateRequest,
             limits: SolverLimits | None = None, *,
             max_rows: int = DEFAULT_MAX_ROWS) -> SimulationOutcome:
    """Run the scenario of ``request`` on its stored rig, within ``limits``.

    Raises
    ------
    NotFoundError
        Unknown rig or version.
    InputError
        A time series asked of the steady path, an unknown parameter, a value out of bounds,
        sampling asked of ROS2, a sampling grid of more than ``max_rows`` rows (JSON:
        :data:`JSON_MAX_ROWS`); :class:`~sim.errors.SolverLimitError` when the run needs
        more than ``limits`` allow.
    SimulationError
        The solver failed.
    """
    if request.timeseries is not None and request.method == "steady":
        raise InputError("the steady path has no time series; use method 'transient'",
                         field="timeseries")
    resolved = rigs.get(session, request.rig_id, request.rig_version)
    rig = resolved.rig
    overrides = fault_overrides(rig, request.fault) if request.fault else {}
    overrides.update(request.overrides)
    condition = condition_of(rig, request.condition)
    if request.solver == "ros2" and request.sample_rate is not None:
        raise InputError("sampling on a grid needs the dense output of 'rodas4'",
                         field="sample_rate")
    outputs = rig.model.output_names
    for field, given in (("noise", request.noise), ("noise_fraction", request.noise_fraction)):
        for name in given:  # a misspelt target ran at the defaults, silently (a modelling
            if name not in outputs:  # engineer's pass)
                near = difflib.get_close_matches(name, outputs, n=1)
                hint = f" (did you mean {near[0]!r}?)" if near else ""
                raise InputError(f"{name!r} is not an output of the rig's model{hint}; its "
                                 f"outputs: {', '.join(outputs)}", field=f"{field}.{name}")
    accuracy = None
    if request.noise or request.noise_fraction or (request.rtol is not None
                                                   and request.solver == "rodas4"):
        # a tolerance given is run as it is and its error estimated, as the schema says
        # (without a noise target it was not estimated at all: a modelling engineer's pass)
        accuracy = NoiseAccuracy(sigma=dict(request.noise),
                                 fraction=dict(request.noise_fraction))
    sample_rate = request.sample_rate
    if sample_rate is None and request.timeseries is None and request.solver == "rodas4":
        # no rows asked for: the summary and the error estimate come from a data logger's
        # grid (the step rows right after the valve switch would only cost time)
        sample_rate = SUMMARY_SAMPLE_RATE
    try:
        _check_grid(rig, overrides, condition, request, max_rows, limits)
        result = run_scenario(rig, overrides, condition, method=request.method,
                              timeseries=request.timeseries is not None, rtol=request.rtol,
                              solver=request.solver, sample_rate=sample_rate,
                              accuracy=accuracy, limits=limits)
    except InputError as exc:  # ParameterError, SolverLimitError: named as sent
        raise _blamed_right(exc, request, set(overrides) - set(request.overrides)) from None
    if (result.timeseries is not None and request.sample_rate is not None
            and len(result.timeseries) > _row_cap(request, max_rows)):
        raise _too_many_rows(len(result.timeseries), request, max_rows, expected=False)
    return SimulationOutcome(resolved, request.fault, overrides, condition, request.method,
                             result)


def _frame(outcome: SimulationOutcome) -> pd.DataFrame:
    """The run's time series with its condition as constant columns (``load [N]``,
    ``oil_temperature [degC]`` …, :data:`diagnostics.timeseries.CONDITION_CHANNELS`): a
    record cut from the export, or several exports put in one table with a ``record``
    column, still states at what load and temperature it ran (the discrepancy workflow
    refuses a cycle that does not)."""
    frame = outcome.result.timeseries
    if frame is None:
        raise InputError("this run has no time series", field="timeseries")
    condition = condition_dict(outcome.condition)
    return frame.assign(**{f"{k} [{unit}]": float(v) for k, unit in CONDITION_CHANNELS.items()
                           if (v := condition.get(k)) is not None})


def timeseries_table(outcome: SimulationOutcome) -> dict[str, Any]:
    """The time series as ``{"columns": [...], "data": [[...], ...]}``."""
    frame = _frame(outcome)
    rows = frame.astype(object).where(frame.notna(), None).to_numpy().tolist()
    return {"columns": [str(c) for c in frame.columns], "data": rows}


def timeseries_csv(outcome: SimulationOutcome) -> bytes:
    """The time series as CSV, the header's entries first as ``# key = value`` lines.

    Numbers are written as the shortest text that reads back to the same double.
    """
    return table_bytes(_frame(outcome), outcome.header(), "csv")


def timeseries_parquet(outcome: SimulationOutcome) -> bytes:
    """The time series as Parquet, the header as JSON metadata under ``hydrodiag``."""
    return table_bytes(_frame(outcome), outcome.header(), "parquet")


def _solver_public(result: CycleResult) -> dict[str, Any] | None:
    rep = result.solver
    if rep is None:
        return None
    return {"method": rep.method, "rtol": rep.rtol, "rejected": rep.rejected,
            "rhs_evaluations": rep.nfev, "error_sigma": rep.error_sigma,
            "target_sigma": rep.target_sigma, "sigma": rep.sigma,
            "switch_time_error": rep.switch_time_error}


def public_of(outcome: SimulationOutcome, *, table: bool = False) -> SimulationPublic:
    """The JSON answer of a run (the time series inside when ``table``)."""
    result = outcome.result
    return SimulationPublic.model_validate({
        "rig_id": outcome.resolved.rig_id, "rig_version": outcome.resolved.version,
        "fault": outcome.fault, "overrides": outcome.overrides,
        "condition": outcome.condition_used(), "method": outcome.method,
        "summary": summary_of(result),
        "completed": {"working": result.working.completed, "return": result.return_.completed},
        "steps": dict(result.steps),
        "solver": _solver_public(result),
        "timeseries": timeseries_table(outcome) if table else None,
        "notes": outcome.notes(),
    })
