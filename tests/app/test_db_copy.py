"""``hydrodiag db copy``: the whole store into an empty one (SQLite → PostgreSQL; an
operator pass found no way to move to PostgreSQL but a table copy "with a tool of your
choice").  The copy serves what the original served, ids and API keys included, and takes
new rows without colliding."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from sqlalchemy import func, select, text
from sqlalchemy.engine import make_url
from typer.testing import CliRunner

from app.cli import cli
from app.cli_support import store_setting
from app.db import migrate
from app.db.base import Base
from app.db.copy import copy_store
from app.db.engine import make_engine, make_session_factory
from app.settings import Settings
from sim.errors import InputError
from tests.app import postgres
from tests.app.conftest import simulated_record
from tests.app.live import LiveServer, live_server, sqlite_settings


def _fill(server: LiveServer) -> dict[str, Any]:
    """A diagnosis with its record and estimates, re-diagnosed against a second version of
    the rig (a diagnosis superseded by a later one: the copy writes rows in id order, and
    the old row names the new), a calibration table and jobs: what a store in service
    holds; returns what was read back over HTTP."""
    from tests.app.test_rediagnosis import follow, shorter_seal

    record = simulated_record(server, {"cylinder.cc": 4e-5}, measured_at="2026-11-20T10:00:00Z")
    stored = server.client.post("/diagnose", json={"record": record}, headers=server.auth)
    assert stored.status_code == 200, stored.text
    name = server.client.get("/rigs/1").json()["name"]
    assert server.client.put("/rigs/1", json={"document": shorter_seal(name)},
                             headers=server.auth).status_code == 200
    job = server.client.post("/rigs/1/rediagnose", headers=server.auth).json()["job_id"]
    assert follow(server, job)["result"]["rediagnosed"] == 1
    cal = server.client.post(
        "/rigs/1/calibrations", headers=server.auth,
        json={"throttle": "X", "component": "cylinder", "back_pressure_pa": 1.0e6,
              "temperature_c": 55.0,
              "points": [{"opening_turns": 0, "bypass_flow_m3s": 1e-6},
                         {"opening_turns": 1, "bypass_flow_m3s": 3e-6}]})
    assert cal.status_code == 201, cal.text
    return {"diagnoses": server.client.get("/diagnoses", params={"superseded": True}).json(),
            "rigs": server.client.get("/rigs").json(),
            "calibrations": server.client.get("/rigs/1/calibrations").json()}


def _counts(url: str) -> dict[str, int]:
    engine = make_engine(make_url(url))
    try:
        with engine.connect() as c:
            return {t.name: int(c.execute(select(func.count()).select_from(t)).scalar_one())
                    for t in Base.metadata.sorted_tables}
    finally:
        engine.dispose()


def _copy_and_serve(tmp_path: Path, target_url: str, target_settings: Settings) -> None:
    source = sqlite_settings(tmp_path / "old")
    with live_server(source) as server:
        before = _fill(server)
        key = dict(server.auth)
        counts = server.row_counts()
        # copied while the service runs: one snapshot
        copied = copy_store(source.url, make_url(target_url))
    assert copied.rows == counts and copied.revision == migrate.head_revision()
    assert _counts(target_url) == counts
    with live_server(target_settings) as server:
        # what the old store served, the new one serves, under the same ids
        assert server.client.get("/diagnoses", params={"superseded": True}
                                 ).json() == before["diagnoses"]
        # the new diagnosis first (the same record, the larger id), the old naming it
        assert [d["superseded_by"] for d in before["diagnoses"]["items"]] == [
            None, before["diagnoses"]["items"][0]["id"]]
        assert server.client.get("/rigs").json() == before["rigs"]
        assert server.client.get("/rigs/1/calibrations").json() == before["calibrations"]
        # the clients' API key still works, and a new diagnosis takes the next id
        record = simulated_record(server, measured_at="2026-11-21T10:00:00Z")
        again = server.client.post("/diagnose", json={"record": record}, headers=key)
        assert again.status_code == 200, again.text
        ids = [d["id"] for d in server.client.get("/diagnoses").json()["items"]]
        assert max(ids) == max(d["id"] for d in before["diagnoses"]["items"]) + 1


def test_an_sqlite_store_copied_into_an_empty_sqlite_file_serves_the_same(tmp_path: Path
                                                                          ) -> None:
    target = tmp_path / "new" / "hydrodiag.db"
    target.parent.mkdir()
    _copy_and_serve(tmp_path, f"sqlite:///{target}",
                    sqlite_settings(tmp_path / "new", database_url=f"sqlite:///{target}"))


@pytest.mark.skipif(postgres.unavailable_reason() is not None,
                    reason=str(postgres.unavailable_reason()))
def test_an_sqlite_store_copied_into_postgresql_serves_the_same(tmp_path: Path) -> None:
    with postgres.emptied_postgres_url() as url:
        _copy_and_serve(tmp_path, url, Settings(data_dir=tmp_path / "pg", database_url=url))


def _preload(runner: CliRunner) -> None:
    """The runner's store migrated and holding the reference rig."""
    from app.services.bootstrap import ensure_reference_data

    assert runner.invoke(cli, ["db", "upgrade"]).exit_code == 0
    engine = make_engine(Settings().url)
    try:
        with make_session_factory(engine)() as session:
            ensure_reference_data(session)
    finally:
        engine.dispose()


