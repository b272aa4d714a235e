"""Console pages: login, rigs, one rig (parameters, versions, calibrations, bond graph)."""

from __future__ import annotations

import pathlib
import re
import shutil
import subprocess
from typing import Annotated, Any
from urllib.parse import unquote

import numpy as np
from fastapi import Form, Path, Query, Request, Response
from fastapi.responses import FileResponse

from app.api.deps import SessionDep, wrong_key_guard, wrong_keys_counted
from app.console.charts import calibration_chart
from app.console.routing import ConsoleKeyDep, new_router
from app.console.web import (
    COOKIE,
    SECURITY_HEADERS,
    end_console_session,
    issue_cookie,
    page,
    redirect,
)
from app.errors import RateLimitError
from app.schemas.common import MAX_ID
from app.services import calibrations as calibration_service
from app.services import rigs as rig_service
from app.services.keys import authenticate
from diagnostics.plots import Chart, shown_unit
from sim.bondgraph.equations import derive_equations
from sim.bondgraph.export import to_dot
from sim.errors import AuthError, NotFoundError
from sim.rigs import build_graph

__all__ = ["router"]

router = new_router()
_CSS = pathlib.Path(__file__).parent / "static" / "console.css"


@router.get("/static/console.css")
def stylesheet() -> FileResponse:
    """The console's one stylesheet."""
    return FileResponse(_CSS, media_type="text/css", headers=SECURITY_HEADERS)


def _safe_next(target: str | None) -> str:
    """Only a path inside the console (no open redirect): ``/console`` or below it, with no
    ``.`` or ``..`` segment, percent-encoded or not (``/console/../../x`` left it)."""
    if not target or "//" in target or "\\" in target:
        return "/console/rigs"
    path = unquote(target.split("?", 1)[0])
    segments = path.split("/")
    if (path == "/console" or path.startswith("/console/")) and not {".", ".."} & set(segments):
        return target
    return "/console/rigs"


@router.get("/login")
def login_form(request: Request, next: str | None = None) -> Response:
    """The login form: the API key, asked once per browser session."""
    return page(request, "login.html", next=_safe_next(next), error=None)


@router.post("/login")
def login(request: Request, session: SessionDep,
          api_key: Annotated[str, Form(max_length=200)] = "",
          next: Annotated[str, Form(max_length=2000)] = "") -> Response:
    """Check the key; on success set the session cookie and go on."""
    sent = api_key.strip() or None
    try:
        # bounded per address as a wrong X-API-Key is: each wrong key cost a scrypt,
        # without limit (a security review's pass)
        with wrong_keys_counted(request, sent):
            key = authenticate(session, sent, before_check=wrong_key_guard(request))
    except AuthError as exc:
        error = {"type": "AuthError", "message": exc.message, "field": "api_key",
                 "note": "Log in with a key this service issued (hydrodiag keys create)."}
        return page(request, "login.html", status_code=401, next=_safe_next(next), error=error)
    except RateLimitError as exc:
        error = {"type": "RateLimitError", "message": exc.message, "field": "api_key"}
        limited = page(request, "login.html", status_code=429, next=_safe_next(next),
                       error=error)
        limited.headers["Retry-After"] = str(exc.retry_after)
        return limited
    response = redirect(_safe_next(next))
    issue_cookie(response, request, key)
    return response


@router.post("/logout")
def logout(request: Request, session: SessionDep) -> Response:
    """Forget the login, in the browser and on the server (a copy of the cookie is
    refused from now on)."""
    end_console_session(request, session)
    response = redirect("/console/login")
    response.delete_cookie(COOKIE, path="/console")
    return response


@router.get("")
def home(_key: ConsoleKeyDep) -> Response:
    """The console starts at the rigs."""
    return redirect("/console/rigs")


#: Rigs listed on one page of the rigs page [-].
RIGS_PAGE = 500


@router.get("/rigs")
def rigs(request: Request, session: SessionDep, _key: ConsoleKeyDep,
         offset: Annotated[int, Query(ge=0, le=MAX_ID)] = 0) -> Response:
    """The rigs with their latest version, :data:`RIGS_PAGE` a page (a fleet's rigs past
    the first 500 were counted and not listed)."""
    rows, total = rig_service.rig_choices(session, limit=RIGS_PAGE, offset=offset)
    if not rows and total:  # past the last page: the last page, as the history's
        offset = (total - 1) // RIGS_PAGE * RIGS_PAGE
        rows, total = rig_service.rig_choices(session, limit=RIGS_PAGE, offset=offset)
    return page(request, "rigs.html", rows=rows, total=total, offset=offset,
                page_size=RIGS_PAGE)


