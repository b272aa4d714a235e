"""The one mapping from the exception tree to HTTP (app.errors)."""

from __future__ import annotations

import asyncio

import httpx
import pytest
from fastapi import FastAPI

import sim.errors as tree
from app.errors import ServiceUnavailableError, format_location, install_error_handlers, status_for

EXPECTED = {
    "HydrodiagError": 500, "InputError": 422, "ParameterError": 422, "RigFileError": 422,
    "MeasurementError": 422, "ModelStructureError": 422, "CausalityError": 422,
    "DerivativeCausalityError": 422, "AlgebraicLoopError": 422, "NotFoundError": 404,
    "ConflictError": 409, "AuthError": 401, "SimulationError": 500,
}


def test_every_class_of_the_tree_has_its_status() -> None:
    for name, status in EXPECTED.items():
        assert status_for(getattr(tree, name)("x")) == status, name
    for name in tree.__all__:  # classes added later map through their parents
        assert status_for(getattr(tree, name)("x")) in {401, 404, 409, 422, 500}, name
    assert status_for(ServiceUnavailableError("x")) == 503


@pytest.mark.parametrize(("loc", "path"), [
    (("body", "points", 2, "opening_turns"), "points[2].opening_turns"),
    (("query", "limit"), "limit"),
    (("body",), "body"),
    (("body", "quantities", "2bad", "[key]"), "quantities.2bad"),
    ((), None),
])
def test_locations_become_dotted_paths(loc: tuple[int | str, ...], path: str | None) -> None:
    assert format_location(loc) == path


def test_server_side_errors_keep_the_body_and_hide_internals() -> None:
    app = FastAPI()
    install_error_handlers(app)

    @app.get("/solver")
    def solver() -> None:
        raise tree.SimulationError("step size underflow", field="dt")

    @app.get("/bug")
    def bug() -> None:
        raise RuntimeError("secret internals")

    async def ask(path: str) -> httpx.Response:
        transport = httpx.ASGITransport(app=app, raise_app_exceptions=False)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as client:
            return await client.get(path)

    solver_response = asyncio.run(ask("/solver"))
    assert solver_response.status_code == 500
    assert solver_response.json() == {"error": {"type": "SimulationError", "field": "dt",
                                                "message": "step size underflow"}}
    bug_response = asyncio.run(ask("/bug"))
    assert bug_response.status_code == 500
    assert bug_response.json()["error"]["type"] == "InternalError"
    assert "secret" not in bug_response.text


def test_a_row_changed_under_a_write_is_a_409_not_a_500() -> None:
    """Found by the fuzzer: PATCH of a throttle table racing its DELETE raised SQLAlchemy's
    StaleDataError, answered 500."""
    from sqlalchemy.orm.exc import StaleDataError

    app = FastAPI()
    install_error_handlers(app)

    @app.patch("/row")
    def row() -> None:
        raise StaleDataError("UPDATE statement on table 'x' expected to update 1 row(s); 0 "
                             "were matched.")

    async def ask() -> httpx.Response:
        transport = httpx.ASGITransport(app=app, raise_app_exceptions=False)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as client:
            return await client.patch("/row")

    response = asyncio.run(ask())
    assert response.status_code == 409
    assert response.json()["error"]["type"] == "ConflictError"
    assert "retry" in response.json()["error"]["message"]


def test_an_unexpected_error_is_logged_once_with_its_request_id_and_not_raised_further(
        caplog: pytest.LogCaptureFixture) -> None:
    # an operator pass: the 500's body named a request_id the log line lacked, and uvicorn
    # logged the traceback a second time, as plain text (the handler ran outermost, then
    # Starlette re-raised)
    from app.errors import CatchAllMiddleware
    from app.logs import RequestLogMiddleware

    app = FastAPI()
    install_error_handlers(app)
    app.add_middleware(CatchAllMiddleware)
    app.add_middleware(RequestLogMiddleware, log=False)

    @app.get("/bug")
    def bug() -> None:
        raise RuntimeError("secret internals")

    async def ask() -> httpx.Response:
        # raise_app_exceptions=True: an exception that left the app would fail the call
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as client:
            return await client.get("/bug", headers={"X-Request-ID": "abc-123"})

    with caplog.at_level("ERROR", logger="hydrodiag.app"):
        response = asyncio.run(ask())
    assert response.status_code == 500
    assert response.json()["error"]["request_id"] == "abc-123"
    lines = [r for r in caplog.records if r.levelname == "ERROR"]
    assert len(lines) == 1 and getattr(lines[0], "request_id", None) == "abc-123"
    assert lines[0].exc_info is not None


def test_a_database_that_does_not_answer_is_a_503_with_retry_after() -> None:
    from sqlalchemy.exc import OperationalError

    app = FastAPI()
    install_error_handlers(app)

    @app.get("/store")
    def store() -> None:
        raise OperationalError("INSERT ...", {}, ConnectionError("server closed the connection"))

    async def ask() -> httpx.Response:
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as client:
            return await client.get("/store")

    response = asyncio.run(ask())
    assert response.status_code == 503 and response.headers["Retry-After"] == "5"
    error = response.json()["error"]
    assert error["type"] == "ServiceUnavailableError" and "nothing of this request" in \
        error["message"] and "INSERT" not in error["message"]