def test_a_target_that_holds_data_or_is_the_store_is_refused_and_left_as_it_was(
        runner: CliRunner, tmp_path: Path) -> None:
    _preload(runner)
    source = Settings().url
    same = runner.invoke(cli, ["db", "copy", source.render_as_string(hide_password=False)])
    assert isinstance(same.exception, InputError) and same.exception.field == "TARGET"
    # a store a service already started on (the reference rig preloaded)
    used = tmp_path / "used"
    with live_server(sqlite_settings(used)):
        pass
    used_url = f"sqlite:///{used / 'hydrodiag.db'}"
    before = _counts(used_url)
    assert before["rigs"] >= 1
    refused = runner.invoke(cli, ["db", "copy", used_url])
    assert isinstance(refused.exception, InputError) and refused.exception.field == "TARGET"
    assert "holds data" in refused.exception.message and "rigs" in refused.exception.message
    assert _counts(used_url) == before
    bad = runner.invoke(cli, ["db", "copy", "not a url"])
    assert isinstance(bad.exception, InputError) and "not a database URL" in str(bad.exception)


def test_a_store_behind_this_release_is_refused_until_upgraded(runner: CliRunner,
                                                               tmp_path: Path) -> None:
    assert runner.invoke(cli, ["db", "upgrade", "--revision", "0010"]).exit_code == 0
    target = f"sqlite:///{tmp_path / 'copy.db'}"
    behind = runner.invoke(cli, ["db", "copy", target])
    assert isinstance(behind.exception, InputError)
    assert "db upgrade" in behind.exception.message
    # the setting it was found through: the data folder, not a database URL nobody set
    # (an upgrade pass); the URL where one was set (make test-postgres)
    settings = Settings()
    assert behind.exception.field == store_setting(settings)
    named = "hydrodiag.db" if settings.database_url is None else settings.url.database
    assert f"{named} is at revision 0010" in behind.exception.message
    assert not (tmp_path / "copy.db").exists() or _counts(target) == {}
    _preload(runner)
    done = runner.invoke(cli, ["db", "copy", target])
    assert done.exit_code == 0, done.output
    said = " ".join(done.output.split())
    assert "counts checked" in said and "rows copied" in said and " 0 rows" not in said
    assert "the copy ends at the largest ids" in said  # where writes after it begin


def _rig_deleted_at_the_top(url: str) -> int:
    """A store with the reference rig and a rig made and deleted after it: the deleted
    rig's id, which no later rig may take."""
    from app.services.bootstrap import ensure_reference_data
    from app.services.rigs import create_rig, delete_rig
    from sim.rigs import reference_rig_document

    engine = make_engine(make_url(url))
    try:
        migrate.upgrade(engine)
        with make_session_factory(engine)() as session:
            ensure_reference_data(session)
            made, _ = create_rig(session, reference_rig_document() | {"name": "short-lived"})
            delete_rig(session, made.id)
            return int(made.id)
    finally:
        engine.dispose()


def _next_rig_id(url: str) -> int:
    from app.services.rigs import create_rig
    from sim.rigs import reference_rig_document

    engine = make_engine(make_url(url))
    try:
        with make_session_factory(engine)() as session:
            made, _ = create_rig(session, reference_rig_document() | {"name": "after-copy"})
            return int(made.id)
    finally:
        engine.dispose()


def test_an_id_deleted_before_the_copy_is_never_given_again(tmp_path: Path) -> None:
    """The target's counters were set past the copied rows' largest id only, so a deleted
    series' id was handed out again and a stored record that named it pointed at an
    unrelated cycle (an operator pass).  SQLite → SQLite → PostgreSQL → SQLite."""
    source = f"sqlite:///{tmp_path / 'a.db'}"
    gone = _rig_deleted_at_the_top(source)
    middle = f"sqlite:///{tmp_path / 'b.db'}"
    copy_store(make_url(source), make_url(middle))
    chain = [middle]
    if postgres.unavailable_reason() is None:
        with postgres.emptied_postgres_url() as pg:
            copy_store(make_url(middle), make_url(pg))
            back = f"sqlite:///{tmp_path / 'c.db'}"
            copy_store(make_url(pg), make_url(back))
            assert _next_rig_id(pg) > gone
            chain.append(back)
    for url in chain:
        assert _next_rig_id(url) > gone, url


