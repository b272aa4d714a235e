"""API keys in the store: create (shown once), authenticate, list, revoke."""

from __future__ import annotations

from collections.abc import Sequence

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.db.base import utcnow
from app.db.models import ApiKey
from app.security import VerifiedKeys, generate_key, split_key, verify_unknown
from app.services.common import commit, get_or_raise
from sim.errors import AuthError, ConflictError

__all__ = ["authenticate", "count_active_keys", "create_api_key", "list_api_keys",
           "revoke_api_key"]

API_KEY_HEADER = "X-API-Key"

#: Keys verified by this process (scrypt once per key; see :class:`VerifiedKeys`).
_VERIFIED = VerifiedKeys()


def create_api_key(session: Session, name: str) -> tuple[ApiKey, str]:
    """Create a key called ``name``.

    Returns
    -------
    row, plaintext
        The stored row (hash only) and the key itself, which is never stored or shown again.

    Raises
    ------
    ConflictError
        A key with this name exists.
    """
    if session.scalar(select(func.count()).select_from(ApiKey).where(ApiKey.name == name)):
        raise ConflictError(f"a key named {name!r} exists", field="name")
    generated = generate_key()
    row = ApiKey(name=name, prefix=generated.prefix, key_hash=generated.key_hash)
    session.add(row)
    commit(session, conflict=f"a key named {name!r} exists", field="name")
    return row, generated.plaintext


def authenticate(session: Session, key: str | None) -> ApiKey:
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
    valid = verify_unknown(key) if row is None else _VERIFIED.verify(row.id, key,
                                                                     row.key_hash)
    if row is None or not valid or row.revoked_at is not None:
        raise AuthError("the API key is not valid", field=API_KEY_HEADER)
    return row


def list_api_keys(session: Session) -> Sequence[ApiKey]:
    """Return every key row (hashes only), oldest first."""
    return session.scalars(select(ApiKey).order_by(ApiKey.id)).all()


def count_active_keys(session: Session) -> int:
    """Return how many keys are not revoked."""
    statement = select(func.count()).select_from(ApiKey).where(ApiKey.revoked_at.is_(None))
    return int(session.scalar(statement) or 0)


def revoke_api_key(session: Session, key_id: int) -> ApiKey:
    """Revoke key ``key_id``; it stops working at once and stays listed."""
    row = get_or_raise(session, ApiKey, key_id, what="API key")
    if row.revoked_at is None:
        row.revoked_at = utcnow()
        commit(session, conflict=f"key {key_id} changed concurrently")
    return row
