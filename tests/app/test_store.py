"""The store itself: migrations from empty, SQLite settings, history, preloading."""

from __future__ import annotations

from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pytest
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import Engine, inspect, select, text
from sqlalchemy.engine import make_url
from sqlalchemy.exc import IntegrityError

from app.db import migrate
from app.db.base import Base
from app.db.engine import make_engine, make_session_factory
from app.db.models import MeasuredSeries, Rig, RigVersion
from app.reference_data import REFERENCE_CALIBRATIONS
from app.services.bootstrap import ensure_first_key, ensure_reference_data
from app.services.calibrations import list_calibrations
from app.services.history import ComponentEstimate, component_history, record_diagnosis
from app.services.rigs import create_rig, delete_rig, find_rig, update_rig
from sim.errors import InputError, NotFoundError
from sim.rigs import reference_rig_document
from tests.app import postgres


def _schema_differences(engine: Engine) -> list[Any]:
    with engine.connect() as connection:
        context = MigrationContext.configure(connection, opts={"compare_type": True})
        return list(compare_metadata(context, Base.metadata))


def _check_migrations(engine: Engine) -> None:
    assert migrate.current_revision(engine) is None
    migrate.upgrade(engine)
    assert migrate.current_revision(engine) == migrate.head_revision()
    assert _schema_differences(engine) == []
    migrate.downgrade(engine, "base")
    assert set(inspect(engine).get_table_names()) == {"alembic_version"}
    migrate.upgrade(engine)
    assert _schema_differences(engine) == []


def test_migrations_from_an_empty_sqlite_file(tmp_path: Path) -> None:
    engine = make_engine(make_url(f"sqlite:///{tmp_path / 'sub' / 'fresh.db'}"))
    _check_migrations(engine)
    assert {t.name for t in Base.metadata.sorted_tables} <= set(inspect(engine).get_table_names())


def test_sqlite_connections_use_wal_and_foreign_keys(tmp_path: Path) -> None:
    engine = make_engine(make_url(f"sqlite:///{tmp_path / 'pragmas.db'}"))
    migrate.upgrade(engine)
    with engine.connect() as connection:
        assert connection.execute(text("PRAGMA journal_mode")).scalar() == "wal"
        assert connection.execute(text("PRAGMA foreign_keys")).scalar() == 1
    with pytest.raises(IntegrityError), engine.begin() as connection:
        connection.execute(text("INSERT INTO rig_versions (rig_id, version, document, "
                                "created_at) VALUES (4242, 1, '{}', '2026-01-01')"))


@pytest.fixture
def sessions(tmp_path: Path) -> Any:
    engine = make_engine(make_url(f"sqlite:///{tmp_path / 'store.db'}"))
    migrate.upgrade(engine)
    yield make_session_factory(engine)
    engine.dispose()


def test_preloading_is_idempotent_and_keeps_edits(sessions: Any) -> None:
    with sessions() as session:
        first = ensure_reference_data(session)
        assert (first.rig_created, first.calibrations_created) == (True, 2)
        rig = find_rig(session, "paper002-reference")
        assert rig is not None
        again = ensure_reference_data(session)
        assert (again.rig_created, again.calibrations_created) == (False, 0)
        _, total = list_calibrations(session, rig.id, limit=10, offset=0)
        assert total == len(REFERENCE_CALIBRATIONS)
        assert session.query(RigVersion).count() == 1


def test_preloading_keeps_published_rows_when_the_estimator_contradicts_them(
    sessions: Any,
) -> None:
    def too_small(**_: Any) -> float:
        return 1e-6  # below every published clearance

    with sessions() as session:
        ensure_reference_data(session, estimator=too_small)
        rig = find_rig(session, "paper002-reference")
        assert rig is not None
        tables, _ = list_calibrations(session, rig.id, limit=10, offset=0, throttle="H")
        assert [p.clearance_m for p in tables[0].points][-1] is None


def test_first_key_only_once(sessions: Any) -> None:
    with sessions() as session:
        key = ensure_first_key(session)
        assert key is not None and key.startswith("hd_")
        assert ensure_first_key(session) is None


