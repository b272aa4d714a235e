"""Console page: simulate a fault scenario, nominal overlaid; download CSV or Parquet.

The form is sent with GET (it stores nothing, and the page can be bookmarked); its fields
are those of ``POST /simulate`` and are checked by the same request model, so a bad value
gets the API's field-naming error on the page.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal
from urllib.parse import urlencode

from fastapi import Query, Request, Response
from pydantic import ValidationError

from app.api.deps import RigsDep, SessionDep
from app.console.charts import simulation_charts
from app.console.numbers import form_number
from app.console.pages_rigs import CLEARANCES
from app.console.routing import ConsoleKeyDep, new_router
from app.console.web import SECURITY_HEADERS, page
from app.errors import first_problem, status_for
from app.schemas.common import MAX_ID
from app.schemas.simulate import SimulateRequest
from app.services import rigs as rig_service
from app.services.simulation import (
    simulate,
    summary_of,
    timeseries_csv,
    timeseries_parquet,
)
from diagnostics.plots import shown_unit
from sim.errors import HydrodiagError
from sim.scenarios import FAULTS

__all__ = ["router"]

router = new_router()


def _request(rig: int, fault: str, load: str, oil_temperature: str, back_pressure: str,
             timeseries: str) -> SimulateRequest:
    """The ``POST /simulate`` request of the form's fields (blank: the rig's default)."""
    condition: dict[str, Any] = {}
    for name, text in (("load", load), ("oil_temperature", oil_temperature),
                       ("back_pressure", back_pressure)):
        if text.strip():
            condition[name] = form_number(text, field=f"condition.{name}")
    try:
        return SimulateRequest.model_validate({
            "rig_id": rig, "fault": None if fault in ("", "healthy") else fault,
            "condition": condition, "method": "transient", "timeseries": timeseries})
    except ValidationError as exc:
        raise first_problem(exc.errors()) from None


@router.get("/simulate")
def simulate_page(request: Request, session: SessionDep, rigs: RigsDep, _key: ConsoleKeyDep,
                  rig: Annotated[int, Query(ge=1, le=MAX_ID)] = 1,
                  fault: Annotated[str, Query(max_length=40)] = "",
                  load: Annotated[str, Query(max_length=40)] = "",
                  oil_temperature: Annotated[str, Query(max_length=40)] = "",
                  back_pressure: Annotated[str, Query(max_length=40)] = "",
                  run: Annotated[bool, Query()] = False) -> Response:
    """The form; with ``run``, the cycle of the scenario against the healthy rig."""
    rows = [r for r in rig_service.rig_choices(session)[0] if r.cycle]  # can be simulated
    form = {"rig": rig, "fault": fault, "load": load, "oil_temperature": oil_temperature,
            "back_pressure": back_pressure}
    context: dict[str, Any] = {"rigs": rows, "faults": FAULTS, "form": form, "charts": [],
                               "summary": None, "notes": [], "condition": None, "error": None,
                               "query": "", "fault_set": []}
    if run:
        try:
            body = _request(rig, fault, load, oil_temperature, back_pressure, "json")
            outcome = simulate(session, rigs, body)
            nominal = simulate(session, rigs, body.model_copy(update={"fault": None}))
        except HydrodiagError as exc:
            context["error"] = {"type": type(exc).__name__, "message": exc.message,
                                "field": exc.field}
            return page(request, "simulate.html", status_code=status_for(exc), **context)
        label = fault if fault not in ("", "healthy") else "healthy"
        frame = outcome.result.timeseries
        context["charts"] = [] if frame is None else simulation_charts(
            frame, nominal.result.timeseries, label)
        context["summary"] = summary_of(outcome.result)
        context["notes"] = outcome.result.notes()
        context["condition"] = outcome.condition
        # the scenario's own fields: the page's query carries its form's run=true, which
        # the download does not read and refused as unknown (a verification pass)
        context["query"] = urlencode({"rig": rig, "fault": fault, "load": load,
                                      "oil_temperature": oil_temperature,
                                      "back_pressure": back_pressure})
        # what the named fault set on this rig (a planner could not tell how worn
        # "worn_spool" is without the CSV's header)
        context["fault_set"] = [_as_read(k, v, _unit_of(outcome, k))
                                for k, v in outcome.overrides.items()]
    return page(request, "simulate.html", **context)


@router.get("/simulate/download")
def download(session: SessionDep, rigs: RigsDep, _key: ConsoleKeyDep,
             format: Annotated[Literal["csv", "parquet"], Query()],
             rig: Annotated[int, Query(ge=1, le=MAX_ID)] = 1,
             fault: Annotated[str, Query(max_length=40)] = "",
             load: Annotated[str, Query(max_length=40)] = "",
             oil_temperature: Annotated[str, Query(max_length=40)] = "",
             back_pressure: Annotated[str, Query(max_length=40)] = "") -> Response:
    """The scenario's time series as CSV or Parquet (as ``POST /simulate`` gives it)."""
    body = _request(rig, fault, load, oil_temperature, back_pressure, format)
    outcome = simulate(session, rigs, body)
    headers = dict(SECURITY_HEADERS)
    headers["Content-Disposition"] = f'attachment; filename="simulation.{format}"'
    if format == "csv":
        return Response(timeseries_csv(outcome), media_type="text/csv", headers=headers)
    return Response(timeseries_parquet(outcome), media_type="application/vnd.apache.parquet",
                    headers=headers)


def _unit_of(outcome: Any, key: str) -> str:
    """The SI unit of parameter ``role.name`` of the run's rig ("" when unknown)."""
    role, name = key.split(".", 1)
    decl = outcome.resolved.rig.circuit.parameter(role, name)
    return decl.unit if decl is not None else ""


def _as_read(key: str, value: float, unit: str) -> str:
    """``role.name = value unit`` as the rig page shows it (µm, bar, …)."""
    factor, shown = shown_unit(unit, clearance=key.split(".")[-1] in CLEARANCES)
    return f"{key} = {value * factor:.4g} {shown}"
