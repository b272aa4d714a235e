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


def test_one_missing_sample_is_a_gap() -> None:
    """A single dropped sample (a 2× step) was stored without a note, and the plateau reader
    then refused the batch (an analyst's pass)."""
    note = gap_note(record(np.delete(np.arange(60.0), 30), "Z510"))
    assert note is not None and "1 gap(s)" in note and "about 1 sample(s) missing" in note
    assert "after t = 29 s" in note and "refuse it" in note


def test_a_reader_that_needs_uniform_samples_says_where_they_stop() -> None:
    import pytest

    from diagnostics.sampling import uniform_rate
    from sim.errors import InputError

    assert uniform_rate(record(np.arange(60.0))) == 1.0
    with pytest.raises(InputError) as exc:
        uniform_rate(record(np.delete(np.arange(60.0), 30), "Z510"))
    assert exc.value.field == "t"
    assert "'Z510' is not uniformly sampled: its step after t = 29 s is 2 s" in exc.value.message