def test_history_keeps_the_rig_version_and_orders_by_time(sessions: Any) -> None:
    with sessions() as session:
        ensure_reference_data(session)
        rig = find_rig(session, "paper002-reference")
        assert rig is not None
        start = datetime(2026, 3, 1, 8, 0, tzinfo=UTC)
        for days, clearance in ((30, 41e-6), (0, 35e-6)):  # stored out of order
            record_diagnosis(
                session, rig_id=rig.id, measured_at=start + timedelta(days=days),
                record={"p_pump_pa": 7.0e6}, result={"ranked": ["valve"]},
                component="valve", probability=0.7,
                estimates=[ComponentEstimate("valve", 0.7, clearance_m=clearance),
                           ComponentEstimate("cylinder", 0.2, clearance_m=85e-6)],
            )
        document = reference_rig_document()
        document["components"]["valve"]["parameters"]["cv"]["value"] = 4.5e-5
        update_rig(session, rig.id, document, comment="valve reworked")
        record_diagnosis(session, rig_id=rig.id, measured_at=start + timedelta(days=60),
                         record={}, result={}, component="valve", probability=0.6,
                         estimates=[ComponentEstimate("valve", 0.6, clearance_m=46e-6)])
        series = component_history(session, rig.id, "valve")
        assert [p.clearance_m for p in series] == [35e-6, 41e-6, 46e-6]
        assert [p.rig_version for p in series] == [1, 1, 2]
        assert series[0].measured_at == start and series[0].measured_at.tzinfo is not None
        later = component_history(session, rig.id, "valve", since=start + timedelta(days=1))
        assert len(later) == 2
        assert [p.clearance_m for p in component_history(session, rig.id, "cylinder")] == [
            85e-6, 85e-6]
        with pytest.raises(InputError):
            record_diagnosis(session, rig_id=rig.id, measured_at=start, record={}, result={},
                             component=None, probability=None,
                             estimates=[ComponentEstimate("valve"), ComponentEstimate("valve")])
        with pytest.raises(NotFoundError):
            record_diagnosis(session, rig_id=rig.id, measured_at=start, record={}, result={},
                             component=None, probability=None, rig_version=9)
        with pytest.raises(InputError, match="zone"):
            record_diagnosis(session, rig_id=rig.id, measured_at=datetime(2026, 1, 1),
                             record={}, result={}, component=None, probability=None)
        session.rollback()
        assert len(component_history(session, rig.id, "valve")) == 3
        assert session.get(Rig, rig.id) is not None


@pytest.mark.skipif(postgres.unavailable_reason() is not None,
                    reason=str(postgres.unavailable_reason()))
def test_postgresql_migrations_and_a_live_server(tmp_path: Path) -> None:
    from app.settings import Settings
    from tests.app.live import live_server

    with postgres.postgres_url() as url:
        engine = make_engine(make_url(url))
        try:
            _check_migrations(engine)
            migrate.downgrade(engine, "base")
        finally:
            engine.dispose()
        settings = Settings(data_dir=tmp_path / "data", database_url=url)
        with live_server(settings) as server:
            assert server.client.get("/ready").json()["database"] == "postgresql"
            rigs = server.client.get("/rigs").json()
            assert rigs["items"][0]["name"] == "paper002-reference"
            rig_id = rigs["items"][0]["id"]
            before = server.row_counts()
            duplicate = server.client.post(
                f"/rigs/{rig_id}/calibrations", headers=server.auth,
                json={"throttle": "I", "component": "valve", "back_pressure_pa": 1.0e6,
                      "temperature_c": 40.0,
                      "points": [{"opening_turns": 0, "bypass_flow_m3s": 1e-5},
                                 {"opening_turns": 1, "bypass_flow_m3s": 2e-5}]},
            )
            assert duplicate.status_code == 409
            assert server.row_counts() == before


