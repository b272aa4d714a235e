"""Rigs: the rig description document, versioned."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path, Query, Response, status

from app.api.deps import AdminKeyDep, PageDep, ReadAccess, SessionDep, WriteKeyDep
from app.db.models import Rig, RigVersion
from app.schemas.common import ERROR_RESPONSES, MAX_ID
from app.schemas.rigs import RigCreate, RigList, RigPublic, RigUpdate, RigVersionList, RigVersionPublic
from app.services import rigs as service

__all__ = ["RigId", "router"]

router = APIRouter(prefix="/rigs", tags=["rigs"], dependencies=[ReadAccess],
                   responses=ERROR_RESPONSES)

RigId = Annotated[int, Path(ge=1, le=MAX_ID, description="Rig identifier [-]",
                            examples=[1])]


def _public(rig: Rig, version: RigVersion, notes: list[str] | None = None) -> RigPublic:
    return RigPublic(
        id=rig.id, name=rig.name, title=rig.title, latest_version=rig.latest_version,
        document=version.document, created_at=rig.created_at, updated_at=rig.updated_at,
        notes=notes or [],
    )


@router.get("", summary="List rigs")
def list_rigs(
    session: SessionDep,
    page: PageDep,
    name: Annotated[str | None, Query(max_length=100, description="Only the rig of this name [-]",
                                      examples=["paper002-reference"])] = None,
) -> RigList:
    """Return a page of rigs with their latest documents, in order of creation."""
    rows, total = service.list_rigs(session, limit=page.limit, offset=page.offset, name=name)
    return RigList(items=[_public(r, v) for r, v in rows], total=total, limit=page.limit,
                   offset=page.offset)


@router.post("", status_code=status.HTTP_201_CREATED, summary="Create a rig")
def create_rig(body: RigCreate, session: SessionDep, _key: WriteKeyDep,
               response: Response) -> RigPublic:
    """Validate the document with ``sim`` and store it as version 1 of a new rig."""
    rig, version = service.create_rig(session, body.document, comment=body.comment)
    response.headers["Location"] = f"/rigs/{rig.id}"
    return _public(rig, version)


@router.get("/{rig_id}", summary="Get a rig")
def get_rig(rig_id: RigId, session: SessionDep) -> RigPublic:
    """Return the rig with its latest document."""
    rig = service.get_rig(session, rig_id)
    return _public(rig, service.latest_version(session, rig))


@router.put("/{rig_id}", summary="Store a new version of a rig's document")
def update_rig(rig_id: RigId, body: RigUpdate, session: SessionDep,
               _key: WriteKeyDep) -> RigPublic:
    """Validate the document and add it as the rig's next version; older ones stay.
    ``notes`` name the commissioned values it replaces (an update from the author's
    original file undoes a commissioning without a word otherwise)."""
    before = service.latest_version(session, service.get_rig(session, rig_id)).document
    rig, version = service.update_rig(session, rig_id, body.document, comment=body.comment)
    return _public(rig, version, service.reverted_commissioned(before, version.document))


@router.delete("/{rig_id}", status_code=status.HTTP_204_NO_CONTENT, response_class=Response,
               summary="Delete a rig without history")
def delete_rig(rig_id: RigId, session: SessionDep, _key: AdminKeyDep) -> None:
    """Delete the rig, its versions and calibrations; refused (409) if it has history.

    Needs a key of scope ``admin``.
    """
    service.delete_rig(session, rig_id)


@router.get("/{rig_id}/versions", summary="List a rig's versions")
def list_versions(rig_id: RigId, session: SessionDep, page: PageDep) -> RigVersionList:
    """Return a page of the rig's document versions, newest first."""
    rows, total = service.list_versions(session, rig_id, limit=page.limit, offset=page.offset)
    return RigVersionList(items=[RigVersionPublic.model_validate(v) for v in rows],
                          total=total, limit=page.limit, offset=page.offset)


@router.get("/{rig_id}/versions/{version}", summary="Get one version of a rig's document")
def get_version(
    rig_id: RigId,
    version: Annotated[int, Path(ge=1, le=MAX_ID, description="Version number [-]",
                                 examples=[1])],
    session: SessionDep,
) -> RigVersionPublic:
    """Return one stored version of the rig's document."""
    return RigVersionPublic.model_validate(service.get_version(session, rig_id, version))
