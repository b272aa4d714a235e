"""API keys in the store: create (shown once), authenticate, list, revoke, rotate.

Each key has a scope (:class:`app.security.Scope`: ``read`` < ``write`` < ``admin``).  A
key stops working at its ``revoked_at``: the moment of :func:`revoke_api_key`, or, for a
key replaced by :func:`rotate_api_key` with a grace period, the end of that period (so
that clients can switch to the new key without a gap).
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Sequence
from datetime import UTC, datetime, timedelta
from typing import Any, NamedTuple

from sqlalchemy import Engine, bindparam, func, or_, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from app.db.base import utcnow
from app.db.models import ApiKey
from app.security import Scope, VerifiedKeys, generate_key, split_key, verify_unknown
from app.services.common import commit, get_or_raise
from sim.errors import AuthError, ConflictError, InputError

__all__ = ["MAX_GRACE_S", "authenticate", "authenticate_on_loop", "count_active_keys",
           "create_api_key", "is_revoked", "list_api_keys", "revoke_api_key", "rotate_api_key"]

API_KEY_HEADER = "X-API-Key"

#: Longest grace period of a rotated key [s] (7 days).
MAX_GRACE_S = 7 * 24 * 3600

#: Longest key name [characters] (the column's width).
MAX_NAME_LENGTH = 100

#: Keys verified by this process (scrypt once per key; see :class:`VerifiedKeys`).
_VERIFIED = VerifiedKeys()


def is_revoked(row: ApiKey, now: datetime | None = None) -> bool:
    """Return whether ``row`` has stopped working at ``now`` (default: the present)."""
    return row.revoked_at is not None and row.revoked_at <= (now or utcnow())


def _check_name(session: Session, name: str) -> str:
    name = name.strip()
    if not name or len(name) > MAX_NAME_LENGTH or not name.isprintable():
        raise InputError(f"a key name is 1 to {MAX_NAME_LENGTH} printable characters",
                         field="name")
    if session.scalar(select(func.count()).select_from(ApiKey).where(ApiKey.name == name)):
        raise ConflictError(f"a key named {name!r} exists", field="name")
    return name


def create_api_key(session: Session, name: str,
                   scope: Scope = Scope.ADMIN) -> tuple[ApiKey, str]:
    """Create a key called ``name`` with ``scope``.

    The default scope is ``admin`` (the first-start key, keys made by tests); the CLI asks
    for the scope explicitly.

    Returns
    -------
    row, plaintext
        The stored row (hash only) and the key itself, which is never stored or shown again.

    Raises
    ------
    InputError
        ``name`` is empty, too long or not printable.
    ConflictError
        A key with this name exists.
    """
    name = _check_name(session, name)
    generated = generate_key()
    row = ApiKey(name=name, prefix=generated.prefix, key_hash=generated.key_hash,
                 scope=Scope(scope).value)
    session.add(row)
    commit(session, conflict=f"a key named {name!r} exists", field="name")
    return row, generated.plaintext


def authenticate(session: Session, key: str | None,
                 before_check: Callable[[], None] | None = None) -> ApiKey:
    """Return the active key row matching ``key``.

    Raises
    ------
    AuthError
        ``key`` is missing, malformed, unknown, wrong or revoked (one message for all but
        the first, so that a caller learns nothing about which).
    """
    if not key:
        raise AuthError(f"this request needs an API key in the {API_KEY_HEADER} header",
                        field=API_KEY_HEADER)
    prefix = split_key(key)
    row = None if prefix is None else session.scalar(select(ApiKey).where(ApiKey.prefix == prefix))
    if before_check is not None and (row is None or not _VERIFIED.known(row.id, key,
                                                                        row.key_hash)):
        before_check()   # a derivation costs ~13 ms of CPU: the caller may refuse it
    valid = verify_unknown(key) if row is None else _VERIFIED.verify(row.id, key,
                                                                     row.key_hash)
    if row is None or not valid or is_revoked(row):
        raise AuthError("the API key is not valid", field=API_KEY_HEADER)
    return row


_KEY_COLUMNS = select(ApiKey.id, ApiKey.name, ApiKey.prefix, ApiKey.scope, ApiKey.key_hash,
                      ApiKey.revoked_at)

#: The key's row by its prefix, one statement built once: its compiled form is found in the
#: engine's cache without walking a new statement (a new ``where(prefix == literal)`` per
#: request cost ~0.3 ms of cache-key generation, the most of a key check; issue 9).
_KEY_BY_PREFIX = _KEY_COLUMNS.where(ApiKey.prefix == bindparam("prefix"))

#: The same read in SQLite's SQL, for :func:`_key_row_sqlite`.
_KEY_SQL = ("SELECT id, name, prefix, scope, key_hash, revoked_at FROM api_keys "
            "WHERE prefix = ?")


class KeyRow(NamedTuple):
    """The columns of a key that a request's check needs."""

    id: int
    name: str
    prefix: str
    scope: str
    key_hash: str
    revoked_at: datetime | None