def test_json_columns_round_trip_as_the_standard_library_wrote_them(sessions: Any) -> None:
    """orjson writes the JSON columns (a long series in ~1/18 of the time): the values the
    standard library's text holds (exponents may be spelled 1e-6 for 1e-06), every float
    back to the bit, numpy values as numbers, an older store's NaN token still read."""
    import json

    import numpy as np

    from app.db.engine import dumps_json, loads_json

    rng = np.random.default_rng(3)
    values = (rng.normal(size=2000) * 10.0 ** rng.integers(-12, 12, size=2000)).tolist()
    doc = {"t": values, "channels": {"P1": [0.1, 1e-300, -2.5e17, 5e-324]}, "n": 3,
           "nested": [{"a": None, "b": True}], 7: "int key"}
    assert json.loads(dumps_json(doc)) == json.loads(json.dumps(doc))
    assert loads_json(json.dumps(doc)) == loads_json(dumps_json(doc)) == json.loads(
        json.dumps(doc))
    assert loads_json(dumps_json({"x": np.float64(0.1), "y": np.arange(3)})) == {
        "x": 0.1, "y": [0, 1, 2]}
    assert dumps_json({"big": 2**70}) == json.dumps({"big": 2**70})  # beyond orjson's ints
    old = loads_json('{"chi2": NaN}')
    assert np.isnan(old["chi2"])
    with sessions() as session:
        ensure_reference_data(session)
        rig = session.scalars(select(Rig)).first()
        assert rig is not None
        row = MeasuredSeries(rig_id=rig.id, name="json",
                             record="r", sample_rate=None, n_samples=len(values),
                             measured=True, units={"P1": "Pa"}, condition={},
                             data={"t": values, "channels": {"P1": values}})
        session.add(row)
        session.commit()
        key = row.id
    with sessions() as session:
        back = session.get(MeasuredSeries, key)
        assert back is not None and back.data["t"] == values  # == on floats: bit for bit


def _counts(engine: Engine) -> dict[str, int]:
    """Rows of each table of the store's revision (0007's tables at 0007)."""
    present = set(inspect(engine).get_table_names())
    with engine.connect() as connection:
        return {t.name: connection.execute(text(f"SELECT count(*) FROM {t.name}")).scalar_one()
                for t in Base.metadata.sorted_tables if t.name in present}


def test_a_deleted_rows_id_is_never_given_again_and_the_migration_keeps_every_row(
        tmp_path: Path) -> None:
    """Revision 0007 rebuilds the SQLite tables with AUTOINCREMENT: a store filled at 0006
    keeps every row and reference (no cascade fires while a referenced table is rebuilt),
    and after it a new rig never takes the id of the newest deleted one (before, SQLite
    handed the highest freed id out again)."""
    engine = make_engine(make_url(f"sqlite:///{tmp_path / 'ids.db'}"))
    # the reference rows are made by today's model (it has columns later revisions add,
    # which its INSERTs name) and taken down to 0006 with them
    migrate.upgrade(engine)
    factory = make_session_factory(engine)
    with factory() as session:
        ensure_reference_data(session)
    migrate.downgrade(engine, "0006")
    with factory() as session:
        # a key as revision 0006 stores it (the model has columns later revisions add)
        session.execute(text("INSERT INTO api_keys (name, prefix, key_hash, scope, created_at) "
                             "VALUES ('first', 'hd_0006', 'x', 'admin', '2026-11-01')"))
        session.commit()
        rig = find_rig(session, "paper002-reference")
        assert rig is not None
        update_rig(session, rig.id, reference_rig_document() | {"title": "second version"})
    before = _counts(engine)
    assert before["rig_versions"] == 2 and before["calibration_points"] > 0
    migrate.upgrade(engine)
    # the tables later revisions add, empty
    assert _counts(engine) == before | {"diagnosis_records": 0, "idempotent_requests": 0,
                                        "console_logouts": 0}
    with engine.connect() as connection:
        assert connection.execute(text("PRAGMA foreign_keys")).scalar() == 1
        assert connection.execute(text("PRAGMA foreign_key_check")).fetchall() == []
    with factory() as session:
        made, _ = create_rig(session, reference_rig_document() | {"name": "short-lived"})
        gone = made.id
        delete_rig(session, gone)
        again, _ = create_rig(session, reference_rig_document() | {"name": "next"})
        assert again.id > gone
    after = _counts(engine)
    assert after["rigs"] == before["rigs"] + 1
    migrate.downgrade(engine, "0006")  # and back: the rows stay
    assert _counts(engine) == {k: v for k, v in after.items()
                               if k not in ("diagnosis_records", "idempotent_requests",
                                            "console_logouts")}
    engine.dispose()


