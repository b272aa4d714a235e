"""API keys: hashing, access by default and with open reads, revocation."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from app.db.models import ApiKey
from app.security import generate_key, hash_key, split_key, verify_key
from app.services.keys import create_api_key, revoke_api_key
from tests.app.live import LiveServer, live_server, store_settings


def test_hashes_are_salted_and_verify_only_the_right_key() -> None:
    generated = generate_key()
    assert split_key(generated.plaintext) == generated.prefix
    assert generated.plaintext not in generated.key_hash
    assert generated.key_hash.startswith("scrypt$4096$8$1$")
    assert verify_key(generated.plaintext, generated.key_hash)
    assert not verify_key(generated.plaintext + "x", generated.key_hash)
    assert hash_key(generated.plaintext) != hash_key(generated.plaintext)  # fresh salt
    assert not verify_key(generated.plaintext, "pbkdf2$1$2$3$4$5")
    assert not verify_key(generated.plaintext, "garbage")


@pytest.mark.parametrize("key", ["", "hd_short_x", "xx_0123456789ab_secret",
                                 "hd_0123456789ab_", "hd_0123456789AB_secret"])
def test_malformed_keys_have_no_prefix(key: str) -> None:
    assert split_key(key) is None


def test_only_hashes_are_stored(server: LiveServer) -> None:
    with server.session() as session:
        stored = [row.key_hash for row in session.query(ApiKey)]
    assert stored and all(server.key not in h and h.startswith("scrypt$") for h in stored)


@pytest.fixture
def closed(server: LiveServer) -> LiveServer:
    """The module's server: default settings, so every operation but three needs a key."""
    assert server.settings.open_reads is False
    return server


@pytest.fixture(scope="module")
def open_reads(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    settings = store_settings(tmp_path_factory.mktemp("open"), open_reads=True)
    with live_server(settings) as live:
        yield live


READS = ["/rigs", "/rigs/1", "/rigs/1/versions", "/rigs/1/calibrations", "/pump-sets", "/jobs",
         "/rigs/1/trends"]
STEADY = {"rig_id": 1, "method": "steady", "condition": {"load": 2100.0}}


@pytest.mark.parametrize("path", READS)
def test_reads_need_a_key_by_default(closed: LiveServer, path: str) -> None:
    refused = closed.anon.get(path)
    assert refused.status_code == 401
    assert refused.json()["error"]["type"] == "AuthError"
    assert refused.headers["WWW-Authenticate"] == "APIKey"
    assert closed.client.get(path).status_code == 200


def test_cpu_heavy_operations_need_a_key_by_default(closed: LiveServer) -> None:
    before = closed.row_counts()
    assert closed.anon.post("/simulate", json=STEADY).status_code == 401
    record = {"rig_id": 1, "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
              "p1": 11.9e5}
    assert closed.anon.post("/diagnose", json={"record": record, "store": False}
                            ).status_code == 401
    assert closed.client.post("/simulate", json=STEADY).status_code == 200
    assert closed.row_counts() == before


@pytest.mark.parametrize("path", ["/health", "/ready", "/metrics", "/openapi.json", "/docs"])
def test_operations_and_docs_stay_open(closed: LiveServer, path: str) -> None:
    assert closed.anon.get(path).status_code == 200


@pytest.mark.parametrize("path", READS)
def test_open_reads_is_an_explicit_setting(open_reads: LiveServer, path: str) -> None:
    assert open_reads.anon.get(path).status_code == 200


def test_open_reads_never_opens_writes(open_reads: LiveServer) -> None:
    assert open_reads.anon.post("/simulate", json=STEADY).status_code == 200
    assert open_reads.anon.post("/pump-sets", json={}).status_code == 401
    assert open_reads.anon.delete("/rigs/1").status_code == 401


def test_the_document_states_the_access_of_each_operation(closed: LiveServer,
                                                          open_reads: LiveServer) -> None:
    default = closed.anon.get("/openapi.json").json()["paths"]
    opened = open_reads.anon.get("/openapi.json").json()["paths"]
    for path, operations in default.items():
        for method, operation in operations.items():
            access = operation["x-hydrodiag-access"]
            twin = opened[path][method]
            assert twin["x-hydrodiag-access"] == access
            if path in {"/health", "/ready", "/metrics"}:
                assert access == "open" and "security" not in operation, (method, path)
                continue
            assert operation["security"] == [{"APIKeyHeader": []}], (method, path)
            assert "401" in operation["responses"], (method, path)
            if method in {"get"} or path in {"/simulate", "/diagnose"}:
                assert access == "open-reads", (method, path)
                assert twin["security"] == [{}, {"APIKeyHeader": []}], (method, path)
            else:
                assert access == "key", (method, path)
                assert twin["security"] == [{"APIKeyHeader": []}], (method, path)


def test_revoked_keys_stop_working(closed: LiveServer) -> None:
    with closed.session() as session:
        row, key = create_api_key(session, "to-revoke")
    assert closed.anon.get("/rigs", headers={"X-API-Key": key}).status_code == 200
    with closed.session() as session:
        revoke_api_key(session, row.id)
    assert closed.anon.get("/rigs", headers={"X-API-Key": key}).status_code == 401
    assert closed.anon.get("/rigs", headers=closed.auth).status_code == 200


def test_verified_keys_skip_scrypt_only_for_the_same_key_and_hash() -> None:
    from app.security import VerifiedKeys

    first, second = generate_key(), generate_key()
    verified = VerifiedKeys(size=1)
    assert verified.verify(1, first.plaintext, first.key_hash)
    assert verified.verify(1, first.plaintext, first.key_hash)  # remembered
    assert not verified.verify(1, first.plaintext + "x", first.key_hash)
    # the same row id with another stored hash (another store, a re-hashed key) verifies anew
    assert not verified.verify(1, first.plaintext, second.key_hash)
    assert verified.verify(1, second.plaintext, second.key_hash)
    assert verified.verify(2, first.plaintext, first.key_hash)  # size 1: row 1 forgotten
    assert not verified.verify(2, second.plaintext, first.key_hash)


def test_cors_is_closed_by_default(closed: LiveServer) -> None:
    origin = {"Origin": "http://elsewhere.example"}
    preflight = closed.anon.options("/rigs", headers=origin | {
        "Access-Control-Request-Method": "GET"})
    assert "access-control-allow-origin" not in preflight.headers
    read = closed.client.get("/rigs", headers=origin)
    assert read.status_code == 200 and "access-control-allow-origin" not in read.headers
