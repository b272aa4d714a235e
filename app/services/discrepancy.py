"""Discrepancy runs as jobs: read the measured file, run the workflow, store the augmented rig.

``POST /discrepancy`` and ``hydrodiag discover`` share this module.  The file is either a
time series in the ``/simulate`` export format (read by
:func:`diagnostics.timeseries.read_series`) or a steady table in the pump-bench CSV format
(``p_out``/``q`` columns and no ``t``: :func:`diagnostics.discrepancy.steady.read_bench_bytes`).
Instead of a file, ``series_ids`` names measured records stored with the rig
(``POST /rigs/{rig_id}/series``, ``hydrodiag import``), read back with their phases and
conditions; for a rig without a working/return cycle (the ZeMA rig) their settled pressure
plateaus become the steady table.  It is read before the job starts, so a bad column is
a 422 naming it and nothing is stored; the job runs :func:`diagnostics.discrepancy.discover` (or
:func:`~diagnostics.discrepancy.steady.discover_steady` on a bench table) and, when an
effect is named, stores the augmented rig document as a new version of the rig
(:func:`app.services.rigs.update_rig`).  The job's result is the JSON report with
``new_rig_version`` and the self-contained HTML page under ``html``.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from sqlalchemy.orm import Session

from app.db.engine import SessionFactory
from app.db.models import Job
from app.limits import check_file
from app.schemas.discrepancy import DiscrepancyForm
from app.services.jobs import JobRunner, Progress
from app.services.rig_cache import RigCache
from app.services.rigs import get_rig, latest_version, update_rig
from app.services.series import parse_column_map, stored_records
from diagnostics.discrepancy import Discovery, discover
from diagnostics.discrepancy.first_step import check_records
from diagnostics.discrepancy.pump_refit import MAX_DISPLACEMENT_CHANGE
from diagnostics.discrepancy.report import html_page, stored_line
from diagnostics.discrepancy.steady import (
    discover_steady,
    is_bench_table,
    read_bench_bytes,
    require_rows,
)
from diagnostics.pump.data import BenchData
from diagnostics.real.profile import settled_bench, stated_pump_speed
from diagnostics.timeseries import ColumnEntry, SeriesRecord, read_series
from sim.errors import HydrodiagError, InputError
from sim.rigs import load_rig
from sim.rigs.circuits import DEFAULT_CIRCUIT, get_circuit

__all__ = ["MAX_SERIES_BYTES", "DiscrepancyPlan", "data_field", "plan_discrepancy",
           "run_discrepancy", "submit_discrepancy"]

#: Largest measured file accepted [byte].
MAX_SERIES_BYTES = 50 * 1024 * 1024


@dataclass
class DiscrepancyPlan:
    """What a run needs: the rig version's document and the validated records."""

    rig_id: int
    version: int
    document: dict[str, Any]
    records: list[SeriesRecord]
    refit: bool
    store: bool
    bench: BenchData | None = None
    #: where the data came from, as errors should name it: the upload or the stored ids
    source: str = "file"

    @property
    def names(self) -> list[str]:
        """Names of the records read (``["bench table"]`` for a steady table)."""
        return ["bench table"] if self.bench is not None else [r.name for r in self.records]

    @property
    def channels(self) -> list[str]:
        """Channels found (bench: its quantities)."""
        if self.bench is not None:
            return ["n", "p_in", "p_out", "q", "theta"]
        return sorted(self.records[0].channels)


def read_records(content: bytes, *, field: str = "file",
                 column_map: Mapping[str, ColumnEntry] | None = None,
                 sample_rate: float | None = None,
                 expected: Mapping[str, str] | None = None,
                 filename: str | None = None) -> list[SeriesRecord]:
    """Read a measured CSV/Parquet file given as bytes (errors name the column), through a
    logger's ``column_map`` and ``sample_rate`` where given; ``expected``: the rig's
    channels and their units (a known channel must be of its dimension); ``filename``
    names a record without a ``record`` column."""
    check_file(content, MAX_SERIES_BYTES, field=field)
    return read_series(content, column_map=column_map, sample_rate=sample_rate,
                       expected=expected,
                       name=filename.removesuffix(".gz") if filename else None)