def test_diagnoses_stored_before_0008_are_linked_to_their_own_record(tmp_path: Path) -> None:
    engine = make_engine(make_url(f"sqlite:///{tmp_path / 'links.db'}"))
    migrate.upgrade(engine)   # today's model names later revisions' columns: fill, go down
    with make_session_factory(engine)() as session:
        ensure_reference_data(session)
    migrate.downgrade(engine, "0007")
    with engine.begin() as connection:
        version = connection.execute(text("SELECT id FROM rig_versions")).scalar_one()
        for k in (1, 2):
            connection.execute(text(
                "INSERT INTO measurements (id, rig_id, measured_at, record, created_at) "
                "VALUES (:k, 1, '2026-01-01 00:00:00', '{}', '2026-01-01 00:00:00')"), {"k": k})
        connection.execute(text(
            "INSERT INTO diagnoses (id, measurement_id, rig_version_id, result, created_at) "
            "VALUES (7, 2, :v, '{}', '2026-01-01 00:00:00')"), {"v": version})
    migrate.upgrade(engine)
    with engine.connect() as connection:
        links = connection.execute(text("SELECT diagnosis_id, measurement_id "
                                        "FROM diagnosis_records")).all()
    assert [tuple(row) for row in links] == [(7, 2)]
    engine.dispose()


def test_estimates_stored_before_0012_get_the_interval_their_result_stated(tmp_path: Path
                                                                           ) -> None:
    """Revision 0012 fills ``diagnosis_estimates.low/high`` from each stored result (a
    trend read them out of every result's JSON before); a result without them leaves
    ``NULL``, and the trend reads the intervals from the columns."""
    from app.services.rig_cache import RigCache
    from app.services.trends import component_trends

    engine = make_engine(make_url(f"sqlite:///{tmp_path / 'intervals.db'}"))
    migrate.upgrade(engine)   # today's model names later revisions' columns: fill, go down
    with make_session_factory(engine)() as session:
        ensure_reference_data(session)
    migrate.downgrade(engine, "0011")
    stated = '{"estimates": {"valve": {"value": 4.1e-05, "low": 3.9e-05, "high": 4.3e-05}}}'
    with engine.begin() as connection:
        version = connection.execute(text("SELECT id FROM rig_versions")).scalar_one()
        for k, result in ((1, stated), (2, "{}")):
            connection.execute(text(
                "INSERT INTO measurements (id, rig_id, measured_at, record, created_at) "
                "VALUES (:k, 1, :at, '{}', :at)"), {"k": k, "at": f"2026-01-0{k} 00:00:00"})
            connection.execute(text(
                "INSERT INTO diagnoses (id, measurement_id, rig_version_id, component, result, "
                "created_at) VALUES (:k, :k, :v, 'valve', :r, '2026-01-01 00:00:00')"),
                {"k": k, "v": version, "r": result})
            connection.execute(text(
                "INSERT INTO diagnosis_estimates (diagnosis_id, component, probability, "
                "clearance_m) VALUES (:k, 'valve', 0.9, :c)"), {"k": k, "c": 4.1e-5 + k * 1e-7})
    migrate.upgrade(engine)
    with engine.connect() as connection:
        rows = connection.execute(text("SELECT diagnosis_id, low, high FROM diagnosis_estimates "
                                       "ORDER BY diagnosis_id")).all()
    assert [tuple(r) for r in rows] == [(1, 3.9e-5, 4.3e-5), (2, None, None)]
    with make_session_factory(engine)() as session:
        (valve,) = component_trends(session, RigCache(), 1, component="valve")
    assert [(p.low, p.high) for p in valve.points] == [(3.9e-5, 4.3e-5), (None, None)]
    migrate.downgrade(engine, "0011")
    assert "low" not in {c["name"] for c in inspect(engine).get_columns("diagnosis_estimates")}
    with engine.connect() as connection:  # the rebuilt table keeps revision 0007's rule
        sql = connection.execute(text("SELECT sql FROM sqlite_master WHERE name = "
                                      "'diagnosis_estimates'")).scalar_one()
    assert "AUTOINCREMENT" in sql
    engine.dispose()


