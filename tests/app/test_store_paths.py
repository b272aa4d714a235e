"""The two ways a diagnosis is stored write the same rows.

``POST /diagnose`` stores through Core statements on the group commit
(:func:`app.services.diagnosis_rows.insert_rows`, the path the load figures were measured
on); the console and ``hydrodiag diagnose`` through the ORM
(:func:`app.services.diagnosis.add_outcomes`).  A code review found the two
implementations with nothing to keep them equal: here a single record and a joint visit
go through both, at other times, and every stored column but ids and times is compared.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime
from typing import Any

import pytest
from sqlalchemy import select

from app.db.models import Diagnosis, DiagnosisEstimate, Measurement
from app.schemas.diagnose import DiagnoseRequest
from app.services.diagnosis import diagnose_request
from app.services.rig_cache import RigCache
from tests.app.conftest import simulated_record
from tests.app.live import LiveServer

_SKIP = {"record_index"}


def _stored(server: LiveServer, diagnosis_id: int) -> dict[str, Any]:
    with server.session() as session:
        d = session.get(Diagnosis, diagnosis_id)
        assert d is not None
        records = [m.record | {"rig_id": m.rig_id} for m in d.records]
        estimates = sorted(
            (e.component, e.clearance_m, e.slip_coefficient, e.probability, e.low, e.high)
            for e in session.scalars(select(DiagnosisEstimate)
                                     .where(DiagnosisEstimate.diagnosis_id == d.id)))
        kept = session.get(Measurement, d.measurement_id)
        assert kept is not None
        return {"rig_version_id": d.rig_version_id, "component": d.component,
                "probability": d.probability, "superseded_by": d.superseded_by,
                "result": {k: v for k, v in d.result.items() if k not in _SKIP},
                "records": records, "estimates": estimates,
                "kept_with": [m.id for m in d.records].index(kept.id)}


def _strip_times(rows: dict[str, Any]) -> dict[str, Any]:
    rows = dict(rows)
    rows["records"] = [{k: v for k, v in r.items() if k != "measured_at"}
                       for r in rows["records"]]
    return rows


def test_the_api_and_the_orm_store_the_same_rows(server: LiveServer) -> None:
    single = simulated_record(server, {"valve.cv": 55e-6})
    visit = [simulated_record(server, {"cylinder.cc": 110e-6}, load=load)
             for load in (2100.0, 4200.0)]
    bodies: list[dict[str, Any]] = [{"record": single}, {"records": visit, "joint": True}]
    api_ids: list[int] = []
    orm_ids: list[int] = []
    for n, body in enumerate(bodies):
        dated = _dated(body, f"2026-05-0{n + 1}T08:00:00Z")
        answer = server.client.post("/diagnose", json=dated)
        assert answer.status_code == 200, answer.text
        api_ids.append(answer.json()["diagnoses"][0]["id"])
        with server.session() as session:
            outcomes = diagnose_request(
                session, RigCache(4), DiagnoseRequest.model_validate(
                    _dated(body, f"2026-06-0{n + 1}T08:00:00Z")),
                datetime(2026, 6, 10, tzinfo=UTC))
        stored_id = outcomes[0].diagnosis_id
        assert stored_id is not None
        orm_ids.append(stored_id)
    for a, b in zip(api_ids, orm_ids, strict=True):
        api, orm = _strip_times(_stored(server, a)), _strip_times(_stored(server, b))
        _same(api, orm, f"diagnoses {a}/{b}")
    joint = _stored(server, api_ids[1])
    assert len(joint["records"]) == 2 and joint["estimates"]


#: the two computations run in different processes from different Newton starts (the
#: diagnosis processes' warm evaluators, this test's cold one): numbers agree to the
#: solvers' convergence, not bit for bit (a probability 1e-9 apart seen) [-]
REL = 1e-6


def _same(a: Any, b: Any, where: str) -> None:
    """``a`` and ``b`` equal in every key, list item, text and flag, and their numbers
    within :data:`REL` (or both not finite)."""
    if isinstance(a, dict) and isinstance(b, dict):
        assert a.keys() == b.keys(), (where, sorted(a.keys() ^ b.keys()))
        for key in a:
            _same(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, list | tuple) and isinstance(b, list | tuple):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert isinstance(a, int | float) and isinstance(b, int | float), where
        if math.isfinite(a) or math.isfinite(b):
            assert b == pytest.approx(a, rel=REL, abs=1e-300), where
    else:
        assert a == b, where


def _dated(body: dict[str, Any], when: str) -> dict[str, Any]:
    if "record" in body:
        return {"record": body["record"] | {"measured_at": when}}
    return {"records": [r | {"measured_at": when} for r in body["records"]],
            "joint": body["joint"]}