def plan_discrepancy(session: Session, rigs: RigCache, form: DiscrepancyForm,
                     content: bytes | None, filename: str | None = None) -> DiscrepancyPlan:
    """Resolve the rig version and read the file (``filename`` names a record without a
    ``record`` column), or the stored series ``form.series_ids`` (one of the two); raises
    before anything is stored.  ``POST /discrepancy`` and ``hydrodiag discover`` both plan
    here."""
    if (content is None) == (form.series_ids is None):
        raise InputError("give a file or series_ids (stored records of the rig), one of them",
                         field="file" if content is None else "series_ids")
    resolved = rigs.get(session, form.rig_id, form.rig_version)
    if content is None:
        records = stored_records(session, form.rig_id, form.ids())
        document = dict(resolved.document)
        if not get_circuit(document.get("circuit", DEFAULT_CIRCUIT)).cycle:
            bench = _plateaus(records, resolved.rig.values(), form.relaxation)
            with data_field("series_ids"):
                require_rows(bench)
            return DiscrepancyPlan(resolved.rig_id, resolved.version, document, [],
                                   form.refit, form.store, bench, "series_ids")
        try:
            check_records(document, records)
        except InputError as exc:
            raise _on_series(document, records, exc) from None
        return DiscrepancyPlan(resolved.rig_id, resolved.version, document, records,
                               form.refit, form.store, source="series_ids")
    if len(content) <= MAX_SERIES_BYTES and is_bench_table(content):
        if form.column_map or form.sample_rate:
            raise InputError("a column map and a sample rate read a time series, not a bench "
                             "table", field="column_map" if form.column_map else "sample_rate")
        bench = read_bench_bytes(content)
        require_rows(bench)
        return DiscrepancyPlan(resolved.rig_id, resolved.version, dict(resolved.document), [],
                               form.refit, form.store, bench)
    records = read_records(content, column_map=parse_column_map(form.column_map),
                           sample_rate=form.sample_rate, filename=filename,
                           expected=resolved.rig.channels())  # a rig's channel: its dimension
    check_records(resolved.document, records)  # a 422 now, not a job that fails
    return DiscrepancyPlan(resolved.rig_id, resolved.version, dict(resolved.document), records,
                           form.refit, form.store)


def _on_series(document: Mapping[str, Any], records: list[SeriesRecord],
               exc: InputError) -> InputError:
    """``exc`` on stored records named by the series id that fails it alone, on the field
    ``series_ids``: an error naming a record ("the load of record 'couette-2100N-40C'
    varies") and the channel ``load`` left a user to find which of their ids it was, among
    many series of that record name (a discrepancy pass)."""
    for r in records:
        try:
            check_records(document, [r])
        except InputError as alone:
            if alone.message == exc.message:
                return type(exc)(f"series {r.metadata.get('series_id')} (record "
                                 f"{r.name!r}): {exc.message}", field="series_ids")
        except HydrodiagError:
            continue
    return type(exc)(exc.message, field="series_ids")


def _plateaus(records: list[SeriesRecord], values: Mapping[str, float],
              relaxation: float) -> BenchData:
    """Stored records of a rig without a cycle (a pump feeding a relief valve and an
    orifice, the ZeMA rig) as the steady table of their settled working plateaus
    (:func:`diagnostics.real.profile.settled_bench`) at the pump speed the rig's parameter
    ``values`` state."""
    names = ", ".join(r.name for r in records[:3]) + (" …" if len(records) > 3 else "")
    return settled_bench(records, stated_pump_speed(values), relaxation=relaxation,
                         provenance=f"settled plateaus (τ = {relaxation:g} s) of stored "
                                    f"records {names}")


@contextmanager
def data_field(name: str, fields: tuple[str, ...] = ("file", "records")) -> Iterator[None]:
    """Errors of the workflow about its data (``field`` one of ``fields``: ``file``, as the
    upload is called, or the library's argument ``records``) name ``name`` instead:
    ``series_ids`` for stored records, an option on the command line."""
    try:
        yield
    except HydrodiagError as exc:
        if exc.field in fields:
            exc.field = name
        raise