def _bootstrap_together(url: str, n: int = 3) -> list[str]:
    """``n`` processes' bootstrap (migrate, preload, first key) at once on one empty store,
    as replicas started together do; returns the first keys made."""
    import threading

    from app.services.bootstrap import bootstrap_lock, upgrade_database

    keys: list[str] = []
    errors: list[BaseException] = []
    barrier = threading.Barrier(n)

    def one() -> None:
        engine = make_engine(make_url(url))
        try:
            barrier.wait()
            with bootstrap_lock(engine):
                upgrade_database(engine)
                sessions = make_session_factory(engine)
                with sessions() as session:
                    ensure_reference_data(session)
                with sessions() as session:
                    key = ensure_first_key(session)
                    if key is not None:
                        keys.append(key)
        except BaseException as exc:  # reported below
            errors.append(exc)
        finally:
            engine.dispose()

    threads = [threading.Thread(target=one) for _ in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(120)
    assert not errors, errors
    return keys


def test_replicas_bootstrapping_one_empty_store_together_make_it_once(tmp_path: Path) -> None:
    # an operator pass: two replicas started together on an empty PostgreSQL database, and
    # one exited with "ConflictError: throttle: a table for this throttle and condition
    # exists" (both preloaded)
    url = f"sqlite:///{tmp_path / 'together.db'}"
    assert len(_bootstrap_together(url)) == 1
    engine = make_engine(make_url(url))
    with make_session_factory(engine)() as session:
        rig = find_rig(session, "paper002-reference")
        assert rig is not None
        assert list_calibrations(session, rig.id, limit=100, offset=0)[1] == len(
            REFERENCE_CALIBRATIONS)
    engine.dispose()
    if postgres.unavailable_reason() is None:
        with postgres.postgres_url() as pg:
            assert len(_bootstrap_together(pg)) == 1
            engine = make_engine(make_url(pg))
            try:
                migrate.downgrade(engine, "base")
            finally:
                engine.dispose()


def test_a_store_that_cannot_serve_is_named_in_one_line_at_start(tmp_path: Path,
                                                                  monkeypatch: Any) -> None:
    """An operator pass: a damaged file, a store migrated by a newer release and a
    read-only store gave 49- to 461-line tracebacks (the read-only one after "store
    ready"); each is now one line naming the store and what to do, and serve exits 1."""
    import sqlite3

    from typer.testing import CliRunner

    from app.cli import cli
    from app.services.bootstrap import upgrade_database

    monkeypatch.setenv("HYDRODIAG_DATA_DIR", str(tmp_path))
    monkeypatch.delenv("HYDRODIAG_DATABASE_URL", raising=False)
    store = tmp_path / "hydrodiag.db"
    assert CliRunner().invoke(cli, ["db", "upgrade"]).exit_code == 0
    with sqlite3.connect(store) as connection:   # as a newer release leaves it
        connection.execute("UPDATE alembic_version SET version_num = '0099'")
    newer = CliRunner().invoke(cli, ["serve", "--port", "1"])
    assert newer.exit_code != 0 and isinstance(newer.exception, InputError)
    assert "revision 0099, which this release does not know" in newer.exception.message
    store.write_bytes(b"SQLite format 3\x00" + b"\xff" * 8000)   # a damaged file
    damaged = CliRunner().invoke(cli, ["serve", "--port", "1"])
    assert isinstance(damaged.exception, InputError)
    assert "is damaged" in damaged.exception.message and "backup" in damaged.exception.message
    # read-only (as root the file mode does not stop a write: the driver's read-only mode)
    fresh = tmp_path / "ro.db"
    engine = make_engine(make_url(f"sqlite:///{fresh}"))
    migrate.upgrade(engine)
    engine.dispose()
    elsewhere = tmp_path / "cwd"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)   # a URI filename was read as a relative path: "file:/…"
    read_only = make_engine(make_url(f"sqlite:///file:{fresh}?mode=ro&uri=true"))
    with pytest.raises(InputError, match="is read-only"):
        upgrade_database(read_only)
    read_only.dispose()
    assert list(elsewhere.iterdir()) == []
    from app.db.engine import sqlite_path

    assert sqlite_path(make_url(f"sqlite:///file:{fresh}?mode=ro&uri=true")) == fresh
    assert sqlite_path(make_url("sqlite:///file::memory:?uri=true")) is None
    assert sqlite_path(make_url("sqlite:///:memory:")) is None
    # every question of the store's file asks there: a copy or backup of a URI store found
    # "no store at …/file:/…" (the same plain-path reading, in five more places)
    from app.db.copy import existing_store

    existing_store(make_url(f"sqlite:///file:{fresh}?mode=ro&uri=true"))


@pytest.mark.skipif(postgres.unavailable_reason() is not None,
                    reason=str(postgres.unavailable_reason()))
