"""Key scopes over real HTTP: read < write < admin, 403 below the needed scope, rotation,
the migration that makes older keys admin, constant-time comparison, and the CLI."""

from __future__ import annotations

import hmac
from collections.abc import Iterator
from datetime import timedelta
from pathlib import Path
from typing import Any

import pytest
import sqlalchemy as sa
from typer.testing import CliRunner

from app import security
from app.cli import cli
from app.db import migrate
from app.db.base import utcnow
from app.db.engine import make_engine, make_session_factory
from app.security import Scope, generate_key
from app.services.keys import (
    MAX_GRACE_S,
    authenticate,
    create_api_key,
    revoke_api_key,
    rotate_api_key,
)
from app.settings import Settings
from sim.errors import AuthError, InputError
from sim.rigs import reference_rig_document
from tests.app.live import LiveServer, live_server, store_settings

STEADY = {"rig_id": 1, "method": "steady", "condition": {"load": 2100.0}}
RECORD = {"rig_id": 1, "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
          "pump_pressure": 14.6e5, "p1": 11.9e5, "p2": 1.2e5, "flow_B": 4.44e-4,
          "flow_C": 3.97e-4, "speed_work": 0.180, "speed_return": 0.215}


@pytest.fixture(scope="module")
def scoped(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[LiveServer, dict[str, str]]]:
    """A server (keys required) and one key of each scope."""
    with live_server(store_settings(tmp_path_factory.mktemp("scopes"))) as live:
        keys: dict[str, str] = {}
        with live.session() as session:
            for scope in Scope:
                keys[scope.value] = create_api_key(session, f"scope-{scope.value}", scope)[1]
        yield live, keys


def _as(keys: dict[str, str], scope: str) -> dict[str, str]:
    return {"X-API-Key": keys[scope]}


def _refused(response: Any, needed: str) -> None:
    assert response.status_code == 403, response.text
    error = response.json()["error"]
    assert error["type"] == "ScopeError" and error["field"] == "X-API-Key"
    assert f"scope {needed!r}" in error["message"]


def test_a_read_key_reads_and_computes_but_stores_nothing(
        scoped: tuple[LiveServer, dict[str, str]]) -> None:
    server, keys = scoped
    read = _as(keys, "read")
    before = server.row_counts()
    assert server.anon.get("/rigs", headers=read).status_code == 200
    assert server.anon.get("/rigs/1/calibrations", headers=read).status_code == 200
    assert server.anon.post("/simulate", json=STEADY, headers=read).status_code == 200
    unstored = server.anon.post("/diagnose", json={"record": RECORD, "store": False},
                                headers=read)
    assert unstored.status_code == 200, unstored.text
    _refused(server.anon.post("/diagnose", json={"record": RECORD}, headers=read), "write")
    document = reference_rig_document() | {"name": "read-key-rig"}
    _refused(server.anon.post("/rigs", json={"document": document}, headers=read), "write")
    _refused(server.anon.post("/pump-sets", json={}, headers=read), "write")
    _refused(server.anon.delete("/rigs/1", headers=read), "admin")
    assert server.row_counts() == before


def test_a_write_key_stores_but_cannot_delete(scoped: tuple[LiveServer, dict[str, str]]) -> None:
    server, keys = scoped
    write = _as(keys, "write")
    stored = server.anon.post("/diagnose", json={"record": RECORD}, headers=write)
    assert stored.status_code == 200, stored.text
    document = reference_rig_document() | {"name": "write-key-rig"}
    created = server.anon.post("/rigs", json={"document": document}, headers=write)
    assert created.status_code == 201, created.text
    rig_id = created.json()["id"]
    _refused(server.anon.delete(f"/rigs/{rig_id}", headers=write), "admin")
    assert server.anon.get(f"/rigs/{rig_id}", headers=write).status_code == 200
    assert server.anon.delete(f"/rigs/{rig_id}", headers=_as(keys, "admin")).status_code == 204
    assert server.anon.get(f"/rigs/{rig_id}", headers=write).status_code == 404


def test_scope_is_checked_after_the_key(scoped: tuple[LiveServer, dict[str, str]]) -> None:
    server, _ = scoped
    assert server.anon.delete("/rigs/1").status_code == 401
    assert server.anon.delete("/rigs/1", headers={"X-API-Key": "hd_0123456789ab_x"}
                              ).status_code == 401


def test_the_document_states_the_scope_of_each_operation(
        scoped: tuple[LiveServer, dict[str, str]]) -> None:
    server, _ = scoped
    paths = server.anon.get("/openapi.json").json()["paths"]
    for path, operations in paths.items():
        for method, operation in operations.items():
            if operation["x-hydrodiag-access"] == "open":
                assert "x-hydrodiag-scope" not in operation, (method, path)
                continue
            scope = operation["x-hydrodiag-scope"]
            if method == "get" or path in {"/simulate", "/diagnose"}:
                assert scope == "read", (method, path)
            elif method == "delete":
                assert scope == "admin", (method, path)
            else:
                assert scope == "write", (method, path)
            assert "403" in operation["responses"], (method, path)
    assert paths["/diagnose"]["post"]["x-hydrodiag-scope-store"] == "write"


def test_rotation_without_grace_revokes_the_old_key_at_once(
        scoped: tuple[LiveServer, dict[str, str]]) -> None:
    server, _ = scoped
    with server.session() as session:
        row, old_key = create_api_key(session, "rotate-now", Scope.WRITE)
        old, new, new_key = rotate_api_key(session, row.id)
        assert (new.name, new.scope) == ("rotate-now", "write")
        assert old.name == f"rotate-now.rotated-{row.id}"
    assert server.anon.get("/rigs", headers={"X-API-Key": old_key}).status_code == 401
    assert server.anon.get("/rigs", headers={"X-API-Key": new_key}).status_code == 200
    _refused(server.anon.delete("/rigs/1", headers={"X-API-Key": new_key}), "admin")