def run_discrepancy(plan: DiscrepancyPlan, sessions: SessionFactory | None,
                    progress: Progress) -> dict[str, Any]:
    """Run the workflow; store the augmented rig when an effect is named (``sessions``)."""
    def report(fraction: float, what: str) -> None:
        progress(min(0.95, fraction), what)

    with data_field(plan.source):
        if plan.bench is not None:
            d = discover_steady(plan.document, plan.bench, progress=report)
        else:
            d = discover(plan.document, plan.records, progress=report, refit=plan.refit)
    result = d.to_dict()
    result["rig_id"] = plan.rig_id
    result["rig_version"] = plan.version
    result["new_rig_version"] = result["not_stored"] = None
    if plan.store and sessions is not None:
        # a last look for a cancel (a stopping service asks its late jobs to stop): a job
        # failed at shutdown with "submit it again" had stored its rig version all the same,
        # its report lost (an SRE pass, 1 of 5 stops)
        progress.check()
        with sessions() as session:
            result["new_rig_version"], result["not_stored"] = store_discovery(
                session, plan.rig_id, plan.version, d)
    result["html"] = html_page(d, stored=stored_line(
        plan.rig_id, plan.version, result["new_rig_version"], result["not_stored"]))
    return result


def store_discovery(session: Session, rig_id: int, from_version: int, d: Discovery
                    ) -> tuple[int | None, str | None]:
    """Store the augmented rig of ``d`` (the workflow run on version ``from_version``) as a
    new version of rig ``rig_id``: (the new version, None), or (None, why it was not
    stored), or (None, None) when nothing was named.

    Not stored: a ``partially explained`` verdict (the effects did not close the gap, so
    they may stand for a cause outside the library: a thermometer 3 K low was "explained"
    by two piston-leak laws, stored as a version that every later diagnosis used — a
    simulation engineer's pass); a named effect outside its plausible range (the report
    names it, as evidence that the data may not be this rig's); a version that is no
    longer the latest (its successors' changes, an effect added since, would be dropped); a
    pump displacement re-fitted by more than :data:`MAX_DISPLACEMENT_CHANGE` (another pump).
    """
    if not d.named:
        return None, None
    reasons = [f"outside its plausible range: {n.name} ({n.parameter} = {n.value:.4g}"
               f"{'' if n.unit == '1' else ' ' + n.unit}, plausible {n.plausible_range[0]:.3g} to "
               f"{n.plausible_range[1]:.3g}) — the data may not come from this rig, or the "
               "effect stands for another" for n in d.named if not n.plausible]
    if d.verdict == "partially explained":
        reasons.append("partially explained: the named effects leave a gap, so they may "
                       "stand for a cause outside the library (a stated oil temperature or "
                       "load that is off, a transducer's zero); a version is stored only "
                       "for effects that explain the data")
    rig = get_rig(session, rig_id, field="rig_id")
    if rig.latest_version != from_version:
        reasons.append(f"the workflow ran on version {from_version} and the rig's latest is "
                       f"{rig.latest_version}, whose changes a version built on "
                       f"{from_version} would drop; run it on the latest version to store")
    before = load_rig(latest_version(session, rig).document).values()
    after = load_rig(d.rig_document).values()
    for key in (k for k in before if k.endswith(".Vp") and k in after):
        change = after[key] / before[key] - 1.0
        if abs(change) > MAX_DISPLACEMENT_CHANGE:
            reasons.append(f"the re-fit moves {key} by {100 * change:+.0f} %: a displacement "
                           "does not wear by that much, so the data come from another pump "
                           "(hydrodiag calibrate pump characterises it)")
    if reasons:  # every reason, not the first (an operator fixing one met the next)
        return None, "not stored: " + "; ".join(reasons)
    names = ", ".join(n.name for n in d.named)
    _, version = update_rig(session, rig_id, d.rig_document,
                            comment=f"hydrodiag discover: added {names} (from version "
                                    f"{from_version})")
    return version.version, None


def submit_discrepancy(runner: JobRunner, sessions: SessionFactory, form: DiscrepancyForm,
                       plan: DiscrepancyPlan) -> Job:
    """Start :func:`run_discrepancy` of ``plan`` as a job of ``runner`` (``POST
    /discrepancy`` and the console's measured-series page); returns the queued job."""
    def run(_params: dict[str, Any], progress: Progress) -> dict[str, Any]:
        return run_discrepancy(plan, sessions, progress)

    return runner.submit("discrepancy", form.model_dump(mode="json"), run)
