"""The JSON-kind check of request models (:func:`app.schemas.json_kinds.json_type_problem`),
built once per annotation: what it refuses and what it leaves to pydantic."""

from __future__ import annotations

import datetime as dt
from typing import Annotated

import pytest
from pydantic import Field

from app.schemas.common import FiniteFloat
from app.schemas.json_kinds import json_type_problem


@pytest.mark.parametrize(("annotation", "value", "problem"), [
    (int, True, "must be a JSON number, not bool"),
    (float, "1.5", "must be a JSON number, not str"),
    (int, 1.5, None),  # a fraction: pydantic's own message
    (FiniteFloat, 2, None),
    (bool, 1, "must be true or false, not int"),
    (str, 3, "must be a JSON string, not int"),
    (int | None, None, None),
    (int | str, "x", None),
    (int | bool, "x", "must be a JSON number, not str"),
    (list[float], [1.0, "2"], "must be a JSON number, not str"),
    (list[float], {"a": 1}, "must be a JSON array, not dict"),
    (dict[str, int], {"a": 1, "b": False}, "must be a JSON number, not bool"),
    (dict[str, int], [1], "must be a JSON object, not list"),
    (Annotated[list[int], Field(max_length=3)], [1, 2], None),
    (dt.datetime, 0.5, "give the time as ISO 8601 with its zone, e.g. 2026-11-22T08:30:00Z"),
    (dt.datetime, "2026-11-22T08:30:00Z", None),
])
def test_json_kinds(annotation: object, value: object, problem: str | None) -> None:
    assert json_type_problem(annotation, value) == problem
    assert json_type_problem(annotation, value) == problem  # the cached check agrees
