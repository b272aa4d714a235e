"""Rig resource: the rig description document, versioned."""

from __future__ import annotations

from functools import partial
from typing import Any, ClassVar

from pydantic import Field

from app.schemas.common import Page, PublicModel, RequestModel
from app.schemas.times import Timestamp
from sim.rigs import reference_rig_document

__all__ = ["RigCreate", "RigList", "RigPublic", "RigUpdate", "RigVersionList", "RigVersionPublic"]

#: Examples that pass their operations: a complete document (the paper-002 reference rig),
#: as a new rig under another name, and as a new version of the preloaded rig 1.
_UPDATE_EXAMPLE: dict[str, Any] = reference_rig_document()
_CREATE_EXAMPLE: dict[str, Any] = reference_rig_document() | {
    "name": "lab-rig-2", "title": "Second rig of the lab, built like paper 002's"}

_document = partial(
    Field,
    description=(
        "Rig description document (schema hydrodiag.rig/1): components and parameters, each "
        "value with its unit inside the document (SI or a spelling an engineer writes: bar, "
        "rpm, cm³/rev, µm … ; docs/rig-files.md) [-]; validated by sim.rigs"
    ),
)
_comment = partial(
    Field,
    default=None,
    max_length=500,
    description="What this version changes and why [-]",
    examples=["valve spool clearance measured after overhaul"],
)


#: the top-level keys of a rig document (:mod:`sim.rigs.schema`)
_RIG_DOCUMENT = ("document", frozenset({"schema", "name", "title", "circuit", "description",
                                        "fluid", "components", "condition"}))


class RigCreate(RequestModel):
    """A new rig: its first description document."""

    document: dict[str, Any] = _document(examples=[_CREATE_EXAMPLE])
    comment: str | None = _comment()

    wraps: ClassVar[tuple[str, frozenset[str]] | None] = _RIG_DOCUMENT


class RigUpdate(RequestModel):
    """A new version of a rig's description document (the name must stay the same)."""

    document: dict[str, Any] = _document(examples=[_UPDATE_EXAMPLE])
    comment: str | None = _comment()

    wraps: ClassVar[tuple[str, frozenset[str]] | None] = _RIG_DOCUMENT


class RigVersionPublic(PublicModel):
    """One stored version of a rig's description."""

    rig_id: int = Field(description="Rig identifier [-]", examples=[1])
    version: int = Field(ge=1, description="Version number, 1 for the first [-]", examples=[3])
    document: dict[str, Any] = _document(examples=[_UPDATE_EXAMPLE])
    comment: str | None = _comment()
    created_at: Timestamp


class RigPublic(PublicModel):
    """A rig with its latest description document."""

    id: int = Field(description="Rig identifier [-]", examples=[1])
    name: str = Field(
        description="Unique rig name, from the document [-]", examples=["paper002-reference"]
    )
    title: str = Field(
        description="Human-readable title, from the document [-]",
        examples=["Paper 002 test platform"],
    )
    latest_version: int = Field(ge=1, description="Number of the newest version [-]",
                                examples=[1])
    document: dict[str, Any] = _document(examples=[_UPDATE_EXAMPLE])
    created_at: Timestamp
    updated_at: Timestamp
    notes: list[str] = Field(
        default_factory=list, description="What an update did that its sender may not mean: "
        "commissioned values it replaced with others (PUT only; empty elsewhere) [-]",
        examples=[[]])


class RigList(Page[RigPublic]):
    """A page of rigs."""


class RigVersionList(Page[RigVersionPublic]):
    """A page of a rig's versions, newest first."""
