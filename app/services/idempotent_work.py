"""The ``Idempotency-Key`` of the request being run, marked in the transaction of its work.

:class:`app.idempotency.IdempotencyMiddleware` keeps a keyed write's answer once the app
has answered; a process killed between the commit of the work and that keeping left a key
whose retry ran the work again (an operator's kill -9 under load doubled 2 of ~4 requests
in flight).  The middleware puts its row in :data:`CURRENT` (a context variable:
the route, its dependencies and the threads they run in see it), and
:func:`app.services.common.commit` marks the row stored in the same transaction as the
work (:func:`mark_stored`); ``POST /diagnose``, whose rows the group committer writes in a
thread of its own, keeps its whole answer there (:func:`keep_answer`).  A retry of a write
marked stored whose answer was never kept is refused instead of run again
(:mod:`app.idempotency`).
"""

from __future__ import annotations

from contextvars import ContextVar
from dataclasses import dataclass

from sqlalchemy import update
from sqlalchemy.orm import Session

from app.db.base import utcnow
from app.db.models import IdempotentRequest

__all__ = ["CURRENT", "KeyedWrite", "keep_answer", "mark_stored"]


@dataclass(slots=True)
class KeyedWrite:
    """The keyed write being run: its ``idempotent_requests`` row, and whether the route
    kept its answer itself (the middleware then does not keep it again)."""

    row_id: int
    kept: bool = False


#: The keyed write being run (``None``: none).
CURRENT: ContextVar[KeyedWrite | None] = ContextVar("hydrodiag_keyed_write", default=None)


def mark_stored(session: Session) -> None:
    """Mark the current keyed write's work as stored, in ``session``'s transaction (no-op
    outside a keyed write)."""
    keyed = CURRENT.get()
    if keyed is not None:
        session.execute(update(IdempotentRequest).where(IdempotentRequest.id == keyed.row_id)
                        .values(stored_at=utcnow()))


def keep_answer(session: Session, row_id: int, status: int, body: bytes, *,
                content_type: str = "application/json", location: str | None = None) -> None:
    """Keep the answer of keyed write ``row_id`` in ``session``'s transaction, the one that
    stores its work: once that commits, a retry is answered from the store."""
    session.execute(update(IdempotentRequest).where(IdempotentRequest.id == row_id).values(
        status=status, content_type=content_type, location=location, body=body,
        stored_at=utcnow()))
