"""Compiled rigs, cached per stored rig version.

``diagnostics`` caches its signature maps and steady-state evaluators by the identity of
the :class:`sim.rigs.Rig` object, so the service must hand it the same object for the
same rig version on every request: compiling a new one per request would rebuild those
maps each time.  :class:`RigCache` keeps the compiled rig of each (rig id, version,
creation time of the version) — the creation time guards against an id that SQLite
reuses after a rig without history was deleted.  Versions never change once stored, so
an entry never goes stale; the least recently used ones are dropped past ``size``.
"""

from __future__ import annotations

import hashlib
import json
import threading
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import Integer, and_, bindparam, func, select
from sqlalchemy.orm import Session

from app.db.models import Rig as RigRow
from app.db.models import RigVersion
from sim.errors import NotFoundError
from sim.rigs import Rig, load_rig

__all__ = ["DocumentRigs", "ResolvedRig", "RigCache", "RigKey", "document_digest"]

#: Key of a compiled rig: rig id, version, creation time of the version.
RigKey = tuple[int, int, datetime]


@dataclass(frozen=True, slots=True)
class ResolvedRig:
    """A stored rig version and its compiled model.

    Attributes
    ----------
    rig_id, version
        Which rig and which version of its document.
    version_id
        Row id of that version in the store.
    name
        The rig's name.
    document
        The version's rig document (SI values with units inside).
    rig
        The compiled rig, the same object for every request on this version.
    created_at
        When the version was stored (with id and version, the key of the compiled rig).
    """

    rig_id: int
    version: int
    version_id: int
    name: str
    document: Mapping[str, Any]
    rig: Rig
    created_at: datetime

    @property
    def key(self) -> RigKey:
        """Key of the compiled rig: (rig id, version, creation time of the version)."""
        return (self.rig_id, self.version, self.created_at)


def document_digest(document: Mapping[str, Any]) -> str:
    """Return a digest of a rig document (canonical JSON), to key compiled rigs by."""
    text = json.dumps(document, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class _Lru:
    """A small thread-safe least-recently-used map."""

    def __init__(self, size: int) -> None:
        if size < 1:
            raise ValueError("the cache must hold at least one rig")
        self._size = size
        self._items: OrderedDict[Any, Any] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: Any) -> Any:
        with self._lock:
            item = self._items.get(key)
            if item is not None:
                self._items.move_to_end(key)
            return item

    def put(self, key: Any, item: Any) -> Any:
        """Store ``item`` unless another thread stored one first; return the kept one."""
        with self._lock:
            kept = self._items.setdefault(key, item)
            self._items.move_to_end(key)
            while len(self._items) > self._size:
                self._items.popitem(last=False)
            return kept

    def __len__(self) -> int:
        with self._lock:
            return len(self._items)


#: The statement of :meth:`RigCache.get`, built once (a statement built per request cost
#: its cache key's generation, ~0.3 ms each; issue 9): the rig and its version ``version``
#: (null: the latest) in one statement, the version's columns null where the rig has no such
#: version.  Two statements (the rig, then the version) cost a diagnosis process ~60 µs more
#: a request (issue 9).
_RIG_VERSION = (
    select(RigRow.name, RigRow.latest_version, RigVersion.id, RigVersion.created_at)
    .select_from(RigRow)
    .outerjoin(RigVersion, and_(
        RigVersion.rig_id == RigRow.id,
        RigVersion.version == func.coalesce(bindparam("version", type_=Integer),
                                            RigRow.latest_version)))
    .where(RigRow.id == bindparam("rig_id")))


class RigCache:
    """Compiled rigs per stored (rig id, version); thread-safe.

    Parameters
    ----------
    size
        Number of compiled rigs kept [-].
    """

    def __init__(self, size: int = 16) -> None:
        self._rigs = _Lru(size)

    def __len__(self) -> int:
        return len(self._rigs)

    def get(
        self,
        session: Session,
        rig_id: int,
        version: int | None = None,
        *,
        rig_field: str = "rig_id",
        version_field: str = "rig_version",
    ) -> ResolvedRig:
        """Return rig ``rig_id`` at ``version`` (the latest when ``None``), compiled.

        Parameters
        ----------
        session
            Session of the store.
        rig_id, version
            The rig and the version of its document.
        rig_field, version_field
            Names of the two in the request, for the ``field`` of a 404.

        Raises
        ------
        NotFoundError
            No such rig, or the rig has no such version.
        """
        row = session.execute(_RIG_VERSION, {"rig_id": rig_id, "version": version}).first()
        if row is None:
            raise NotFoundError(f"no rig with id {rig_id}", field=rig_field)
        name, latest, version_id, created_at = row
        number = latest if version is None else version
        if version_id is None:
            raise NotFoundError(f"rig {rig_id} has no version {number}", field=version_field)
        key: RigKey = (rig_id, number, created_at)
        cached: tuple[Rig, Mapping[str, Any]] | None = self._rigs.get(key)
        if cached is None:  # the document is read only when the rig is compiled
            stored = session.get(RigVersion, version_id)
            if stored is None:  # deleted since the statement above (an SRE pass: a 500)
                raise NotFoundError(f"no rig with id {rig_id}", field=rig_field)
            cached = self._rigs.put(key, (load_rig(stored.document), stored.document))
        rig, document = cached
        return ResolvedRig(rig_id, number, version_id, name, document, rig, created_at)

    def compiled(self, key: RigKey, document: Mapping[str, Any] | None) -> Rig | None:
        """The compiled rig of ``key`` (see :meth:`ResolvedRig.key`), compiled from
        ``document`` on a miss; ``None`` on a miss without the document."""
        cached: tuple[Rig, Mapping[str, Any]] | None = self._rigs.get(key)
        if cached is None:
            if document is None:
                return None
            cached = self._rigs.put(key, (load_rig(document), document))
        return cached[0]


class DocumentRigs:
    """Compiled rigs keyed by their document's digest (for callers holding only a document).

    Parameters
    ----------
    size
        Number of compiled rigs kept [-].
    """

    def __init__(self, size: int = 8) -> None:
        self._rigs = _Lru(size)

    def get(self, document: Mapping[str, Any]) -> Rig:
        """Return the compiled rig of ``document`` (validated and compiled once)."""
        key = document_digest(document)
        rig = self._rigs.get(key)
        if rig is None:
            rig = self._rigs.put(key, load_rig(document))
        return rig
