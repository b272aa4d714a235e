"""Rigs: create, read, version, delete.

Every document is validated by :func:`sim.rigs.validate_rig_document` and stored in the
canonical form that ``sim`` writes back (``RigSpec.to_document()``), so that a stored
version always loads.  An update never overwrites: it adds a version.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import exists, func, select, true
from sqlalchemy.orm import Session

from app.db.models import MeasuredSeries, Measurement, Rig, RigVersion
from app.services.common import commit, get_or_raise, lock_row, paginate, prefixed
from sim.errors import ConflictError, NotFoundError, ParameterError
from sim.rigs import validate_rig_document
from sim.rigs.circuits import DEFAULT_CIRCUIT, get_circuit

__all__ = [
    "COMMISSIONED_SOURCE",
    "RigChoice",
    "create_rig",
    "delete_rig",
    "find_rig",
    "get_rig",
    "get_version",
    "has_cycle",
    "latest_version",
    "list_rigs",
    "list_versions",
    "lock_rig",
    "reverted_commissioned",
    "rig_choices",
    "update_rig",
]


def _canonical(document: Mapping[str, Any]) -> tuple[str, str, dict[str, Any]]:
    """Validate ``document``; return (name, title, canonical document)."""
    try:
        spec = validate_rig_document(document, strict=True)
    except ParameterError as exc:  # RigFileError and its parents: the field is in `document`
        raise type(exc)(exc.message, field=prefixed("document", exc.field)) from exc
    canonical = spec.to_document()
    title = canonical.get("title")
    return spec.name, str(title) if title else spec.name, canonical


def get_rig(session: Session, rig_id: int, *, field: str = "rig_id") -> Rig:
    """Return the rig ``rig_id`` or raise :class:`NotFoundError`."""
    return get_or_raise(session, Rig, rig_id, what="rig", field=field)


def lock_rig(session: Session, rig_id: int) -> None:
    """Make the rest of this transaction the only writer of rig ``rig_id``'s data
    (:func:`~app.services.common.lock_row`); nothing of the row changes."""
    lock_row(session, Rig.updated_at, rig_id)


def find_rig(session: Session, name: str) -> Rig | None:
    """Return the rig called ``name``, if there is one."""
    return session.scalar(select(Rig).where(Rig.name == name))


def get_version(session: Session, rig_id: int, version: int) -> RigVersion:
    """Return version ``version`` of rig ``rig_id``."""
    get_rig(session, rig_id)
    row = session.scalar(
        select(RigVersion).where(RigVersion.rig_id == rig_id, RigVersion.version == version)
    )
    if row is None:
        raise NotFoundError(f"rig {rig_id} has no version {version}", field="version")
    return row


def latest_version(session: Session, rig: Rig) -> RigVersion:
    """Return the newest version of ``rig``."""
    return get_version(session, rig.id, rig.latest_version)


def list_rigs(
    session: Session, *, limit: int, offset: int, name: str | None = None
) -> tuple[list[tuple[Rig, RigVersion]], int]:
    """Return a page of rigs, each with its latest version, and the total count."""
    condition = Rig.name == name if name is not None else true()
    statement = (
        select(Rig, RigVersion)
        .join(RigVersion, (RigVersion.rig_id == Rig.id)
              & (RigVersion.version == Rig.latest_version))
        .where(condition)
        .order_by(Rig.id)
    )
    total = session.scalar(select(func.count()).select_from(Rig).where(condition)) or 0
    rows = session.execute(statement.limit(limit).offset(offset)).all()
    return [(rig, version) for rig, version in rows], total


@dataclass(frozen=True, slots=True)
class RigChoice:
    """A rig as the console's lists and menus show it: its row and its latest version's
    circuit, without the document."""

    id: int
    name: str
    title: str
    latest_version: int
    updated_at: datetime
    #: whether the latest version's circuit has the cylinder cycle (:func:`has_cycle`)
    cycle: bool


def rig_choices(session: Session, *, limit: int | None = None, offset: int = 0
                ) -> tuple[list[RigChoice], int]:
    """Every rig (or a page of them, by id) as :class:`RigChoice`, and the number of rigs.

    The console's menus read the first 500 rigs with their latest documents: a fleet's
    501st rig could not be chosen, and each page parsed 500 documents (~9 kB each) to show
    their names — 60 ms a page at 1,000 rigs (a store-scale pass).
    """
    circuit = RigVersion.document["circuit"].as_string()
    statement = (
        select(Rig.id, Rig.name, Rig.title, Rig.latest_version, Rig.updated_at, circuit)
        .join(RigVersion, (RigVersion.rig_id == Rig.id)
              & (RigVersion.version == Rig.latest_version))
        .order_by(Rig.id).offset(offset).limit(limit)
    )
    total = session.scalar(select(func.count()).select_from(Rig)) or 0
    return [RigChoice(i, n, t, v, at, get_circuit(c or DEFAULT_CIRCUIT).cycle)
            for i, n, t, v, at, c in session.execute(statement)], int(total)


def has_cycle(version: RigVersion) -> bool:
    """Whether the version's circuit has paper 002's cylinder cycle, which simulation and
    diagnosis need (:attr:`sim.rigs.circuits.Circuit.cycle`)."""
    return get_circuit(version.document.get("circuit", DEFAULT_CIRCUIT)).cycle


def list_versions(
    session: Session, rig_id: int, *, limit: int, offset: int
) -> tuple[Sequence[RigVersion], int]:
    """Return a page of the versions of rig ``rig_id``, newest first."""
    get_rig(session, rig_id)
    statement = (
        select(RigVersion).where(RigVersion.rig_id == rig_id).order_by(RigVersion.version.desc())
    )
    return paginate(session, statement, limit=limit, offset=offset)


def create_rig(
    session: Session, document: Mapping[str, Any], *, comment: str | None = None
) -> tuple[Rig, RigVersion]:
    """Store a new rig with ``document`` as its version 1.

    Raises
    ------
    RigFileError
        The document does not validate (``field`` is under ``document``).
    ConflictError
        A rig with the document's name exists.
    """
    name, title, canonical = _canonical(document)
    if find_rig(session, name) is not None:
        raise ConflictError(f"a rig named {name!r} exists; update it instead",
                            field="document.name")
    rig = Rig(name=name, title=title, latest_version=1)
    version = RigVersion(rig=rig, version=1, document=canonical, comment=comment)
    session.add_all([rig, version])
    commit(session, conflict=f"a rig named {name!r} exists", field="document.name")
    return rig, version


#: how a commissioned value's source starts (:mod:`app.services.commissioning`)
COMMISSIONED_SOURCE = "commissioned from"


def reverted_commissioned(before: Mapping[str, Any], after: Mapping[str, Any]) -> list[str]:
    """Notes on the commissioned values of ``before`` that ``after`` replaces with a value
    that is not a commissioning's: an update from the author's original file, made for an
    unrelated fix, put every commissioned value back to its guess without a word, and every
    later diagnosis was unexplained (a commissioning engineer's pass)."""
    notes = []
    for role, component in (before.get("components") or {}).items():
        for name, old in ((component or {}).get("parameters") or {}).items():
            if not (isinstance(old, Mapping)
                    and str(old.get("source", "")).startswith(COMMISSIONED_SOURCE)):
                continue
            new = (((after.get("components") or {}).get(role) or {})
                   .get("parameters") or {}).get(name)
            if isinstance(new, Mapping) and str(new.get("source", "")).startswith(
                    COMMISSIONED_SOURCE):
                continue
            shown = (f"{new.get('value')} {new.get('unit', '')}".strip()
                     if isinstance(new, Mapping) else "removed")
            notes.append(f"{role}.{name} was commissioned ({old.get('value')} "
                         f"{old.get('unit', '')}); this version has {shown}: the "
                         "commissioning is undone for it (hydrodiag rigs show ID writes the "
                         "latest version's file to edit)")
    return notes


def update_rig(
    session: Session, rig_id: int, document: Mapping[str, Any], *, comment: str | None = None
) -> tuple[Rig, RigVersion]:
    """Add a new version of rig ``rig_id`` with ``document``.

    A document identical to the latest version's, with no comment or the same one, adds
    nothing and returns that version: a retried update (``PUT`` after a lost answer,
    ``hydrodiag rigs update`` run twice) stores one version, not two identical ones.

    Raises
    ------
    NotFoundError
        No such rig.
    RigFileError
        The document does not validate.
    ConflictError
        The document names another rig (create a new rig for that).
    """
    rig = get_rig(session, rig_id)
    name, title, canonical = _canonical(document)
    if name != rig.name:
        raise ConflictError(
            f"the document names rig {name!r} but rig {rig_id} is {rig.name!r}; "
            "a rig keeps its name (create a new rig instead)",
            field="document.name",
        )
    latest = latest_version(session, rig)
    if latest.document == canonical and comment in (None, latest.comment):
        return rig, latest
    rig.latest_version += 1
    rig.title = title
    version = RigVersion(rig=rig, version=rig.latest_version, document=canonical,
                         comment=comment)
    session.add(version)
    commit(session, conflict=f"rig {rig_id} was updated concurrently; retry")
    return rig, version


def delete_rig(session: Session, rig_id: int) -> None:
    """Delete rig ``rig_id`` with its versions and calibrations.

    Raises
    ------
    ConflictError
        The rig has measurement history, which is kept, or measured series (delete them
        first: ``DELETE /series/{id}``).
    """
    rig = get_rig(session, rig_id)
    if session.scalar(select(exists().where(Measurement.rig_id == rig_id))):
        raise ConflictError(
            f"rig {rig_id} has measurement history; it cannot be deleted", field="rig_id"
        )
    series = session.scalar(select(func.count()).select_from(MeasuredSeries)
                            .where(MeasuredSeries.rig_id == rig_id))
    if series:
        raise ConflictError(
            f"rig {rig_id} has {series} measured series (GET /rigs/{rig_id}/series); delete "
            f"them first (DELETE /series/{{id}}; hydrodiag rigs series {rig_id} --delete ID)",
            field="rig_id")
    session.delete(rig)
    commit(session, conflict=f"rig {rig_id} is in use")
