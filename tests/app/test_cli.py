"""The command line: `serve` end to end in a subprocess, `keys` and `db` in process."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import httpx
import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.db.migrate import head_revision
from sim.errors import InputError
from tests.app import postgres
from tests.app.conftest import cli_store, first_api_key

STARTUP_TIMEOUT_S = 120.0


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@contextmanager
def _serve(data_dir: Path) -> Iterator[tuple[str, subprocess.Popen[str]]]:
    port = _free_port()
    # one server worker: these tests are about the store and the keys (several workers:
    # test_serve_workers.py), and the machine running the suite has few cores; the store is
    # the test's (cli_store: a database of its own under make test-postgres)
    env = os.environ | {"HYDRODIAG_DATA_DIR": str(data_dir), "HYDRODIAG_WORKERS": "1"}
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "--host", "127.0.0.1", "--port", str(port)],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
    )
    base_url = f"http://127.0.0.1:{port}"
    try:
        _wait_healthy(process, base_url)
        yield base_url, process
    finally:
        process.terminate()
        process.wait(timeout=30)


def _wait_healthy(process: subprocess.Popen[str], base_url: str,
                  timeout: float = STARTUP_TIMEOUT_S) -> None:
    """Poll ``/health`` until it answers 200; fail if ``process`` exits or time runs out."""
    deadline = time.monotonic() + timeout
    while True:
        if process.poll() is not None:
            raise AssertionError(f"the server exited at start-up with {process.returncode}")
        try:
            if httpx.get(f"{base_url}/health", timeout=1).status_code == 200:
                return
        except httpx.TransportError:
            pass
        if time.monotonic() > deadline:
            raise AssertionError("the server did not answer /health in time")
        time.sleep(0.1)


def _wait_ready(base_url: str) -> None:
    """Poll ``/ready`` until it answers 200 (rigs warmed), or fail after the timeout."""
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    while httpx.get(f"{base_url}/ready", timeout=5).status_code != 200:
        if time.monotonic() > deadline:
            raise AssertionError("the service did not become ready in time")
        time.sleep(0.1)


def _keys_shown(process: subprocess.Popen[str], data_dir: Path) -> list[str]:
    """The first keys ``serve`` made: one in the data folder per start that says so."""
    assert process.stdout is not None
    output = process.stdout.read()
    return [first_api_key(data_dir, output)] if "API key: " in output else []


def test_serve_migrates_preloads_and_shows_the_first_key_once(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cli_store(monkeypatch, tmp_path)   # _serve's environment: make test-postgres's database
    with _serve(tmp_path) as (base_url, process):
        assert httpx.get(f"{base_url}/rigs").status_code == 401  # a key by default
        _wait_ready(base_url)
    keys = _keys_shown(process, tmp_path)
    assert len(keys) == 1
    with _serve(tmp_path) as (base_url, process):
        rigs = httpx.get(f"{base_url}/rigs", headers={"X-API-Key": keys[0]}).json()
        assert [r["name"] for r in rigs["items"]] == ["paper002-reference"]
        document = rigs["items"][0]["document"] | {"name": "cli-rig"}
        created = httpx.post(f"{base_url}/rigs", json={"document": document},
                             headers={"X-API-Key": keys[0]})
        assert created.status_code == 201, created.text
        assert httpx.get(f"{base_url}/rigs", headers={"X-API-Key": keys[0]}
                         ).json()["total"] == 2
    assert _keys_shown(process, tmp_path) == []
    assert (tmp_path / "hydrodiag.db").exists() is ("HYDRODIAG_DATABASE_URL" not in os.environ)



def test_db_upgrade_and_current(runner: CliRunner) -> None:
    assert runner.invoke(cli, ["db", "current"]).output.strip() == ""
    result = runner.invoke(cli, ["db", "upgrade"])
    assert result.exit_code == 0, result.output
    from app.db.migrate import head_revision

    assert runner.invoke(cli, ["db", "current"]).output.strip() == head_revision() != ""


def test_keys_create_list_revoke(runner: CliRunner) -> None:
    created = runner.invoke(cli, ["keys", "create", "--name", "lab-pc", "--scope", "write"])
    assert created.exit_code == 0, created.output
    key = created.stdout.strip()   # the key alone on stdout (the new-store note: stderr)
    assert key.startswith("hd_")
    listed = runner.invoke(cli, ["keys", "list"]).output
    assert "lab-pc" in listed and key not in listed and key.split("_")[1] in listed
    duplicate = runner.invoke(cli, ["keys", "create", "--name", "lab-pc", "--scope", "read"])
    assert duplicate.exit_code != 0
    revoked = runner.invoke(cli, ["keys", "revoke", "1"])
    assert revoked.exit_code == 0, revoked.output
    assert "revoked" in revoked.output
    # a grace out of range names the option, not the API's field "grace" (a review)
    negative = runner.invoke(cli, ["keys", "rotate", "2", "--grace", "-5"])
    assert negative.exit_code == 1
    assert getattr(negative.exception, "field", None) == "--grace", negative.output


def test_bad_configuration_exits_with_a_message(runner: CliRunner,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HYDRODIAG_DATABASE_URL", "postgresql://u:password@db/x")
    result = runner.invoke(cli, ["db", "current"])
    assert result.exit_code == 2
    assert "HYDRODIAG_DATABASE_URL: the database password is a well-known default" \
        in result.output
    # the message never shows the URL: it holds the password (it printed the whole input)
    monkeypatch.setenv("HYDRODIAG_DATABASE_URL", "postgres://hd:Hd-op-pw-7731@db/hd")
    result = runner.invoke(cli, ["db", "current"])
    assert result.exit_code == 2 and "Hd-op-pw-7731" not in result.output
    assert "postgresql+psycopg://" in result.output and "Value error" not in result.output


def test_main_reports_hydrodiag_errors_without_a_traceback(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from app.cli_support import store_session

    cli_store(monkeypatch, tmp_path)
    env = dict(os.environ)
    with store_session():   # the store (keys revoke makes none: it holds no key 7)
        pass
    result = subprocess.run([sys.executable, "-m", "app.cli", "keys", "revoke", "7"],
                            env=env, capture_output=True, text=True, check=False)
    assert result.returncode == 1
    assert "NotFoundError" in result.stderr and "Traceback" not in result.stderr
    # a unit in brackets is part of the message, not rich markup
    result = subprocess.run([sys.executable, "-m", "app.cli", "import", "zema", "--rig", "1",
                             "--relaxation", "-1", "--bench", str(tmp_path / "b.csv")],
                            env=env, capture_output=True, text=True, check=False)
    assert result.returncode == 1 and "must be 0 to 60 [s]" in result.stderr, result.stderr


def test_an_unreachable_database_is_one_line_not_a_traceback(tmp_path: Path) -> None:
    # an operator pass: a database nobody listens on, or a wrong password, printed ~500
    # lines of traceback from every command
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]   # free, and nobody listens once it is closed
    env = os.environ | {"HYDRODIAG_DATA_DIR": str(tmp_path),
                        "HYDRODIAG_DATABASE_URL":
                            f"postgresql+psycopg://hd:Str0ng-pw-x@127.0.0.1:{port}/hd"}
    result = subprocess.run([sys.executable, "-m", "app.cli", "keys", "list"], env=env,
                            capture_output=True, text=True, check=False, timeout=120)
    out = result.stdout + result.stderr
    assert result.returncode == 1 and "Traceback" not in out and len(out.splitlines()) < 6
    assert "the database did not answer" in out and "Str0ng-pw-x" not in out


def _diagnose_burst(base_url: str, key: str, n: int) -> list[httpx.Response]:
    record = {"rig_id": 1, "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
              "pump_pressure": 14.6e5, "p1": 11.9e5, "p2": 1.2e5, "flow_B": 4.44e-4,
              "flow_C": 3.97e-4, "speed_work": 0.180, "speed_return": 0.215}

    def one(_: int) -> httpx.Response:
        return httpx.post(f"{base_url}/diagnose", json={"record": record},
                          headers={"X-API-Key": key}, timeout=120)

    with ThreadPoolExecutor(max_workers=n) as pool:
        return list(pool.map(one, range(n)))


def test_a_restarted_service_answers_its_first_burst(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 16 item 1: 8 concurrent first /diagnose after a restart, none may fail.

    The store and the compiled-code cache have served once; each restart is a fresh
    process that loads the compiled rig modules from the cache while the burst arrives
    (the burst starts as soon as /health answers, before /ready).
    """
    cli_store(monkeypatch, tmp_path)   # _serve's environment: make test-postgres's database
    with _serve(tmp_path) as (base_url, process):
        _wait_ready(base_url)
    key = _keys_shown(process, tmp_path)[0]
    for _restart in range(2):
        with _serve(tmp_path) as (base_url, process):
            responses = _diagnose_burst(base_url, key, 8)
            assert [r.status_code for r in responses] == [200] * 8, [
                r.text for r in responses if r.status_code != 200]
            assert len({r.json()["diagnoses"][0]["id"] for r in responses}) == 8
            _wait_ready(base_url)
            ready = httpx.get(f"{base_url}/ready").json()
            assert ready["status"] == "ready"


