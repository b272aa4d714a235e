"""The import's clock notes: gaps of a uniform logger and a stated rate its times contradict."""

from __future__ import annotations

import numpy as np

from diagnostics.sampling import gap_note, rate_note, sampling_notes
from diagnostics.timeseries import SeriesRecord


def record(t: np.ndarray, name: str = "r") -> SeriesRecord:
    return SeriesRecord(name, t, {"P1": np.full(t.size, 1e5)}, {"P1": "Pa"})


def test_a_uniform_record_without_gaps_has_no_note() -> None:
    assert gap_note(record(np.arange(1000) * 1e-3)) is None
    assert sampling_notes([record(np.arange(1000) * 1e-3)], 1000.0) == []


def test_a_dropout_is_counted_and_located() -> None:
    t = np.delete(np.arange(1000) * 1e-3, np.r_[300:350, 600:610])
    note = gap_note(record(t))
    assert note is not None
    assert "sampled every 1 ms" in note and "2 gap(s)" in note
    assert "about 60 sample(s) missing" in note            # 50 + 10
    assert "the longest 0.051 s after t = 0.299 s" in note


def test_a_variable_step_table_has_no_gaps_to_name() -> None:
    """A solver's own points (steps growing a hundredfold through a cycle) are no logger."""
    t = np.cumsum(np.geomspace(1e-5, 1e-2, 400))
    assert gap_note(record(t)) is None


def test_a_stated_rate_is_checked_against_the_times() -> None:
    r = record(np.arange(500) * 1e-3)
    assert rate_note(r, 1000.0) is None
    assert rate_note(r, 1005.0) is None                   # within 1 %
    note = rate_note(r, 100.0)
    assert note is not None and "100 Hz" in note and "(1000 Hz)" in note
    assert "the times were used" in note
    assert sampling_notes([r], None) == []