def _parameters(document: dict[str, Any]) -> list[dict[str, Any]]:
    """Rows of a rig document's parameters: component, name, value, unit, source, chosen."""
    rows = []
    groups = [("fluid", document.get("fluid", {}))] + [
        (name, c.get("parameters", {})) for name, c in document.get("components", {}).items()]
    for component, params in groups:
        for name, p in params.items():
            if isinstance(p, dict) and "value" in p:
                source = str(p.get("source", ""))
                chosen = "chosen" in source.lower()
                if chosen:  # the badge says it: "chosen chosen: …" read twice (a console pass)
                    source = re.sub(r"^\s*chosen\s*:\s*", "", source, flags=re.IGNORECASE)
                unit = str(p.get("unit", ""))
                # as an engineer reads it (the README's promise): 3.4e-05 m was a spool's
                # 34 µm, 7e+06 Pa a relief's 70 bar (a maintenance planner's pass); the
                # document's own value and unit stay in the cell's title
                factor, shown = shown_unit(unit, clearance=name in CLEARANCES)
                value = p["value"]
                if isinstance(value, int | float) and shown != unit:
                    value = float(value) * factor
                rows.append({"component": component, "name": name, "value": value,
                             "unit": shown if value is not p["value"] else unit,
                             "stored": f"{p['value']} {unit}", "source": source,
                             "chosen": chosen})
    return rows


#: the parameters that are clearances (shown in µm)
CLEARANCES = ("cc", "cv")


def _calibration_chart(calibration: Any) -> Chart:
    curve = calibration_service.curve_of(calibration)
    points = list(calibration.points)
    smooth = None
    if curve is not None:
        xs = np.linspace(min(curve.opening_turns), max(curve.opening_turns), 60)
        smooth = (xs.tolist(), [float(c) for c in curve(xs.tolist(), field="opening_turns")])
    return calibration_chart(
        f"Throttle {calibration.throttle} ({calibration.component}): opening → clearance",
        [p.opening_turns for p in points], [p.clearance_m for p in points], smooth)


def _dot_svg(dot: str) -> str | None:
    """The DOT graph as SVG where graphviz' ``dot`` is installed, else ``None``."""
    exe = shutil.which("dot")
    if exe is None:
        return None
    done = subprocess.run([exe, "-Tsvg"], input=dot.encode(), capture_output=True,
                          timeout=20, check=False)
    if done.returncode != 0:
        return None
    svg = done.stdout.decode("utf-8", "replace")
    return svg[svg.index("<svg"):] if "<svg" in svg else None


@router.get("/rigs/{rig_id}")
def rig(request: Request, session: SessionDep, _key: ConsoleKeyDep,
        rig_id: Annotated[int, Path(ge=1, le=MAX_ID)],
        version_no: Annotated[int | None, Query(alias="version", ge=1, le=MAX_ID)] = None
        ) -> Response:
    """One rig: parameters, versions, throttle tables with their curves, bond graph;
    ``?version=N`` shows that version's document (a job's "stored as version N" links
    here; the page showed the latest whatever the link said: a console pass)."""
    row = rig_service.get_rig(session, rig_id)
    version = (rig_service.latest_version(session, row) if version_no is None
               else rig_service.get_version(session, rig_id, version_no))
    versions, _ = rig_service.list_versions(session, rig_id, limit=500, offset=0)
    calibrations, _ = calibration_service.list_calibrations(session, rig_id, limit=100,
                                                            offset=0)
    graph, _derivations = build_graph(str(version.document.get("circuit",
                                                               "pump-valve-cylinder")))
    dot = to_dot(graph)
    return page(request, "rig.html", rig=row, version=version, versions=versions,
                parameters=_parameters(version.document),
                calibrations=[(c, _calibration_chart(c)) for c in calibrations],
                stale={c.id for c in calibrations
                       if calibration_service.is_stale(c, row.latest_version)},
                equations=derive_equations(graph).describe(), dot=dot, dot_svg=_dot_svg(dot))


#: The console's answer to a path it does not have (it was the API's JSON 404): included
#: after every other console router.
unknown = new_router(checked=False)


@unknown.get("/{rest:path}")
def unknown_page(request: Request, _key: ConsoleKeyDep, rest: str) -> Response:
    """A console path that does not exist: the console's not-found page, with its menu
    (``/console/`` itself goes to the rigs)."""
    if not rest:
        return redirect("/console/rigs")
    raise NotFoundError(f"the console has no page /console/{rest}", field="path")
