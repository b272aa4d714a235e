"""Sweeps: many scenarios of one rig, fanned out to an executor, with progress.

Used by ``POST /scenarios`` (as a job) and ``hydrodiag sweep``.  :func:`plan_sweep` checks
the request and lays out the points before anything runs, so a bad request is a 422 and
not a failed job; :func:`run_sweep` sends chunks of points to the executor
(:mod:`app.services.executors`) and reports progress as chunks come back.

Designs: ``grid`` — every combination of each factor's levels (linear or log spacing);
``lhs`` — a Latin hypercube of ``samples`` points over the factors' ranges
(:class:`scipy.stats.qmc.LatinHypercube`, seeded).  Every design point runs once for each
named fault, the fault's overrides first and the swept ones over them.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor, Future
from dataclasses import dataclass
from typing import Any

import numpy as np
from sqlalchemy.orm import Session

from app.limits import DEFAULT_SWEEP_POINTS, check_count
from app.schemas.sweeps import RangeSpec, SweepRequest
from app.services.rig_cache import ResolvedRig, RigCache
from app.services.simulation import condition_dict, condition_of
from app.services.sweep_worker import SUMMARY_COLUMNS, evaluate_chunk
from diagnostics.batch import as_done
from sim.errors import InputError, ParameterError
from sim.scenarios import fault_overrides

__all__ = ["MAX_POINTS", "SweepPlan", "plan_sweep", "run_sweep"]

#: Most scenarios one sweep may run, per method [-].
MAX_POINTS = DEFAULT_SWEEP_POINTS
#: Scenarios per task sent to the executor, per method [-].
CHUNK = {"steady": 50, "transient": 2}

ProgressFn = Callable[[float, str], None]


@dataclass(frozen=True)
class SweepPlan:
    """The points of a sweep and what they run on."""

    resolved: ResolvedRig
    request: SweepRequest
    factors: tuple[str, ...]
    points: tuple[dict[str, Any], ...]

    def columns(self) -> list[str]:
        """Columns of the result rows: fault, the factors, then the summary."""
        return ["fault", *self.factors, *SUMMARY_COLUMNS]


def _levels(spec: RangeSpec) -> np.ndarray:
    if spec.levels == 1:
        return np.array([spec.low])
    if spec.log:
        return np.geomspace(spec.low, spec.high, spec.levels)
    return np.linspace(spec.low, spec.high, spec.levels)


def _design(request: SweepRequest) -> np.ndarray:
    """Design points, one row per point, one column per factor (parameters, conditions)."""
    specs = [*request.parameters, *request.conditions]
    if not specs:
        return np.zeros((1, 0))
    if request.design == "grid":
        return np.array(list(itertools.product(*(_levels(s) for s in specs))), dtype=float)
    from scipy.stats import qmc

    unit = qmc.LatinHypercube(d=len(specs), seed=request.seed).random(request.samples)
    columns = []
    for j, s in enumerate(specs):
        if s.log:
            columns.append(np.exp(np.log(s.low) + unit[:, j] * (np.log(s.high) - np.log(s.low))))
        else:
            columns.append(s.low + unit[:, j] * (s.high - s.low))
    return np.column_stack(columns)


def _check_ranges(resolved: ResolvedRig, request: SweepRequest) -> None:
    """Both ends of every range must be valid on the rig (422 before the job starts)."""
    rig = resolved.rig
    base = condition_of(rig, request.base_condition)
    for group in ("parameters", "conditions"):
        for i, spec in enumerate(getattr(request, group)):
            for end in ("low", "high"):
                value = getattr(spec, end)
                try:
                    if group == "parameters":
                        rig.values({spec.name: value}, base)
                    else:
                        rig.values(None, condition_of(rig, request.base_condition.model_copy(
                            update={spec.name: value})))
                except ParameterError as exc:
                    unknown = exc.message.startswith("unknown parameter")
                    where = "name" if unknown else end
                    raise ParameterError(exc.message, field=f"{group}[{i}].{where}") from None


def plan_sweep(session: Session, rigs: RigCache, request: SweepRequest,
               max_points: Mapping[str, int] = MAX_POINTS) -> SweepPlan:
    """Check ``request`` and lay out its points.

    ``max_points`` is the most points of one sweep by method [-] (the settings
    ``HYDRODIAG_MAX_SWEEP_POINTS_STEADY`` and ``..._TRANSIENT``; default :data:`MAX_POINTS`).

    Raises
    ------
    NotFoundError
        Unknown rig or version.
    InputError
        Too many points for the method, an unknown parameter, a range end out of bounds.
    """
    check_count(request.n_points(), max_points[request.method],
                what=f"points of a {request.method} sweep", field="design",
                setting=f"max_sweep_points_{request.method}")
    resolved = rigs.get(session, request.rig_id, request.rig_version)
    resolved.rig.require_cycle("a sweep of fault scenarios")
    _check_ranges(resolved, request)
    rig = resolved.rig
    names = [s.name for s in request.parameters]
    conditions = [s.name for s in request.conditions]
    design = _design(request)
    points = []
    for k, fault in enumerate(request.faults):
        base = fault_overrides(rig, fault)
        if hidden := sorted(set(base) & set(names)):
            # the varied parameter replaces the fault's own: every point of this fault would
            # repeat another fault's, labelled with this one
            raise InputError(f"the fault {fault!r} sets {', '.join(hidden)}, which the design "
                             "varies, so its points would be another fault's under its name; "
                             "vary it under 'healthy', or leave the fault out",
                             field=f"faults[{k}]")
        for row in design:
            overrides = dict(base) | {n: float(v) for n, v in zip(names, row, strict=False)}
            changes = {n: float(v) for n, v in zip(conditions, row[len(names):], strict=True)}
            spec = request.base_condition.model_copy(update=changes)
            points.append({"fault": fault, "factors": [float(v) for v in row],
                           "overrides": overrides,
                           "condition": condition_dict(condition_of(rig, spec))})
    factors = (*names, *(f"condition.{n}" for n in conditions))
    return SweepPlan(resolved, request, factors, tuple(points))


def run_sweep(plan: SweepPlan, executor: Executor,
              progress: ProgressFn | None = None,
              waiting: Callable[[], None] | None = None) -> dict[str, Any]:
    """Run every point of ``plan`` on ``executor``; return the table of results.

    Parameters
    ----------
    plan
        From :func:`plan_sweep`.
    executor
        Any ``concurrent.futures``-shaped executor (process pool, Dask client executor).
    progress
        Called with the fraction done [1] and a note after each chunk; when it raises (a
        cancelled job, :class:`app.services.jobs.JobCancelledError`) the chunks not started are
        cancelled and the exception goes on.
    waiting
        Called every second while no chunk completes, and the same when it raises (a
        cancel asked, a Dask cluster without a worker: :func:`diagnostics.batch.as_done`).

    Returns
    -------
    dict
        ``columns`` (fault, factors, summary keys with units), ``rows`` in plan order
        (summary values null for a failed point), ``errors`` ``[{"point", "message"}]`` and
        the counts; JSON-ready.
    """
    method = plan.request.method
    size = CHUNK[method]
    document = dict(plan.resolved.document)
    points = plan.points
    futures: dict[Future[list[dict[str, Any]]], int] = {}
    for start in range(0, len(points), size):
        chunk = [{"overrides": p["overrides"], "condition": p["condition"]}
                 for p in points[start:start + size]]
        futures[executor.submit(evaluate_chunk, document, method, chunk)] = start
    outcomes: list[Mapping[str, Any] | None] = [None] * len(points)
    done = 0
    try:
        for future in as_done(futures, waiting):
            start = futures[future]
            chunk_result: Sequence[Mapping[str, Any]] = future.result()
            for offset, outcome in enumerate(chunk_result):
                outcomes[start + offset] = outcome
            done += len(chunk_result)
            if progress is not None:
                progress(done / len(points), f"point {done} of {len(points)}")
    except BaseException:  # a cancelled job (or a failure): the chunks not started go
        for future in futures:
            future.cancel()
        raise
    rows, errors = [], []
    blank: list[float | None] = [None] * len(SUMMARY_COLUMNS)
    for i, (point, maybe) in enumerate(zip(points, outcomes, strict=True)):
        outcome = maybe if maybe is not None else {"error": "no answer from the executor"}
        if "error" in outcome:
            errors.append({"point": i, "message": str(outcome["error"])})
        rows.append([point["fault"], *point["factors"], *outcome.get("values", blank)])
    return {
        "rig_id": plan.resolved.rig_id, "rig_version": plan.resolved.version,
        "method": method, "design": plan.request.design, "n_points": len(points),
        "n_failed": len(errors), "columns": plan.columns(), "rows": rows, "errors": errors,
    }