def _key_row(engine: Engine, prefix: str) -> KeyRow | None:
    with engine.connect() as connection:
        row = connection.execute(_KEY_BY_PREFIX, {"prefix": prefix}).first()
    return None if row is None else KeyRow(*row)


#: Per engine, the SQLite driver connection that event loop reads keys with.
_LOOP_CONNECTIONS: weakref.WeakKeyDictionary[Engine, Any] = weakref.WeakKeyDictionary()


def _stored_time(value: str | None) -> datetime | None:
    """A time as SQLite keeps a :class:`~app.db.base.UTCDateTime` (UTC, no zone) [UTC]."""
    if value is None:
        return None
    moment = datetime.fromisoformat(value)
    return moment.replace(tzinfo=UTC) if moment.tzinfo is None else moment.astimezone(UTC)


def _key_row_sqlite(engine: Engine, prefix: str) -> KeyRow | None:
    """:func:`_key_row` on SQLite with the driver alone, on a connection of the event loop
    kept for it: ~10 µs, against ~0.1 ms for a connection of the pool and the statement's
    result processing (issue 9).  The read runs outside any transaction (autocommit), so it
    sees every commit made before it: a revoked key stops at once."""
    connection = _LOOP_CONNECTIONS.get(engine)
    if connection is None:
        connection = _LOOP_CONNECTIONS.setdefault(engine, engine.raw_connection())
    cursor = connection.cursor()
    try:
        row = cursor.execute(_KEY_SQL, (prefix,)).fetchone()
    finally:
        cursor.close()
    if connection.driver_connection.in_transaction:  # never hold a snapshot between reads
        connection.rollback()
    if row is None:
        return None
    return KeyRow(row[0], row[1], row[2], row[3], row[4], _stored_time(row[5]))


async def authenticate_on_loop(engine: Engine, key: str | None,
                               before_check: Callable[[], None] | None = None) -> KeyRow:
    """:func:`authenticate` for an ``async`` route, without a thread hand-off when it can.

    On SQLite the key's row is read on the event loop (one indexed read of a local file,
    tens of microseconds: less than the thread hand-off it spares, whose cost on a busy
    server is the event loop's interpreter lock); a key this process has verified before
    is accepted by its HMAC (:meth:`VerifiedKeys.known`).  Only a first verification
    (scrypt, ~15 ms) or another database runs in a thread.  Revocation is read from the
    store on every call, as :func:`authenticate` does.

    Returns
    -------
    KeyRow
        ``id``, ``name``, ``prefix``, ``scope``, ``key_hash``, ``revoked_at`` of the key.

    Raises
    ------
    AuthError
        As :func:`authenticate`.
    """
    if not key:
        raise AuthError(f"this request needs an API key in the {API_KEY_HEADER} header",
                        field=API_KEY_HEADER)
    prefix = split_key(key)
    row = None
    if prefix is not None:
        row = (_key_row_sqlite(engine, prefix) if engine.dialect.name == "sqlite"
               else await run_in_threadpool(_key_row, engine, prefix))
    known = row is not None and _VERIFIED.known(row.id, key, row.key_hash)
    if not known and before_check is not None:
        before_check()   # a derivation costs ~13 ms of CPU: the caller may refuse it
    if row is None:
        valid = await run_in_threadpool(verify_unknown, key)
    else:
        valid = known or await run_in_threadpool(_VERIFIED.verify, row.id, key, row.key_hash)
    if row is None or not valid or (row.revoked_at is not None
                                    and row.revoked_at <= utcnow()):
        raise AuthError("the API key is not valid", field=API_KEY_HEADER)
    return row


