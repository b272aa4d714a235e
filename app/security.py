"""API keys: generation, salted scrypt hashing and constant-time verification.

A key reads ``hd_<prefix>_<secret>``.  The prefix (12 hex digits) finds the stored row;
only ``scrypt(key, salt)`` is stored, with its cost parameters, so they can be raised later
without invalidating older keys.
"""

from __future__ import annotations

import base64
import functools
import hashlib
import hmac
import secrets
import threading
from collections import OrderedDict
from dataclasses import dataclass
from enum import StrEnum

__all__ = [
    "GeneratedKey",
    "Scope",
    "VerifiedKeys",
    "generate_key",
    "hash_key",
    "split_key",
    "verify_key",
    "verify_unknown",
]

_PREFIX_BYTES = 6
_SECRET_BYTES = 32
_SALT_BYTES = 16
#: scrypt cost: N = 2**12, r = 8, p = 1 (4 MiB, about 15 ms).  The secret is 256 random
#: bits, so no work factor is needed against guessing; the hash keeps a stolen store from
#: yielding usable keys, and the cost bounds what each authenticated request pays.  The
#: parameters are stored with each hash and can be raised without invalidating old keys.
_SCRYPT_N, _SCRYPT_R, _SCRYPT_P, _SCRYPT_LEN = 2**12, 8, 1, 32


class Scope(StrEnum):
    """What an API key may do; each scope includes the ones before it.

    ``read``
        Read stored things, and compute without storing (``/simulate``, ``/diagnose``
        with ``"store": false``).
    ``write``
        Also store and change things (rigs, tables, pump sets, series, stored diagnoses,
        sweeps and other jobs).
    ``admin``
        Also delete stored things and read the list of keys.
    """

    READ = "read"
    WRITE = "write"
    ADMIN = "admin"

    @property
    def rank(self) -> int:
        """Position in ``read < write < admin`` [-]."""
        return _SCOPE_ORDER.index(self)

    def allows(self, needed: Scope) -> bool:
        """Return whether a key of this scope may run an operation that needs ``needed``."""
        return self.rank >= needed.rank


_SCOPE_ORDER = (Scope.READ, Scope.WRITE, Scope.ADMIN)


@dataclass(frozen=True, slots=True)
class GeneratedKey:
    """A freshly generated key: ``plaintext`` is shown once and never stored."""

    plaintext: str
    prefix: str
    key_hash: str


def _b64(data: bytes) -> str:
    return base64.urlsafe_b64encode(data).decode("ascii").rstrip("=")


def _unb64(text: str) -> bytes:
    return base64.urlsafe_b64decode(text + "=" * (-len(text) % 4))


def _scrypt(key: str, salt: bytes, n: int, r: int, p: int, length: int) -> bytes:
    return hashlib.scrypt(
        key.encode("utf-8"), salt=salt, n=n, r=r, p=p, dklen=length, maxmem=64 * 1024 * 1024
    )


def hash_key(key: str, *, salt: bytes | None = None) -> str:
    """Hash ``key`` with scrypt and a random salt.

    Returns
    -------
    str
        ``scrypt$N$r$p$<salt>$<hash>`` with base64url salt and hash.
    """
    salt = secrets.token_bytes(_SALT_BYTES) if salt is None else salt
    digest = _scrypt(key, salt, _SCRYPT_N, _SCRYPT_R, _SCRYPT_P, _SCRYPT_LEN)
    return f"scrypt${_SCRYPT_N}${_SCRYPT_R}${_SCRYPT_P}${_b64(salt)}${_b64(digest)}"


def verify_key(key: str, stored: str) -> bool:
    """Return whether ``key`` matches the stored hash (constant-time comparison)."""
    try:
        scheme, n, r, p, salt, digest = stored.split("$")
        expected = _unb64(digest)
        if scheme != "scrypt":
            return False
        actual = _scrypt(key, _unb64(salt), int(n), int(r), int(p), len(expected))
    except ValueError:
        return False
    return hmac.compare_digest(actual, expected)


@functools.cache
def _dummy_hash() -> str:
    return hash_key("hd_000000000000_dummy", salt=b"\0" * _SALT_BYTES)


def verify_unknown(key: str) -> bool:
    """Spend the time of a verification for a key whose prefix is unknown; always false.

    An unknown prefix then costs the same time as a wrong secret.
    """
    verify_key(key, _dummy_hash())
    return False


def split_key(key: str) -> str | None:
    """Return the prefix of a well-formed key, or ``None`` if ``key`` is not one."""
    parts = key.split("_")
    if len(parts) != 3 or parts[0] != "hd" or len(parts[1]) != 2 * _PREFIX_BYTES:
        return None
    if not parts[2] or not all(c in "0123456789abcdef" for c in parts[1]):
        return None
    return parts[1]


def generate_key() -> GeneratedKey:
    """Generate a new random key and its stored hash."""
    prefix = secrets.token_hex(_PREFIX_BYTES)
    plaintext = f"hd_{prefix}_{secrets.token_urlsafe(_SECRET_BYTES).replace('_', '-')}"
    return GeneratedKey(plaintext=plaintext, prefix=prefix, key_hash=hash_key(plaintext))


class VerifiedKeys:
    """Keys this process has verified, so that scrypt runs once per key and process.

    The scrypt cost protects keys in a stolen store; paying it on every request only
    slows the service (15 ms per write).  After a key verifies against its stored hash,
    an HMAC of (key, stored hash) under a random per-process secret is kept here; a later
    request with the same key and the same stored hash is accepted on that HMAC
    (constant-time comparison).  Nothing here outlives the process, the stored hash is
    part of the HMAC (a re-hashed key verifies anew), and revocation is still read from
    the store on every request by the caller.

    Parameters
    ----------
    size
        Number of keys remembered [-]; the least recently used are forgotten.
    """

    def __init__(self, size: int = 256) -> None:
        self._secret = secrets.token_bytes(32)
        self._size = size
        self._seen: OrderedDict[int, bytes] = OrderedDict()
        self._lock = threading.Lock()

    def _tag(self, key: str, stored: str) -> bytes:
        message = key.encode("utf-8") + b"\0" + stored.encode("ascii", "replace")
        return hmac.new(self._secret, message, hashlib.sha256).digest()

    def known(self, row_id: int, key: str, stored: str) -> bool:
        """Return whether ``key`` matches ``stored`` by the remembered HMAC alone (no
        scrypt: cheap enough for the event loop); false when it was not verified yet."""
        tag = self._tag(key, stored)
        with self._lock:
            known = self._seen.get(row_id)
        return known is not None and hmac.compare_digest(known, tag)

    def verify(self, row_id: int, key: str, stored: str) -> bool:
        """Return whether ``key`` matches ``stored``, by the remembered HMAC or by scrypt."""
        tag = self._tag(key, stored)
        with self._lock:
            known = self._seen.get(row_id)
            if known is not None:
                self._seen.move_to_end(row_id)
        if known is not None and hmac.compare_digest(known, tag):
            return True
        if not verify_key(key, stored):
            return False
        with self._lock:
            self._seen[row_id] = tag
            self._seen.move_to_end(row_id)
            while len(self._seen) > self._size:
                self._seen.popitem(last=False)
        return True
