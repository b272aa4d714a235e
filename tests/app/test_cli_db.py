"""``hydrodiag db``: upgrade only forward, downgrade on request, backup of a live store."""

from __future__ import annotations

import threading
from pathlib import Path

from sqlalchemy import text
from typer.testing import CliRunner

from app.cli import cli
from app.db import migrate
from app.db.engine import make_engine, make_session_factory
from app.services.bootstrap import ensure_reference_data
from app.settings import Settings
from sim.errors import InputError


def test_upgrade_goes_forward_only_and_downgrade_asks_first(runner: CliRunner) -> None:
    assert runner.invoke(cli, ["db", "upgrade"]).exit_code == 0
    head = migrate.head_revision()
    # an older target did nothing, silently (an operator pass)
    back = runner.invoke(cli, ["db", "upgrade", "--revision", "0010"])
    assert isinstance(back.exception, InputError) and back.exception.field == "--revision"
    assert f"at revision {head}, past 0010" in back.exception.message
    unknown = runner.invoke(cli, ["db", "upgrade", "--revision", "9999"])
    assert isinstance(unknown.exception, InputError) and "unknown revision" in str(
        unknown.exception)
    unasked = runner.invoke(cli, ["db", "downgrade", "--revision", "0010"])
    assert isinstance(unasked.exception, InputError) and unasked.exception.field == "--yes"
    done = runner.invoke(cli, ["db", "downgrade", "--revision", "0010", "--yes"])
    assert done.exit_code == 0, done.output
    assert runner.invoke(cli, ["db", "current"]).output.strip() == "0010"
    assert runner.invoke(cli, ["db", "upgrade"]).exit_code == 0
    assert runner.invoke(cli, ["db", "current"]).output.strip() == head


def test_a_backup_is_a_whole_copy_made_while_another_connection_writes(
        sqlite_runner: CliRunner, tmp_path: Path) -> None:
    # SQLite only: db backup copies the SQLite file (PostgreSQL's is pg_dump's)
    runner = sqlite_runner
    assert runner.invoke(cli, ["db", "upgrade"]).exit_code == 0
    engine = make_engine(Settings().url)
    with make_session_factory(engine)() as session:
        ensure_reference_data(session)
    stop = threading.Event()

    def writer() -> None:   # a service taking writes meanwhile
        with engine.connect() as connection:
            while not stop.is_set():
                connection.execute(text("UPDATE rigs SET name = name"))
                connection.commit()

    thread = threading.Thread(target=writer)
    thread.start()
    try:
        copy = tmp_path / "copy.db"
        made = runner.invoke(cli, ["db", "backup", str(copy)])
        assert made.exit_code == 0, made.output
        assert "integrity ok" in made.output
    finally:
        stop.set()
        thread.join()
    copied = make_engine(Settings().url.set(database=str(copy)))
    with copied.connect() as c, engine.connect() as live:
        for table in ("rigs", "rig_versions", "calibration_points"):
            assert c.execute(text(f"SELECT count(*) FROM {table}")).scalar() == \
                live.execute(text(f"SELECT count(*) FROM {table}")).scalar() > 0
        assert migrate.current_revision(copied) == migrate.head_revision()
    copied.dispose()
    engine.dispose()
    again = runner.invoke(cli, ["db", "backup", str(copy)])   # never over a file
    assert isinstance(again.exception, InputError) and again.exception.field == "FILE"


def test_a_new_store_and_its_backup_are_readable_by_their_owner_only(
        sqlite_runner: CliRunner, tmp_path: Path) -> None:
    """The store (key hashes, every record) and its backups were created world-readable,
    the console's secret beside them 0600 (an operator's pass); a store whose operator set
    its mode keeps it, and its backup takes it."""
    import stat

    runner = sqlite_runner   # SQLite only: the modes of the store's file and its backups
    assert runner.invoke(cli, ["db", "upgrade"]).exit_code == 0
    store = Path(str(Settings().url.database))
    assert stat.S_IMODE(store.stat().st_mode) == 0o600
    backup = tmp_path / "backup.db"
    assert runner.invoke(cli, ["db", "backup", str(backup)]).exit_code == 0
    assert stat.S_IMODE(backup.stat().st_mode) == 0o600
    store.chmod(0o640)                                     # a backup agent's group may read
    shared = tmp_path / "shared.db"
    assert runner.invoke(cli, ["db", "backup", str(shared)]).exit_code == 0
    assert stat.S_IMODE(shared.stat().st_mode) == 0o640
    assert stat.S_IMODE(store.stat().st_mode) == 0o640      # left as its operator set it