def test_ready_answers_503_when_the_database_does_not_answer(tmp_path: Path) -> None:
    """A PostgreSQL that accepts but answers nothing held /ready for 100 s and more (an
    operator pass): here a lock another session holds on the schema's revision table
    stalls the readiness query; /ready answers 503 within its timeout, then 200 again."""
    from app.api.routes.ops import READY_TIMEOUT_S
    from app.settings import Settings
    from tests.app.live import live_server

    with postgres.emptied_postgres_url() as url, live_server(
            Settings(data_dir=tmp_path / "data", database_url=url)) as server:
        assert server.client.get("/ready").status_code == 200
        stalled, waited = _while_locked(url, "alembic_version",
                                        lambda: server.client.get("/ready", timeout=30))
        assert stalled.status_code == 503, stalled.text
        assert "did not answer" in stalled.json()["error"]["message"]
        # the readiness query gave up on its own timeout, not the client's 30 s one (the
        # answer would be a client error then); no bound on the clock here (a review)
        assert waited >= READY_TIMEOUT_S
        assert server.client.get("/ready").status_code == 200


def _while_locked(url: str, table: str, call: Callable[[], Any]) -> tuple[Any, float]:
    """What ``call`` answers while another session holds an exclusive lock on ``table``
    of the PostgreSQL store ``url``, and how long it took [s]."""
    import time

    engine = make_engine(make_url(url))
    try:
        with engine.connect() as holder:
            holder.execute(text(f"LOCK TABLE {table} IN ACCESS EXCLUSIVE MODE"))
            start = time.monotonic()
            answer = call()
            waited = time.monotonic() - start
            holder.rollback()
    finally:
        engine.dispose()
    return answer, waited


@pytest.mark.skipif(postgres.unavailable_reason() is not None,
                    reason=str(postgres.unavailable_reason()))
def test_a_request_stalled_by_another_sessions_lock_is_a_503(tmp_path: Path) -> None:
    """Requests on connections already open waited as long as a lock another session held
    (an operator pass: only /ready gave up): now they wait ``db_lock_timeout`` and answer
    503 with Retry-After, nothing stored; the bootstrap and the migrations, on the same
    engine, lift the limit for their own transaction."""
    from app.db.engine import lift_timeouts
    from app.settings import Settings
    from tests.app.live import live_server

    with postgres.emptied_postgres_url() as url, live_server(
            Settings(data_dir=tmp_path / "data", database_url=url,
                     db_lock_timeout=1.5)) as server:
        assert server.client.get("/rigs/1").status_code == 200
        stalled, waited = _while_locked(url, "rigs",
                                        lambda: server.client.get("/rigs/1", timeout=30))
        assert stalled.status_code == 503, stalled.text
        assert stalled.headers["Retry-After"] == "5"
        assert "nothing of this request was stored" in stalled.json()["error"]["message"]
        assert waited >= 1.5            # the lock was waited on for db_lock_timeout
        assert server.client.get("/rigs/1").status_code == 200
        served = make_engine(make_url(url), lock_timeout_s=1.5)
        try:
            with served.connect() as connection:
                assert connection.exec_driver_sql("SHOW lock_timeout").scalar() == "1500ms"
                assert connection.exec_driver_sql("SHOW statement_timeout").scalar() == "1min"
                lift_timeouts(connection)
                assert connection.exec_driver_sql("SHOW lock_timeout").scalar() == "0"
                connection.commit()   # SET LOCAL: the transaction's own
                assert connection.exec_driver_sql("SHOW lock_timeout").scalar() == "1500ms"
        finally:
            served.dispose()


def test_a_tables_computed_clearances_keep_their_rig_version_through_0013(tmp_path: Path
                                                                           ) -> None:
    """Revision 0013 sets ``throttle_calibrations.rig_version`` for the tables of a rig
    with one version that hold a computed clearance (the only document that can have
    computed them), leaves it null elsewhere, and its downgrade keeps AUTOINCREMENT."""
    from app.services.throttle_estimator import ThrottleClearanceEstimator

    engine = make_engine(make_url(f"sqlite:///{tmp_path / 'cal.db'}"))
    migrate.upgrade(engine)
    with make_session_factory(engine)() as session:
        ensure_reference_data(session, estimator=ThrottleClearanceEstimator())
    migrate.downgrade(engine, "0012")
    migrate.upgrade(engine)
    with engine.connect() as connection:
        rows = dict(connection.execute(text(
            "SELECT throttle, rig_version FROM throttle_calibrations")).all())
    # throttle H's fifth row is computed; throttle I's are all published
    assert rows == {"H": 1, "I": None}
    migrate.downgrade(engine, "0012")
    with engine.connect() as connection:
        sql = connection.execute(text("SELECT sql FROM sqlite_master WHERE name = "
                                      "'throttle_calibrations'")).scalar_one()
    assert "AUTOINCREMENT" in sql and "rig_version" not in sql
    engine.dispose()
