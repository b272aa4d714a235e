"""API keys: hashing, closed reads, revocation."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from app.db.models import ApiKey
from app.security import generate_key, hash_key, split_key, verify_key
from app.services.keys import create_api_key, revoke_api_key
from tests.app.live import LiveServer, live_server, sqlite_settings


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


@pytest.fixture(scope="module")
def closed(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    settings = sqlite_settings(tmp_path_factory.mktemp("closed"), open_reads=False)
    with live_server(settings) as live:
        yield live


@pytest.mark.parametrize("path", ["/rigs", "/rigs/1", "/rigs/1/versions", "/rigs/1/calibrations",
                                  "/pump-sets", "/jobs", "/metrics"])
def test_closed_reads_need_a_key(closed: LiveServer, path: str) -> None:
    refused = closed.client.get(path)
    assert refused.status_code == 401
    assert refused.json()["error"]["type"] == "AuthError"
    assert closed.client.get(path, headers=closed.auth).status_code == 200


def test_health_and_ready_stay_open(closed: LiveServer) -> None:
    assert closed.client.get("/health").status_code == 200
    assert closed.client.get("/ready").status_code == 200


def test_revoked_keys_stop_working(closed: LiveServer) -> None:
    with closed.session() as session:
        row, key = create_api_key(session, "to-revoke")
    assert closed.client.get("/rigs", headers={"X-API-Key": key}).status_code == 200
    with closed.session() as session:
        revoke_api_key(session, row.id)
    assert closed.client.get("/rigs", headers={"X-API-Key": key}).status_code == 401
    assert closed.client.get("/rigs", headers=closed.auth).status_code == 200


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