def test_the_uvicorn_factory_starts_on_a_fresh_folder(tmp_path: Path) -> None:
    """Issue 14: `uvicorn app.main:create_service_app --factory` migrates as serve does."""
    port = _free_port()
    env = os.environ | {"HYDRODIAG_DATA_DIR": str(tmp_path / "fresh")}
    process = subprocess.Popen(
        [sys.executable, "-m", "uvicorn", "app.main:create_service_app", "--factory",
         "--host", "127.0.0.1", "--port", str(port)],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    base_url = f"http://127.0.0.1:{port}"
    try:
        _wait_healthy(process, base_url)
        _wait_ready(base_url)
        assert httpx.get(f"{base_url}/ready").json()["revision"] == head_revision()
    finally:
        process.terminate()
        _, stderr = process.communicate(timeout=30)
    assert "Traceback" not in stderr, stderr


def _runner_store() -> tuple[str, str]:
    """The store the :func:`runner`'s CLI uses as its messages name it (the SQLite file,
    or the URL, password hidden, of its PostgreSQL database) and the variable that chose it."""
    from app.cli_support import settings_from_env, store_setting
    from app.db.engine import sqlite_path

    settings = settings_from_env()
    file = sqlite_path(settings.url)
    return (str(file) if file is not None else settings.url.render_as_string(),
            store_setting(settings))


def _no_table_made() -> bool:
    """Whether no store was made where the :func:`runner`'s CLI looked: on PostgreSQL its
    database still holds no table (an SQLite file's folder is looked at by the caller)."""
    from app.cli_support import settings_from_env
    from app.db.copy import holds_no_table
    from app.db.engine import make_engine

    url = settings_from_env().url
    if url.get_backend_name() == "sqlite":
        return True
    engine = make_engine(url)
    try:
        return holds_no_table(engine)
    finally:
        engine.dispose()


def test_a_command_that_makes_a_new_store_says_so(runner: CliRunner, tmp_path: Path) -> None:
    # an operator pass: run from another folder, 'keys create' made a key in a new, empty
    # ./data store that no running service used, and said nothing
    # a command that only reads makes none: it says where it looked (jobs list made an
    # empty store and exited 0, and a db backup there "succeeded": an operator's pass; on
    # PostgreSQL an empty database is as a missing file: it made the schema there)
    store, variable = _runner_store()
    for args in (["keys", "list"], ["jobs", "list"], ["rigs", "list"], ["rigs", "show", "1"]):
        looked = runner.invoke(cli, args)
        assert looked.exit_code != 0, args
        assert getattr(looked.exception, "field", None) == variable, args
        assert "no store at" in looked.exception.message  # type: ignore[union-attr]
    assert not (tmp_path / "data").exists() and _no_table_made()
    first = runner.invoke(cli, ["keys", "create", "--name", "here", "--scope", "read"])
    assert first.exit_code == 0 and "a new, empty store was made at" in first.output
    assert store in first.output.replace("\n", "")
    again = runner.invoke(cli, ["keys", "list"])
    assert again.exit_code == 0 and "new, empty store" not in again.output
    # rich wraps a long path anywhere: compare without the white space
    said = "".join(first.output.split())
    assert ("HYDRODIAG_DATA_DIR,default./data" if variable == "HYDRODIAG_DATA_DIR" else
            f"({variable};") in said


#: every command that reads the store or changes only what it holds, with the arguments
#: it needs (``{out}``: a folder that exists)
_ON_AN_EXISTING_STORE = {
    "calibrate tables": ["--rig", "1"], "history list": [], "history show": ["1"],
    "jobs cancel": ["3f2a"], "jobs list": [], "jobs show": ["3f2a"], "keys list": [],
    "keys revoke": ["1"], "keys rotate": ["1"],
    "report diagnosis": ["1", "--output", "{out}/r.html"],
    "report trends": ["--rig", "1", "--output", "{out}/t.csv"], "rigs list": [],
    "rigs rediagnose": ["1"], "rigs series": ["1"], "rigs show": ["1"]}


@pytest.mark.parametrize("command", sorted(_ON_AN_EXISTING_STORE))
def test_a_command_on_what_a_store_holds_makes_no_store(runner: CliRunner, tmp_path: Path,
                                                        command: str) -> None:
    """``calibrate tables``, ``report diagnosis`` and ``report trends`` run where there was
    no store made one (one stderr line said so) and listed the preloaded tables or said
    "no diagnosis with id 1" (a review's leftover): every command that only reads (or
    changes only what the store holds) says where it looked, exits 1 and makes none."""
    out = tmp_path / "out"
    out.mkdir()
    args = [a.format(out=out) for a in _ON_AN_EXISTING_STORE[command]]
    store, variable = _runner_store()
    looked = runner.invoke(cli, [*command.split(), *args])
    assert looked.exit_code == 1, looked.output
    assert getattr(looked.exception, "field", None) == variable, looked.output
    said = " ".join(looked.exception.message.split())  # type: ignore[union-attr]
    if variable == "HYDRODIAG_DATA_DIR":
        where = tmp_path.resolve() / "hydrodiag.db"
        assert f"no store at {where}: set HYDRODIAG_DATA_DIR" in said
    else:   # make test-postgres: a new, empty database
        assert f"no store at {store}: the database holds no table" in said
    assert "HYDRODIAG_DATABASE_URL" in said and "HYDRODIAG_DATA_DIR" in said
    assert list(tmp_path.iterdir()) == [out] and _no_table_made()    # nothing made


def test_the_commands_on_an_existing_store_are_commands_and_all_tested() -> None:
    """The CLI's one list of them (app.cli_support) names real commands, each tested
    above; a command that adds to the store still makes one (as simulate and diagnose,
    the README's first commands, do)."""
    from typer.main import get_command

    from app.cli_support import EXISTING_STORE_COMMANDS

    root: Any = get_command(cli)
    for path in EXISTING_STORE_COMMANDS:
        group, name = path.split()
        assert name in root.commands[group].commands, path
    assert set(_ON_AN_EXISTING_STORE) == EXISTING_STORE_COMMANDS
    assert not {"simulate", "diagnose", "rigs add", "rigs update", "keys create",
                "import series", "calibrate throttle"} & EXISTING_STORE_COMMANDS


@pytest.mark.skipif(postgres.unavailable_reason() is not None,
                    reason=str(postgres.unavailable_reason()))
def test_an_empty_postgresql_database_is_no_store(runner: CliRunner, tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """On PostgreSQL a command on what a store holds made the whole schema in whatever
    database the URL named (``jobs list`` exited 0 listing nothing, ``db copy`` said
    "migrate it first"), and a command that made a store there said nothing: an empty
    database is as a missing SQLite file (make test-postgres found it)."""
    from sqlalchemy.engine import make_url

    with postgres.emptied_postgres_url() as url:
        monkeypatch.setenv("HYDRODIAG_DATABASE_URL", url)
        for args in (["jobs", "list"], ["db", "current"],
                     ["db", "copy", f"sqlite:///{tmp_path / 'copy.db'}"]):
            looked = runner.invoke(cli, args)
            assert isinstance(looked.exception, InputError), (args, looked.output)
            assert looked.exception.field == "HYDRODIAG_DATABASE_URL", args
            assert "no store at" in looked.exception.message, args
            assert _no_table_made(), args
        made = runner.invoke(cli, ["keys", "create", "--name", "here", "--scope", "read"])
        said = "".join(made.output.split())
        assert made.exit_code == 0 and "anew,emptystorewasmadeat" in said, made.output
        assert make_url(url).render_as_string() in said and "(HYDRODIAG_DATABASE_URL;" in said
        assert runner.invoke(cli, ["jobs", "list"]).exit_code == 0


def test_a_new_store_by_url_names_the_url_variable(runner: CliRunner, tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """The store came from HYDRODIAG_DATABASE_URL: the note named HYDRODIAG_DATA_DIR (a
    user pass)."""
    monkeypatch.setenv("HYDRODIAG_DATABASE_URL", f"sqlite:///{tmp_path / 'by-url.db'}")
    first = runner.invoke(cli, ["keys", "create", "--name", "here", "--scope", "read"])
    text = "".join(first.output.split())  # rich wraps a long path anywhere
    assert first.exit_code == 0 and "by-url.db" in text
    assert "(HYDRODIAG_DATABASE_URL;" in text


def test_start_up_problems_are_one_line_and_write_nothing(tmp_path: Path) -> None:
    """An operator's pass: a busy port was found after the store was made and the first
    key printed (and, with several workers, named no port); a data folder that cannot be
    made, and db upgrade/downgrade on a store from a newer release, gave 100-281 lines of
    traceback.  Each is now one line naming what to change, with nothing written."""
    def run(args: list[str], **env: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "app.cli", *args],
                              env=os.environ | env, capture_output=True, text=True,
                              check=False, timeout=120)

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        data = tmp_path / "busy"
        result = run(["serve", "--host", "127.0.0.1", "--port", str(port)],
                     HYDRODIAG_DATA_DIR=str(data), HYDRODIAG_WORKERS="2")
    out = result.stdout + result.stderr
    assert result.returncode == 1 and "Traceback" not in out, out
    assert f"cannot listen on 127.0.0.1:{port}" in out and "HYDRODIAG_PORT" in out
    assert "API key" not in out and not (data / "hydrodiag.db").exists()
    # an option's bad value is the option's, a host that names no interface the host's
    # (both were said to be HYDRODIAG_PORT's: a CLI pass)
    for args, said in ((["--port", "0"], "--port: Input should be greater than or equal to 1"),
                       (["--host", "no-such-host.invalid", "--port", str(port)],
                        "--host: cannot listen on no-such-host.invalid: no such interface")):
        result = run(["serve", *args], HYDRODIAG_DATA_DIR=str(data))
        out = " ".join((result.stdout + result.stderr).split())
        assert result.returncode != 0 and said in out, out
        assert not (data / "hydrodiag.db").exists()
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    result = run(["keys", "create", "--name", "x", "--scope", "read"],
                 HYDRODIAG_DATA_DIR=str(blocked / "data"))
    out = result.stdout + result.stderr
    assert result.returncode == 1 and "Traceback" not in out and len(out.splitlines()) < 4
    assert "cannot make the data folder" in out and "HYDRODIAG_DATA_DIR" in out
    # a store a newer release migrated: the line serve says, from db upgrade and downgrade
    newer = tmp_path / "newer"
    assert run(["db", "upgrade"], HYDRODIAG_DATA_DIR=str(newer)).returncode == 0
    import sqlite3

    with sqlite3.connect(newer / "hydrodiag.db") as db:
        db.execute("UPDATE alembic_version SET version_num = '0099'")
    for args in (["db", "upgrade"], ["db", "downgrade", "--revision", "0013", "--yes"]):
        result = run(args, HYDRODIAG_DATA_DIR=str(newer))
        out = result.stdout + result.stderr
        assert result.returncode == 1 and "Traceback" not in out, (args, out)
        assert "is at revision 0099, which this release does not know" in out


def test_a_server_that_refused_is_not_said_to_have_been_silent() -> None:
    """A misspelt database name read "the database did not answer", which pointed at the
    network (an operator pass); libpq's own words tell the two apart."""
    from app.cli import _database_trouble

    assert _database_trouble('connection failed: FATAL:  database "nosuchdb" does not exist'
                             ) == "the database server refused the connection"
    assert _database_trouble("FATAL:  password authentication failed for user \"hd\""
                             ) == "the database server refused the connection"
    assert _database_trouble("connection failed: Connection refused") == \
        "the database did not answer"


def test_the_first_key_is_read_from_either_form_serve_shows_it_in(tmp_path: Path) -> None:
    """The benchmarks read the key from a printed line; piped, serve prints the file's path
    instead (the chaos run then fuzzed without a key and every operation read 401/429)."""
    from app.cli import first_key_shown

    key = "hd_0123456789ab_" + "k" * 43
    assert first_key_shown(f"API key: {key} (shown only now)\n") == key
    path = tmp_path / "first-api-key"
    path.write_text(key + "\n")
    assert first_key_shown(f"API key: written to {path} (readable by this user only), not "
                           "to this log; read it, keep it, delete the file\n") == key
    assert first_key_shown("store at revision 0014: sqlite:///x.db\n") is None


@pytest.mark.parametrize("encoding", ["latin-1", "ascii"])
def test_commands_run_in_a_terminal_that_is_not_utf8(tmp_path: Path, encoding: str) -> None:
    """In an ISO-8859-1 or ASCII locale every command ended in a UnicodeEncodeError (σ, …,
    ≈ on the terminal) or UnicodeDecodeError (the compiled models' cache read in the
    locale's encoding), and left .tmp files in the cache (a CLI pass)."""
    env = os.environ | {"HYDRODIAG_DATA_DIR": str(tmp_path / "data"), "LC_ALL": "C",
                        "LANG": "C", "PYTHONUTF8": "0", "PYTHONCOERCECLOCALE": "0",
                        "PYTHONIOENCODING": encoding}
    cache = Path(os.environ.get("HYDRODIAG_CACHE_DIR", ".hydrodiag-cache"))
    before = set(cache.glob("*.tmp")) if cache.exists() else set()
    for args in (["simulate", "--help"], ["simulate", "--steady", "--load", "2100"],
                 ["rigs", "show", "1"]):
        done = subprocess.run([sys.executable, "-m", "app.cli", *args], env=env,
                              capture_output=True, timeout=300)
        assert done.returncode == 0, (args, done.stderr.decode(encoding, "replace")[-2000:])
        assert b"Traceback" not in done.stderr and b"UnicodeEncodeError" not in done.stdout
    assert (set(cache.glob("*.tmp")) if cache.exists() else set()) == before
