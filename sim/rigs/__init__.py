"""Rig descriptions: validation, the paper-002 reference preset, assembly into a model."""

from __future__ import annotations

import json
from collections.abc import Mapping
from functools import lru_cache
from pathlib import Path
from typing import Any

import yaml

from sim.errors import RigFileError
from sim.rigs.assembly import Condition, Rig, build_graph
from sim.rigs.schema import RigSpec, validate_rig_document
from sim.yaml_loader import load_yaml

__all__ = [
    "REFERENCE_RIG_PATH",
    "Condition",
    "Rig",
    "RigSpec",
    "build_graph",
    "load_rig",
    "load_rig_document",
    "reference_rig",
    "reference_rig_document",
    "validate_rig_document",
]

REFERENCE_RIG_PATH = Path(__file__).with_name("reference_002.yaml")


def load_rig_document(path: str | Path) -> dict[str, Any]:
    """Read a rig document from a YAML or JSON file (no validation)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise RigFileError(f"cannot read {p}: {exc.strerror}", field="path") from None
    except UnicodeDecodeError:
        raise RigFileError(f"{p.name} is not UTF-8 text", field="path") from None
    try:
        doc = json.loads(text) if p.suffix == ".json" else load_yaml(text)
    except (json.JSONDecodeError, yaml.YAMLError) as exc:
        raise RigFileError(f"{p.name} is not valid {'JSON' if p.suffix == '.json' else 'YAML'}:"
                           f" {exc}", field="") from None
    if not isinstance(doc, dict):
        raise RigFileError("a rig document must be a mapping", field="")
    return doc


def reference_rig_document() -> dict[str, Any]:
    """The paper-002 reference rig document (a fresh copy)."""
    return load_rig_document(REFERENCE_RIG_PATH)


def load_rig(source: str | Path | Mapping[str, Any], *, strict: bool | None = None) -> Rig:
    """Validate a rig (file path or document) and compile it.

    ``strict`` (:func:`validate_rig_document`: unknown keys and the plausibility bounds
    that ``rigs add`` checks) defaults to True for a file and False for a document (a
    stored one keeps loading when a bound came after it).  The geometric relations (a rod
    thinner than the bore, a clearance less than the radius) are checked either way, with
    the message an override breaking them gets: a 70 mm rod in a 63 mm bore compiled from a
    document with A1 < 0, and ``run_cycle`` answered a "stall" (a library user's pass).

    Raises
    ------
    RigFileError
        The document does not validate, naming the field
        (``components.cylinder.parameters.rod1``).
    """
    doc = source if isinstance(source, Mapping) else load_rig_document(source)
    check = not isinstance(source, Mapping) if strict is None else strict
    return Rig.from_spec(validate_rig_document(doc, strict=check))


@lru_cache(maxsize=1)
def reference_rig() -> Rig:
    """The compiled paper-002 reference rig (cached)."""
    return load_rig(REFERENCE_RIG_PATH)
