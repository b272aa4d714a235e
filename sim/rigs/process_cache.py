"""Compiled rigs kept per process, keyed by their document (for work sent to pool workers).

A sweep point or a batch of records travels to a worker process with its rig *document*; the
worker compiles (or loads from the disk cache) that rig once and keeps it for the next chunk.
"""

from __future__ import annotations

import hashlib
import json
import threading
from collections import OrderedDict
from collections.abc import Mapping
from typing import Any

from sim.rigs import Rig, load_rig

__all__ = ["KEPT", "rig_of_document"]

#: Rigs kept per process [-].
KEPT = 4

_RIGS: OrderedDict[str, Rig] = OrderedDict()
_LOCK = threading.Lock()


def rig_of_document(document: Mapping[str, Any]) -> Rig:
    """The compiled rig of ``document``, kept per process (the :data:`KEPT` most recent).

    Raises
    ------
    RigFileError
        The document is not a valid rig.
    """
    key = hashlib.sha256(json.dumps(document, sort_keys=True, default=str).encode()).hexdigest()
    with _LOCK:
        rig = _RIGS.get(key)
        if rig is not None:
            _RIGS.move_to_end(key)
            return rig
    rig = load_rig(document)
    with _LOCK:
        rig = _RIGS.setdefault(key, rig)
        while len(_RIGS) > KEPT:
            _RIGS.popitem(last=False)
    return rig
