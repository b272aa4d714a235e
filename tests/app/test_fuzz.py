"""Schemathesis over the live OpenAPI document, in the test suite (issue 14).

A light run: one example per operation in every phase, ``--checks all``, with the API key,
against a real ``hydrodiag serve`` on a fresh store (:func:`benchmarks.chaos.fuzz`).  The long
run (500 examples per operation) is ``make chaos``.  Every response must match its documented
schema and status codes; no server error.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from benchmarks import chaos


@pytest.mark.skipif(shutil.which("schemathesis") is None
                    and not (Path(chaos.sys.executable).with_name("schemathesis")).exists(),
                    reason="schemathesis is not installed")
def test_live_document_fuzzed_without_a_failure(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(chaos, "FUZZ_EXAMPLES", 1)
    result = chaos.fuzz(tmp_path)
    assert result["operations"] >= 30
    assert result["requests"] > result["operations"]
    assert result["failures"] == {}, result["failures"]
    assert result["server_errors"] == 0
    assert result["errors"] == 0, result["error_titles"]
    assert result["server_up_after"]