def list_api_keys(session: Session) -> Sequence[ApiKey]:
    """Return every key row (hashes only), oldest first."""
    return session.scalars(select(ApiKey).order_by(ApiKey.id)).all()


def count_active_keys(session: Session) -> int:
    """Return how many keys are not revoked (a rotated key in its grace period is not)."""
    statement = select(func.count()).select_from(ApiKey).where(
        or_(ApiKey.revoked_at.is_(None), ApiKey.revoked_at > utcnow()))
    return int(session.scalar(statement) or 0)


def revoke_api_key(session: Session, key_id: int) -> ApiKey:
    """Revoke key ``key_id``; it stops working at once (a grace period ends now) and stays
    listed."""
    row = get_or_raise(session, ApiKey, key_id, what="API key", field="key_id")
    if not is_revoked(row):
        row.revoked_at = utcnow()
        commit(session, conflict=f"key {key_id} changed concurrently")
    return row


def rotate_api_key(session: Session, key_id: int, *,
                   grace_s: float = 0.0) -> tuple[ApiKey, ApiKey, str]:
    """Replace key ``key_id`` by a new key with the same name and scope.

    The old row is renamed ``<name>.rotated-<id>`` and stops working after ``grace_s``
    (at once for 0, the default); the new key takes the name and the old key's rotation
    chain (``lineage_id``), which owns the ``Idempotency-Key`` answers of both: a retry
    sent with the new key is replayed, not run again.

    Parameters
    ----------
    grace_s
        How long the old key keeps working [s], 0 to :data:`MAX_GRACE_S`.

    Returns
    -------
    old, new, plaintext
        The old row, the new row and the new key (shown once, never stored).

    Raises
    ------
    NotFoundError
        No key ``key_id``.
    InputError
        ``grace_s`` is out of range, or the key is revoked already (nothing to rotate).
    """
    if not 0 <= grace_s <= MAX_GRACE_S:
        raise InputError(f"the grace period must be 0 to {MAX_GRACE_S} s, not {grace_s}",
                         field="grace")
    old = get_or_raise(session, ApiKey, key_id, what="API key", field="key_id")
    now = utcnow()
    if is_revoked(old, now):
        raise InputError(f"key {key_id} is revoked; create a new key instead", field="key_id")
    name = old.name
    old.name = f"{name[:MAX_NAME_LENGTH - 24]}.rotated-{old.id}"
    end = now + timedelta(seconds=grace_s)
    old.revoked_at = end if old.revoked_at is None else min(old.revoked_at, end)
    try:
        session.flush()  # the old row frees the name before the new row takes it
    except IntegrityError as exc:
        session.rollback()
        raise ConflictError(f"a key named {old.name!r} exists", field="key_id") from exc
    generated = generate_key()
    new = ApiKey(name=name, prefix=generated.prefix, key_hash=generated.key_hash,
                 scope=old.scope, lineage_id=old.lineage_id or old.id)  # the same client
    session.add(new)
    commit(session, conflict=f"key {key_id} changed concurrently", field="key_id")
    return old, new, generated.plaintext
