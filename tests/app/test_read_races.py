"""Reads that a delete can overtake: the rig cache's three statements and a stored
diagnosis's read-back (a concurrency pass found both as rare 500s; these tests make the
interleaving certain instead of waiting for it)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy import delete, event, select
from sqlalchemy.engine import Engine
from sqlalchemy.engine.url import make_url
from sqlalchemy.orm import Session

from app.db import migrate
from app.db.engine import make_engine, make_session_factory
from app.db.models import Diagnosis, Rig, RigVersion
from app.schemas.diagnose import DiagnoseRequest
from app.services.bootstrap import ensure_reference_data
from app.services.diagnosis import diagnose_request
from app.services.readback import get_diagnosis, list_diagnoses, public_diagnosis
from app.services.rig_cache import RigCache
from sim.errors import NotFoundError
from sim.rigs import reference_rig
from tests.diagnostics.synth import readings


@pytest.fixture
def engine(tmp_path: Path) -> Iterator[Engine]:
    """A migrated SQLite store with the reference rig (id 1)."""
    made = make_engine(make_url(f"sqlite:///{tmp_path / 'races.db'}"))
    migrate.upgrade(made)
    with make_session_factory(made)() as session:
        ensure_reference_data(session)
    yield made
    made.dispose()


def _stored_diagnosis(session: Session) -> int:
    """Diagnose one record of a worn spool on rig 1 and store it; its diagnosis id."""
    values = readings(reference_rig(), {"valve.cv": 60e-6}, 2100.0, 40.0)
    record = {"rig_id": 1, "measured_at": "2026-03-01T08:00:00Z",
              "condition": {"oil_temperature": 40.0, "load_force": 2100.0}} | values
    diagnose_request(session, RigCache(1), DiagnoseRequest.model_validate({"record": record}))
    return int(session.scalars(select(Diagnosis.id)).one())


def test_a_rig_deleted_between_the_caches_statements_is_a_404(engine: Engine,
                                                              monkeypatch: pytest.MonkeyPatch
                                                              ) -> None:
    """The cache reads the rig row, its version row, then the document: a rig deleted
    after the second statement is "no rig with id 1" (404), never an assertion (500), and
    the cache keeps nothing for it."""
    cache = RigCache(4)
    with make_session_factory(engine)() as session:
        original = session.get

        def deleted_first(entity: Any, ident: Any, **kw: Any) -> Any:
            if entity is RigVersion:  # the delete lands between the statements
                session.execute(delete(RigVersion).where(RigVersion.rig_id == 1))
                session.execute(delete(Rig).where(Rig.id == 1))
            return original(entity, ident, **kw)

        monkeypatch.setattr(session, "get", deleted_first)
        with pytest.raises(NotFoundError) as raised:
            cache.get(session, 1)
        session.rollback()
    assert raised.value.field == "rig_id" and "no rig with id 1" in raised.value.message
    assert len(cache) == 0
    with make_session_factory(engine)() as session:  # rolled back: the rig is still there
        assert cache.get(session, 1).rig_id == 1 and len(cache) == 1


def _statements(engine: Engine) -> list[str]:
    seen: list[str] = []

    @event.listens_for(engine, "before_cursor_execute")
    def count(conn: Any, cursor: Any, statement: str, *args: Any) -> None:
        seen.append(statement)

    return seen


def test_a_stored_diagnosis_reads_back_from_what_its_own_statements_loaded(engine: Engine
                                                                           ) -> None:
    """``GET /diagnoses/{id}`` and the list: once the diagnosis is loaded, building its
    read-back issues no further statement, so a delete of its record in between cannot
    leave ``measurement`` None (a 500 five times in 30 rounds before); a diagnosis whose
    record is gone is a 404."""
    factory = make_session_factory(engine)
    with factory() as session:
        diagnosis_id = _stored_diagnosis(session)
    seen = _statements(engine)
    with factory() as session:
        row = get_diagnosis(session, diagnosis_id)
        loaded = len(seen)
        public = public_diagnosis(row)
        assert len(seen) == loaded, seen[loaded:]   # no lazy load after the read
        rows, total = list_diagnoses(session, limit=10, offset=0)
        listed = len(seen)
        assert total == 1 and [public_diagnosis(r).id for r in rows] == [diagnosis_id]
        assert len(seen) == listed, seen[listed:]
    assert public.rig_id == 1 and public.rig_version == 1
    assert public.measurement_ids == [public.measurement_id]
    with factory() as session:
        session.execute(delete(Diagnosis).where(Diagnosis.id == diagnosis_id))
        session.commit()
        with pytest.raises(NotFoundError) as raised:
            get_diagnosis(session, diagnosis_id)
    assert raised.value.field == "diagnosis_id"
