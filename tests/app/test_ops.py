"""/health, /ready, /metrics, and the common error body for unknown routes."""

from __future__ import annotations

from pathlib import Path

import pytest

from app import __version__
from app.db import migrate
from tests.app.live import LiveServer, live_server, store_settings


def test_health(server: LiveServer) -> None:
    response = server.client.get("/health")
    assert response.status_code == 200
    assert response.json() == {"status": "ok", "version": __version__}


def test_a_warm_server_keeps_its_start_up_heap_out_of_the_collectors_sight(
        server: LiveServer) -> None:
    # full collections traversing the warm heap held the interpreter ~170 ms, and /health
    # p99 rose to ~200 ms under two trends readers (an operator pass; 31 ms frozen,
    # /work/notes/s43/health_probe.py): warm-up ends with gc.freeze()
    import gc

    assert server.client.get("/ready").status_code == 200
    assert gc.get_freeze_count() > 10_000


def test_ready_reports_the_migrated_store(server: LiveServer) -> None:
    response = server.client.get("/ready")
    assert response.status_code == 200
    from app.db.migrate import head_revision

    body = response.json()
    sweeps = body.pop("sweeps")
    assert body == {"status": "ready", "database": server.engine.dialect.name,
                    "revision": head_revision()}
    assert body["database"] in ("sqlite", "postgresql")
    # the sweeps' executor is named (a Dask pass: nothing named the scheduler): the test
    # server's local pool, whose processes are the sweep workers it was given
    assert sweeps["kind"] == "processes" and sweeps["scheduler"] is None
    assert sweeps["connection"] == "local"
    assert sweeps["workers"] == sweeps["threads"] == server.app.state.sweep_executors.capacity()
    text = server.client.get("/metrics").text
    assert 'hydrodiag_executor{kind="processes",scheduler="",connection="local"} 1' in text
    assert f'hydrodiag_executor_threads{{kind="processes"}} {sweeps["threads"]}' in text


def test_ready_is_503_while_the_store_is_behind(tmp_path: Path) -> None:
    with live_server(store_settings(tmp_path)) as live:
        migrate.downgrade(live.engine, "base")
        behind = live.client.get("/ready")
        assert behind.status_code == 503
        assert behind.json()["error"]["type"] == "ServiceUnavailableError"
        from app.db.migrate import head_revision

        assert behind.json()["error"]["message"] == (
            f"database at revision None, service needs {head_revision()}")
        assert live.client.get("/health").status_code == 200  # liveness does not touch the store
        migrate.upgrade(live.engine)
        assert live.client.get("/ready").status_code == 200


def test_metrics_count_requests_per_route_template(server: LiveServer) -> None:
    for rig_id in (1, 2, 999999):
        server.client.get(f"/rigs/{rig_id}")
    server.client.get("/no/such/route")
    server.client.get("/pump-sets/999999")  # a route with a converter: {pump_set_id:int}
    text = server.client.get("/metrics").text
    assert 'route="/pump-sets/{pump_set_id}"' in text and ":int}" not in text
    assert 'hydrodiag_http_requests_total{method="GET",route="/rigs/{rig_id}",status="404"}' \
        in text
    assert 'route="/rigs/999999"' not in text
    assert 'route="<unmatched>",status="404"' in text
    assert 'hydrodiag_http_request_duration_seconds_count{method="GET",route="/rigs/{rig_id}"}' \
        in text
    count_line = next(line for line in text.splitlines() if line.startswith(
        'hydrodiag_http_request_duration_seconds_count{method="GET",route="/rigs/{rig_id}"}'))
    assert float(count_line.split()[-1]) >= 3
    # the store's jobs by status, as one gauge line each (stuck jobs showed nowhere)
    with server.session() as session:
        from sqlalchemy import func, select

        from app.db.models import Job
        queued = session.scalar(select(func.count()).select_from(Job)
                                .where(Job.status == "queued"))
    assert f'hydrodiag_jobs{{status="queued"}} {queued}' in text
    assert 'hydrodiag_jobs{status="succeeded"}' in text
    from prometheus_client.parser import text_string_to_metric_families
    assert "hydrodiag_jobs" in {f.name for f in text_string_to_metric_families(text)}


@pytest.mark.parametrize(("method", "path", "status"), [
    ("GET", "/no/such/route", 404),
    ("DELETE", "/health", 405),
])
def test_routing_errors_have_the_common_body(
    server: LiveServer, method: str, path: str, status: int
) -> None:
    response = server.client.request(method, path)
    assert response.status_code == status
    assert set(response.json()["error"]) == {"type", "message", "field", "request_id"}
