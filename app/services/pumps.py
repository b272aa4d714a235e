"""Pump parameter sets and loss maps (payloads of named quantities with units)."""

from __future__ import annotations

from collections.abc import Sequence

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from app.db.models import PumpSet
from app.schemas.pumps import PumpSetCreate, PumpSetKind, PumpSetUpdate
from app.services.common import commit, get_or_raise, paginate
from app.services.rigs import get_rig
from sim.errors import ConflictError

__all__ = [
    "check_name_free",
    "create_pump_set",
    "delete_pump_set",
    "get_pump_set",
    "list_pump_sets",
    "update_pump_set",
]


def get_pump_set(session: Session, pump_set_id: int) -> PumpSet:
    """Return pump set ``pump_set_id`` or raise :class:`~sim.errors.NotFoundError`."""
    return get_or_raise(session, PumpSet, pump_set_id, what="pump set", field="pump_set_id")


def list_pump_sets(
    session: Session,
    *,
    limit: int,
    offset: int,
    rig_id: int | None = None,
    kind: PumpSetKind | None = None,
) -> tuple[Sequence[PumpSet], int]:
    """Return a page of pump sets, optionally of one rig or one kind."""
    statement = select(PumpSet).order_by(PumpSet.id)
    if rig_id is not None:
        statement = statement.where(PumpSet.rig_id == rig_id)
    if kind is not None:
        statement = statement.where(PumpSet.kind == kind)
    return paginate(session, statement, limit=limit, offset=offset)


def check_name_free(session: Session, name: str, *, exclude_id: int | None = None) -> None:
    statement = select(func.count()).select_from(PumpSet).where(PumpSet.name == name)
    if exclude_id is not None:
        statement = statement.where(PumpSet.id != exclude_id)
    if session.scalar(statement):
        raise ConflictError(f"a pump set named {name!r} exists", field="name")


def create_pump_set(session: Session, data: PumpSetCreate) -> PumpSet:
    """Store a new pump set.

    Raises
    ------
    NotFoundError
        ``rig_id`` names no rig.
    ConflictError
        The name is taken.
    """
    if data.rig_id is not None:
        get_rig(session, data.rig_id, field="rig_id")
    check_name_free(session, data.name)
    pump_set = PumpSet(
        name=data.name,
        kind=data.kind,
        rig_id=data.rig_id,
        pump=data.pump,
        source=data.source,
        quantities=data.model_dump(mode="json")["quantities"],
    )
    session.add(pump_set)
    commit(session, conflict=f"a pump set named {data.name!r} exists", field="name")
    return pump_set


def update_pump_set(session: Session, pump_set_id: int, data: PumpSetUpdate) -> PumpSet:
    """Change a pump set; fields left out stay, ``rig_id: null`` detaches it from its rig.
    New quantities without a new source keep the old source with a note that it describes
    the set as it was (a bench set's "loss model checked" no longer holds for them)."""
    pump_set = get_pump_set(session, pump_set_id)
    changes = data.model_dump(mode="json", exclude_unset=True)
    if changes.get("rig_id") is not None:
        get_rig(session, changes["rig_id"], field="rig_id")
    if changes.get("name") is not None:
        check_name_free(session, changes["name"], exclude_id=pump_set_id)
    if "quantities" in changes and "source" not in changes and pump_set.source:
        # the source describes the quantities it came with (a bench check, a held-out S)
        changes["source"] = (f"{pump_set.source}; quantities replaced by an update since: "
                             "the notes before describe the set as it was")[-2000:]
    for key, value in changes.items():
        setattr(pump_set, key, value)
    commit(session, conflict="a pump set with this name exists", field="name")
    return pump_set


def delete_pump_set(session: Session, pump_set_id: int) -> None:
    """Delete a pump set."""
    session.delete(get_pump_set(session, pump_set_id))
    commit(session, conflict=f"pump set {pump_set_id} is in use")
