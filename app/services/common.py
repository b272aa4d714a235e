"""Helpers shared by the services: look-ups that raise, pagination, safe commits."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, TypeVar, cast

from sqlalchemy import ColumnElement, Select, func, select, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.ext.compiler import compiles
from sqlalchemy.orm import InstrumentedAttribute, Session
from sqlalchemy.sql.sqltypes import NULLTYPE

from app.db.models import Diagnosis
from app.services.idempotent_work import mark_stored
from sim.errors import ConflictError, NotFoundError

__all__ = ["commit", "current_diagnoses", "flush", "get_or_raise", "lock_row", "paginate",
           "prefixed"]

T = TypeVar("T")


def get_or_raise(session: Session, model: type[T], ident: Any, *, what: str, field: str) -> T:
    """Return the row of ``model`` with primary key ``ident``.

    Raises
    ------
    NotFoundError
        No such row; the message says ``what`` was looked for, ``field`` names the
        parameter that gave ``ident`` (every 404 names it: a second DELETE of a measurement
        answered without one, an operator pass).
    """
    row = session.get(model, ident)
    if row is None:
        raise NotFoundError(f"no {what} with id {ident}", field=field)
    return row


class _Current(ColumnElement[Any]):
    """``diagnoses.superseded_by IS NULL``, written for each database
    (:func:`current_diagnoses`); untyped, as a boolean-typed element gets ``= 1`` added
    on SQLite."""

    inherit_cache = True
    type = NULLTYPE

    @property
    def _from_objects(self) -> list[Any]:
        return [Diagnosis.__table__]


@compiles(_Current)
def _current_default(_element: _Current, compiler: Any, **kw: Any) -> str:
    return str(compiler.process(Diagnosis.superseded_by.is_(None), **kw))


@compiles(_Current, "sqlite")
def _current_sqlite(_element: _Current, compiler: Any, **kw: Any) -> str:
    return str(compiler.process(func.coalesce(Diagnosis.superseded_by, 0) == 0, **kw))


def current_diagnoses() -> ColumnElement[bool]:
    """The diagnoses a re-diagnosis has not replaced (``superseded_by`` null).

    On SQLite written ``coalesce(superseded_by, 0) = 0``, which no index serves: with
    ``superseded_by IS NULL`` SQLite (without statistics, as a store is) walked the index
    on ``superseded_by``, where nearly every row is current, and sorted all of a rig's
    diagnoses to return one page — 1.1 s for the first 50 of 100,000 — where the records'
    (rig, time) index gives the page in time order (0.2 ms for its ids; a store-scale
    pass, ``make history-bench``).  PostgreSQL keeps ``IS NULL``: its planner has the
    statistics, and read as a function the condition took a rig's first page from 84 to
    257 ms at 100,000.
    """
    return cast(ColumnElement[bool], _Current())


def paginate(
    session: Session, statement: Select[T], *, limit: int, offset: int
) -> tuple[Sequence[T], int]:
    """Run ``statement`` for one page and count the whole result.

    Returns
    -------
    items, total
        The rows of the page and the number of rows without limit/offset.
    """
    total = session.scalar(select(func.count()).select_from(statement.order_by(None).subquery()))
    items = session.scalars(statement.limit(limit).offset(offset)).all()
    return items, int(total or 0)


def commit(session: Session, *, conflict: str, field: str | None = None) -> None:
    """Commit, turning a constraint violation into :class:`ConflictError`.

    The explicit checks in the services catch the usual conflicts with a precise message;
    this is the backstop for two writers racing past those checks.  In a write sent with an
    ``Idempotency-Key`` the key is marked stored in the same transaction
    (:func:`app.services.idempotent_work.mark_stored`).
    """
    try:
        mark_stored(session)
        session.commit()
    except IntegrityError as exc:
        session.rollback()
        raise ConflictError(conflict, field=field) from exc


def flush(session: Session, *, conflict: str, field: str | None = None) -> None:
    """Flush, turning a constraint violation into :class:`ConflictError`, as
    :func:`commit` does: a flush before the commit was a 500 where two writers raced past
    the services' checks (two tables PATCHed onto one condition at once: an SRE pass)."""
    try:
        session.flush()
    except IntegrityError as exc:
        session.rollback()
        raise ConflictError(conflict, field=field) from exc


def lock_row(session: Session, column: InstrumentedAttribute[Any], row_id: int) -> None:
    """Make the rest of this transaction the only writer of the row ``row_id`` of
    ``column``'s table: a no-op update of ``column`` (set to itself) takes SQLite's write
    lock, or PostgreSQL's row lock, before the caller's checks, which then see every write
    committed before, and a second writer waits for this one's commit
    (``HYDRODIAG_DB_LOCK_TIMEOUT``).  A column with an ``onupdate`` of its own (``updated_at``)
    keeps its value only where it is the column given."""
    table = column.class_
    session.execute(update(table).where(table.id == row_id).values({column.key: column}))


def prefixed(prefix: str, field: str | None) -> str:
    """Return ``field`` as a path under ``prefix`` (``document`` + ``a.b`` → ``document.a.b``)."""
    if not field:
        return prefix
    return f"{prefix}{field}" if field.startswith("[") else f"{prefix}.{field}"