def test_a_refused_target_is_left_as_it_was_and_a_missing_or_empty_store_is_not_copied(
        sqlite_runner: CliRunner, tmp_path: Path) -> None:
    """A target at an older revision holding rows was migrated and then refused; a copy or
    backup run from the wrong folder made a new, empty store and "copied 0 rows" (an
    operator pass).  SQLite only: a missing file of the folder, and its backup."""
    runner = sqlite_runner
    old = f"sqlite:///{tmp_path / 'old.db'}"
    engine = make_engine(make_url(old))
    try:
        migrate.upgrade(engine, "0011")
        with engine.begin() as c:
            c.execute(text("INSERT INTO rigs (name, title, latest_version, created_at, "
                           "updated_at) VALUES ('elsewhere', '', 1, '2026-01-01', "
                           "'2026-01-01')"))
    finally:
        engine.dispose()
    with live_server(sqlite_settings(tmp_path / "store")):
        pass
    source = sqlite_settings(tmp_path / "store").url
    with pytest.raises(InputError, match="nothing was written"):
        copy_store(source, make_url(old))
    engine = make_engine(make_url(old))
    try:
        assert migrate.current_revision(engine) == "0011"
    finally:
        engine.dispose()
    # the CLI run from a folder without a store: refused, nothing made
    for args in (["db", "copy", f"sqlite:///{tmp_path / 'x.db'}"],
                 ["db", "backup", str(tmp_path / "b.db")], ["db", "current"],
                 ["db", "revisions"]):
        missing = runner.invoke(cli, args)
        assert isinstance(missing.exception, InputError), args
        assert "no store at" in missing.exception.message
        # the folder's variable chose the store, not HYDRODIAG_DATABASE_URL (a review)
        assert missing.exception.field == "HYDRODIAG_DATA_DIR", args
    assert not (tmp_path / "hydrodiag.db").exists() and not (tmp_path / "x.db").exists()
    # a store with its schema but no row: nothing to copy
    assert runner.invoke(cli, ["db", "upgrade"]).exit_code == 0
    empty = runner.invoke(cli, ["db", "copy", f"sqlite:///{tmp_path / 'x.db'}"])
    assert isinstance(empty.exception, InputError) and "holds no rows" in str(empty.exception)


def test_target_mistakes_are_one_line_naming_what_to_fix(runner: CliRunner, tmp_path: Path
                                                         ) -> None:
    """A URL with a typo echoed its password; a weak password was copied into and serve
    then refused it; a file that is not a database and an uninstalled driver were
    tracebacks (an operator pass)."""
    _preload(runner)
    typo = runner.invoke(cli, ["db", "copy", "postgresql+psycopg//hd:S3cure-pw-44@h/db"])
    assert isinstance(typo.exception, InputError) and "S3cure" not in str(typo.exception)
    weak = runner.invoke(cli, ["db", "copy", "postgresql+psycopg://hd:changeme@h/db"])
    assert isinstance(weak.exception, InputError) and "well-known" in str(weak.exception)
    driver = runner.invoke(cli, ["db", "copy", "postgresql+asyncpg://hd:S3cure-pw-44@h/db"])
    assert isinstance(driver.exception, InputError) and "+psycopg" in str(driver.exception)
    other = runner.invoke(cli, ["db", "copy", "mysql://hd:S3cure-pw-44@h/db"])
    assert isinstance(other.exception, InputError) and "unsupported" in str(other.exception)
    junk = tmp_path / "notadb.db"
    junk.write_bytes(b"this is not a database file at all, just some text" * 100)
    refused = runner.invoke(cli, ["db", "copy", f"sqlite:///{junk}"])
    assert isinstance(refused.exception, InputError) and refused.exception.field == "TARGET"
    assert "not a database" in refused.exception.message
    # three slashes where four were meant: a relative path whose folders were made under
    # the current one, the message naming the URL, not the file (an operator pass)
    relative = runner.invoke(cli, ["db", "copy", "sqlite:///nosuch-folder-x/copy.db"])
    assert isinstance(relative.exception, InputError) and relative.exception.field == "TARGET"
    assert f"no folder {Path('nosuch-folder-x').resolve()}" in relative.exception.message
    assert not Path("nosuch-folder-x").exists()


def test_a_row_the_target_refuses_is_named_and_leaves_its_tables_empty(tmp_path: Path
                                                                      ) -> None:
    """A target whose calibration points refuse every row (a trigger added by hand):
    nothing kept, and the refusal names the table and the rows' ids (a U+0000 in a rig
    document read "unsupported Unicode escape sequence" and nothing else; an operator
    pass)."""
    source = sqlite_settings(tmp_path / "old")
    with live_server(source) as server:
        _fill(server)
    target = tmp_path / "t.db"
    engine = make_engine(make_url(f"sqlite:///{target}"))
    try:
        migrate.upgrade(engine)
        with engine.begin() as c:
            c.execute(text("CREATE TRIGGER no_points BEFORE INSERT ON calibration_points "
                           "BEGIN SELECT RAISE(ABORT, 'no points here'); END"))
    finally:
        engine.dispose()
    with pytest.raises(InputError, match=r"row of calibration_points \(id 1….*left empty: "
                       "no points here"):
        copy_store(source.url, make_url(f"sqlite:///{target}"))
    assert set(_counts(f"sqlite:///{target}").values()) == {0}
