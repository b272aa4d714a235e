"""Console page of the pump sets: the stored sets, the chosen one's quantities, measured vs
model and loss surfaces, and a bench CSV made into a set (as ``POST /pump-sets/bench``).

The upload goes through the same service and validation as the API
(:func:`app.services.pump_bench.store_bench_parameters`); a refused file or field shows the
page again with the error naming it and the fields as entered, nothing stored.  The
displacement is asked in cm³/rev, as an engineer reads it off a data sheet, and passed on
in m³/rad.
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import File, Form, Query, Request, Response, UploadFile
from pydantic import ValidationError
from starlette.concurrency import run_in_threadpool

from app.api.deps import SessionDep
from app.console.charts import surface_chart
from app.console.numbers import form_number
from app.console.pump_charts import pump_check_charts
from app.console.routing import ConsoleKeyDep, new_router, write_refusal
from app.console.web import page, redirect
from app.errors import first_problem, status_for
from app.schemas.common import MAX_ID
from app.schemas.pumps import OIL_NU_MIN, PumpBenchForm
from app.services import pumps as pump_service
from app.services.pump_bench import MAX_CSV_BYTES, store_bench_parameters
from diagnostics.plots import Chart
from sim.errors import HydrodiagError, InputError
from sim.units import to_si

__all__ = ["router"]

router = new_router()

def _page(request: Request, session: Any, set_id: int | None, *, status_code: int = 200,
          error: dict[str, Any] | None = None, entered: dict[str, str] | None = None
          ) -> Response:
    rows, total = pump_service.list_pump_sets(session, limit=500, offset=0)
    chosen = pump_service.get_pump_set(session, set_id) if set_id is not None else (
        rows[0] if rows else None)
    charts: list[Chart] = []
    if chosen is not None:
        q = chosen.quantities
        for name in sorted(k[:-5] for k in q if k.endswith("_coef")):
            try:
                charts.append(surface_chart(
                    name, q[f"{name}_coef"]["value"], q[f"{name}_p_ref"]["value"],
                    q[f"{name}_omega_ref"]["value"], q["dp_range"]["value"],
                    q["omega_range"]["value"]))
            except (KeyError, TypeError, ValueError):
                continue  # a hand-made set without the surface's scales: table only
        charts = pump_check_charts(q) + charts
    return page(request, "pumps.html", status_code=status_code, rows=rows, total=total,
                chosen=chosen, charts=charts, error=error, entered=entered or {})


@router.get("/pumps")
def pumps(request: Request, session: SessionDep, _key: ConsoleKeyDep,
          set_id: Annotated[int | None, Query(ge=1, le=MAX_ID)] = None) -> Response:
    """Pump sets; the chosen one with its quantities, measured vs model from its checked
    points, and its fitted loss surfaces; the form that makes a set from a bench CSV."""
    return _page(request, session, set_id)


#: the page's fields in the units an engineer types (cm³/rev, the data sheet's cSt, kg/m³)
#: and the API form's SI fields they fill
_PAGE_FIELDS = {"displacement": ("displacement_m3_rad", "cm^3/rev", "m^3/rad"),
                "oil_nu40": ("oil_nu40_m2_s", "cSt", "m^2/s"),
                "oil_nu100": ("oil_nu100_m2_s", "cSt", "m^2/s"),
                "oil_rho15": ("oil_rho15_kg_m3", "kg/m^3", "kg/m^3")}


def _form(name: str, pump: str, rig: str, source: str, numbers: dict[str, str]
          ) -> PumpBenchForm:
    """The API's form of the page's fields (``numbers`` by page field: the displacement in
    cm³/rev, the oil's viscosities in cSt and density in kg/m³)."""
    fields: dict[str, Any] = {"name": name.strip(), "pump": pump.strip(),
                              "rig_id": rig.strip() or None, "source": source.strip() or None}
    for page_field, text in numbers.items():
        if not text.strip():
            continue
        api_field, unit, si = _PAGE_FIELDS[page_field]
        fields[api_field] = to_si(form_number(text, field=page_field), unit, si, field=page_field)
        if unit == "cSt" and not fields[api_field] >= OIL_NU_MIN:
            # said in the field's unit, not the form's SI (a verification pass)
            raise InputError(f"{text.strip()} cSt is below {OIL_NU_MIN * 1e6:g} cSt, where "
                             "ASTM D341's Walther law starts: the field takes cSt (46 for a "
                             "VG 46 at 40 °C)", field=page_field)
    try:
        return PumpBenchForm.model_validate(fields)
    except ValidationError as exc:
        problem = first_problem(exc.errors())
        # the page's names: the displacement in cm³/rev, the oil's, the rig's id
        names = {api: page for page, (api, _, _) in _PAGE_FIELDS.items()} | {"rig_id": "rig"}
        problem.field = names.get(problem.field or "", problem.field)
        raise problem from None


@router.post("/pumps/bench")
async def bench(request: Request, session: SessionDep, _key: ConsoleKeyDep,
                name: Annotated[str, Form(max_length=200)] = "",
                pump: Annotated[str, Form(max_length=200)] = "",
                rig: Annotated[str, Form(max_length=20)] = "",
                source: Annotated[str, Form(max_length=2000)] = "",
                displacement: Annotated[str, Form(max_length=40)] = "",
                oil_nu40: Annotated[str, Form(max_length=40)] = "",
                oil_nu100: Annotated[str, Form(max_length=40)] = "",
                oil_rho15: Annotated[str, Form(max_length=40)] = "",
                file: Annotated[UploadFile | None, File()] = None) -> Response:
    """Parameterise a bench CSV (ISO 4409 test points, paper 000's loss model) and store
    the set; go to it.  A refused file or field: the page again with the error, the fields
    as entered, nothing stored; a read key: 403."""
    numbers = {"displacement": displacement, "oil_nu40": oil_nu40, "oil_nu100": oil_nu100,
               "oil_rho15": oil_rho15}
    entered = {"name": name, "pump": pump, "rig": rig, "source": source} | numbers
    refusal = write_refusal(_key, "storing a pump set")
    if refusal is not None:
        return await run_in_threadpool(_page, request, session, None, status_code=403,
                                       error=refusal, entered=entered)
    try:
        if file is None or not file.filename:
            raise InputError("choose a bench CSV", field="file")
        form = _form(name, pump, rig, source, numbers)
        content = await file.read(MAX_CSV_BYTES + 1)
        pump_set = await run_in_threadpool(store_bench_parameters, session, form, content)
    except HydrodiagError as exc:
        error = {"type": type(exc).__name__, "message": exc.message, "field": exc.field}
        return await run_in_threadpool(_page, request, session, None,
                                       status_code=status_for(exc), error=error,
                                       entered=entered)
    return redirect(f"/console/pumps?set_id={pump_set.id}")