def test_rotation_with_grace_keeps_both_keys_until_revoked(
        scoped: tuple[LiveServer, dict[str, str]]) -> None:
    server, _ = scoped
    with server.session() as session:
        row, old_key = create_api_key(session, "rotate-later", Scope.READ)
        old, _, new_key = rotate_api_key(session, row.id, grace_s=3600)
        assert old.revoked_at is not None and old.revoked_at > utcnow() + timedelta(minutes=59)
    for key in (old_key, new_key):
        assert server.anon.get("/rigs", headers={"X-API-Key": key}).status_code == 200
    with server.session() as session:
        revoke_api_key(session, row.id)  # ends the grace period now
        with pytest.raises(InputError, match="revoked"):
            rotate_api_key(session, row.id)
    assert server.anon.get("/rigs", headers={"X-API-Key": old_key}).status_code == 401
    assert server.anon.get("/rigs", headers={"X-API-Key": new_key}).status_code == 200


def test_rotation_refuses_an_absurd_grace(scoped: tuple[LiveServer, dict[str, str]]) -> None:
    server, _ = scoped
    with server.session() as session:
        row, _ = create_api_key(session, "rotate-bad", Scope.READ)
        for grace in (-1.0, MAX_GRACE_S + 1.0, float("nan")):
            with pytest.raises(InputError, match="grace"):
                rotate_api_key(session, row.id, grace_s=grace)


def test_keys_made_before_scopes_become_admin(tmp_path: Path) -> None:
    engine = make_engine(sa.engine.make_url(f"sqlite:///{tmp_path / 'old.db'}"))
    migrate.upgrade(engine, "0003")
    generated = generate_key()
    with engine.begin() as connection:
        connection.execute(sa.text(
            "INSERT INTO api_keys (name, prefix, key_hash, created_at) "
            "VALUES ('old', :prefix, :hash, '2026-01-01 00:00:00')"),
            {"prefix": generated.prefix, "hash": generated.key_hash})
    migrate.upgrade(engine)
    with make_session_factory(engine)() as session:
        row = authenticate(session, generated.plaintext)
        assert row.scope == "admin"
        assert Scope(row.scope).allows(Scope.ADMIN)
    migrate.downgrade(engine, "0003")
    with engine.connect() as connection:
        columns = {c["name"] for c in sa.inspect(connection).get_columns("api_keys")}
    assert "scope" not in columns
    engine.dispose()


def test_keys_are_compared_in_constant_time(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every verification, right, wrong or of an unknown prefix, ends in
    ``hmac.compare_digest`` over two scrypt digests of equal length."""
    compared: list[tuple[int, int]] = []
    real = hmac.compare_digest

    def spy(a: bytes, b: bytes) -> bool:
        compared.append((len(a), len(b)))
        return real(a, b)

    monkeypatch.setattr(security.hmac, "compare_digest", spy)
    generated = generate_key()
    assert security.verify_key(generated.plaintext, generated.key_hash)
    assert not security.verify_key(generated.plaintext[:-1] + "!", generated.key_hash)
    assert not security.verify_unknown("hd_000000000000_guess")
    assert compared == [(32, 32)] * 3
    assert generated.plaintext not in generated.key_hash


def test_scope_order() -> None:
    assert Scope.ADMIN.allows(Scope.WRITE) and Scope.WRITE.allows(Scope.READ)
    assert not Scope.READ.allows(Scope.WRITE) and not Scope.WRITE.allows(Scope.ADMIN)



def test_cli_creates_lists_rotates_and_revokes_scoped_keys(runner: CliRunner,
                                                           tmp_path: Path) -> None:
    created = runner.invoke(cli, ["keys", "create", "--name", "plant", "--scope", "READ"])
    assert created.exit_code == 0, created.output
    key = created.stdout.strip()   # the key alone on stdout
    listed = runner.invoke(cli, ["keys", "list"]).output
    assert "plant" in listed and "read" in listed and key not in listed
    rotated = runner.invoke(cli, ["keys", "rotate", "1", "--grace", "60"])
    assert rotated.exit_code == 0, rotated.output
    new_key = rotated.stdout.strip().splitlines()[-1]
    assert new_key.startswith("hd_") and new_key != key
    engine = make_engine(Settings().url)   # the runner's store (make test-postgres: a database)
    with make_session_factory(engine)() as session:
        assert authenticate(session, key).name == "plant.rotated-1"  # in its grace period
        assert authenticate(session, new_key).scope == "read"
        assert runner.invoke(cli, ["keys", "revoke", "1"]).exit_code == 0
        with pytest.raises(AuthError):
            authenticate(session, key)
    engine.dispose()


@pytest.mark.parametrize(("args", "code", "says"), [
    (["keys", "create", "--name", "x"], 2, "--scope"),
    (["keys", "create", "--name", "x", "--scope", "root"], 2, "'root' is not one of"),
    (["keys", "rotate", "abc"], 2, "key_id"),
    (["keys", "rotate", "1", "--grace", "-5"], 1, "grace"),
    (["keys", "rotate", "9"], 1, "9"),
])
def test_cli_refuses_bad_input(runner: CliRunner, args: list[str], code: int,
                               says: str) -> None:
    assert runner.invoke(cli, ["keys", "create", "--name", "k", "--scope", "admin"]
                         ).exit_code == 0
    result = runner.invoke(cli, args)
    assert result.exit_code == code, result.output
    text = result.output + (str(result.exception) if code == 1 else "")
    assert says in text
    assert "Value error" not in text  # pydantic's prefix, which typer's enum check let through
