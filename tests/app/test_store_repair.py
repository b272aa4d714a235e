"""A store an older release wrote into after its migration, and one taken back and forth.

An upgrade pass: (1) a new instance migrated the store under an older one still serving
it, whose later diagnoses were linked to no record and kept no interval, and no start
mended them; (2) ``db downgrade`` and a new migration lost every "replaced by a
re-diagnosis" mark, so history and trends counted re-diagnosed visits twice, and the
downgrade said nothing of what it would lose.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pytest
from sqlalchemy import text
from typer.testing import CliRunner

from app.cli import cli
from app.db import migrate
from app.db.engine import make_engine, make_session_factory
from app.db.models import Diagnosis
from app.services.bootstrap import upgrade_database, warn_open_file
from app.settings import Settings
from sim.errors import InputError
from tests.app.conftest import cli_store, simulated_record
from tests.app.live import live_server, sqlite_settings, store_settings


def _populated(data: Path, settings: Settings | None = None) -> list[dict[str, Any]]:
    """Two stored diagnoses of the reference rig (a worn spool, days apart); their JSON.
    The store: ``settings``' (default: the SQLite file of ``data``)."""
    with live_server(settings or sqlite_settings(data)) as server:
        out = []
        for day in ("2026-11-01", "2026-11-08"):
            record = simulated_record(server, {"valve.cv": 60e-6},
                                      measured_at=f"{day}T08:00:00Z")
            answer = server.client.post("/diagnose", json={"record": record})
            assert answer.status_code == 200, answer.text
            out.append(answer.json()["diagnoses"][0])
        return out


def test_rows_an_older_release_wrote_after_the_migration_are_mended_at_start(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    stored = _populated(tmp_path)
    engine = make_engine(sqlite_settings(tmp_path).url)
    with engine.begin() as c:    # as an older release writes: no links, no intervals
        c.execute(text("DELETE FROM diagnosis_records"))
        c.execute(text("UPDATE diagnosis_estimates SET low = NULL, high = NULL"))
        before = c.execute(text("SELECT count(*) FROM diagnosis_estimates")).scalar()
    with caplog.at_level(logging.WARNING, logger="hydrodiag.app"):
        upgrade_database(engine)
    said = " ".join(r.getMessage() for r in caplog.records)
    assert f"linked {len(stored)} diagnoses to their record" in said
    assert f"gave {before} estimates their interval" in said
    assert "stop every older instance before upgrading" in said
    with engine.connect() as c:
        links = c.execute(text("SELECT diagnosis_id, measurement_id FROM diagnosis_records "
                               "ORDER BY diagnosis_id")).all()
        assert [(d, m) for d, m in links] == [
            (d["id"], d["measurement_ids"][0]) for d in stored]
        assert c.execute(text("SELECT count(*) FROM diagnosis_estimates "
                              "WHERE low IS NULL OR high IS NULL")).scalar() == 0
        # the intervals are the ones the diagnoses stated
        valve = c.execute(text("SELECT low, high FROM diagnosis_estimates WHERE "
                               "diagnosis_id = :d AND component = 'valve'"),
                          {"d": stored[0]["id"]}).one()
    stated = next(e for e in stored[0]["estimates"] if e["component"] == "valve")
    assert (valve.low, valve.high) == pytest.approx((stated["low"], stated["high"]))
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="hydrodiag.app"):
        upgrade_database(engine)            # whole: nothing to mend, nothing said
    assert "older release" not in " ".join(r.getMessage() for r in caplog.records)
    engine.dispose()


def test_a_downgrade_says_what_it_loses_and_a_new_migration_marks_replaced_diagnoses(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # the CLI's store (a database of its own under make test-postgres), filled by a server
    cli_store(monkeypatch, tmp_path)
    settings = store_settings(tmp_path, database_url=Settings().database_url)
    stored = _populated(tmp_path, settings)
    old, new = stored[0]["id"], stored[1]["id"]
    engine = make_engine(settings.url)
    with engine.begin() as c:   # the second a re-diagnosis of the first, as rediagnose stores
        c.execute(text("UPDATE diagnoses SET superseded_by = :n WHERE id = :o"),
                  {"n": new, "o": old})
    with make_session_factory(engine)() as session:
        replacing = session.get(Diagnosis, new)
        assert replacing is not None
        replacing.result = replacing.result | {"rediagnosis_of": old}
        session.commit()
    runner = CliRunner()
    asked = runner.invoke(cli, ["db", "downgrade", "--revision", "0013"])
    assert isinstance(asked.exception, InputError) and asked.exception.field == "--yes"
    assert "1 diagnosis replaced by a re-diagnosis read as current" in asked.exception.message
    assert "intervals are dropped" not in asked.exception.message   # 0012 is not crossed
    from app.cli_db import _downgrade_losses

    deeper = _downgrade_losses(engine, "0014", "0011")
    assert any("intervals are dropped" in line for line in deeper)
    # a console session logged out works again below 0015 (its cookie's digest is dropped)
    from datetime import UTC, datetime, timedelta

    with engine.begin() as c:
        c.execute(text("INSERT INTO console_logouts (digest, expires_at) VALUES (:d, :e)"),
                  {"d": "a" * 64, "e": datetime.now(UTC) + timedelta(hours=1)})
    assert any("1 console session logged out works again" in line
               for line in _downgrade_losses(engine, "0015", "0014"))
    assert not any("console" in line for line in _downgrade_losses(engine, "0014", "0013"))
    backup = "db backup FILE" if settings.database_url is None else "(pg_dump)"
    assert backup in asked.exception.message    # the backup that backend's store takes
    done = runner.invoke(cli, ["db", "downgrade", "--revision", "0013", "--yes"])
    assert done.exit_code == 0, done.output
    assert "migrating up again marks them anew" in done.output
    migrate.upgrade(engine)
    with engine.connect() as c:
        marks = dict(c.execute(text("SELECT id, superseded_by FROM diagnoses")).all())
    assert marks == {old: new, new: None}
    # the revisions and their dates, the store's marked: which one an older release needs
    listed = runner.invoke(cli, ["db", "revisions"]).output.splitlines()
    assert listed[0].startswith("0001  2026-11-22  Initial schema")
    assert listed[-1].startswith(f"{migrate.head_revision()}  ") and "← the store" in listed[-1]
    engine.dispose()


def test_a_store_others_can_read_is_said_at_start(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """Stores made before new ones were 0600 stayed 0644 through the upgrade, without a
    word (an upgrade pass); a group the operator gave keeps its reading, unsaid."""
    engine = make_engine(sqlite_settings(tmp_path).url)
    upgrade_database(engine)
    store = Path(str(engine.url.database))
    for mode, said in ((0o644, True), (0o640, False), (0o600, False)):
        store.chmod(mode)
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="hydrodiag.app"):
            warn_open_file(engine)      # once per start: serve's and a command's
        text_of = " ".join(r.getMessage() for r in caplog.records)
        assert ("can be read by others (mode 644): chmod 600" in text_of) is said, oct(mode)
    engine.dispose()
