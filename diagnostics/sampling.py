"""What an import's clock says about its logger: gaps in a uniform record, a stated rate the times contradict.

A logger that samples at a fixed rate writes times a constant step apart; when it drops
samples (a buffer overrun, a lost packet, a pause of the acquisition) the file holds a
longer step where they are missing, and the record reads as continuous though a part of
the stroke is absent.  A sample rate stated beside a time column is not used (the times
are), so a rate that contradicts them is a sign one of the two is wrong.  Both were stored
without a word (a discrepancy pass); these notes say so at the import.

A record is judged uniform when at least :data:`UNIFORM_SHARE` of its steps lie within
:data:`STEP_TOLERANCE` of their median: a table of a variable-step solver's points (a
``/simulate`` export without a sample rate) is not, and has no gaps to name.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError

__all__ = ["GAP_FACTOR", "STEP_TOLERANCE", "UNIFORM_SHARE", "gap_note", "gap_spans", "rate_note",
           "sampling_notes", "uniform_rate"]

#: relative spread of a uniform logger's steps about their median [-]
STEP_TOLERANCE = 0.01
#: share of the steps within :data:`STEP_TOLERANCE` of the median for a uniform record [-]
UNIFORM_SHARE = 0.9
#: a step longer than this × the median step in a uniform record is a gap [-]: one sample
#: missing makes a step of 2× (at 2.5× it was stored without a note, and the plateau
#: reader, which needs steps within :data:`STEP_TOLERANCE`, then refused the batch: an
#: analyst's pass)
GAP_FACTOR = 1.5


def _gaps(record: SeriesRecord) -> tuple[npt.NDArray[np.intp], float]:
    """Indices ``k`` of the gaps of a uniformly sampled record (``t[k]`` → ``t[k + 1]`` a
    step over :data:`GAP_FACTOR` × the median step) and that step [s]; none where the
    record is not uniformly sampled."""
    dt = np.diff(record.t)
    none = np.zeros(0, dtype=np.intp)
    if dt.size < 2:
        return none, 0.0
    step = float(np.median(dt))
    if step <= 0.0 or np.mean(np.abs(dt - step) <= STEP_TOLERANCE * step) < UNIFORM_SHARE:
        return none, step
    return np.flatnonzero(dt > GAP_FACTOR * step), step


def gap_spans(record: SeriesRecord) -> list[tuple[float, float]]:
    """The gaps of a uniformly sampled record as (last time before, first time after) [s]
    (:func:`gap_note`'s gaps); empty where it has none or is not uniformly sampled."""
    gaps, _ = _gaps(record)
    return [(float(record.t[k]), float(record.t[k + 1])) for k in gaps]


def gap_note(record: SeriesRecord, *, imported: bool = True) -> str | None:
    """A note on the gaps of a uniformly sampled record (steps over :data:`GAP_FACTOR` × its
    median step): how many, the longest and where, the samples missing; None when it has
    none or is not uniformly sampled.  ``imported``: with what the import did with it (a
    discrepancy answer repeated "Stored as given" for every record)."""
    gaps, step = _gaps(record)
    if gaps.size == 0:
        return None
    dt = np.diff(record.t)
    longest = int(gaps[np.argmax(dt[gaps])])
    missing = int(np.sum(np.round(dt[gaps] / step) - 1))
    said = (f"record {record.name!r} is sampled every {step * 1e3:.4g} ms but has "
            f"{gaps.size} gap(s) in its time, about {missing} sample(s) missing; the longest "
            f"{float(dt[longest]):.4g} s after t = {float(record.t[longest]):.6g} s")
    if not imported:
        return said
    return (said + ": a logger dropout? Stored as given; a stroke across a gap is read "
            "without its missing samples, and the readers that need a uniform record (a "
            "pump's plateaus, the accumulator and switching estimates) refuse it")


def rate_note(record: SeriesRecord, sample_rate: float) -> str | None:
    """A note when ``sample_rate`` [Hz], stated beside the record's time column, differs
    from the rate its times read (their median step) by more than :data:`STEP_TOLERANCE`;
    None when they agree (a record timed by the rate agrees by construction)."""
    dt = np.diff(record.t)
    if dt.size == 0:
        return None
    read = 1.0 / float(np.median(dt))
    if abs(read - sample_rate) <= STEP_TOLERANCE * sample_rate:
        return None
    return (f"record {record.name!r}: the sample rate given, {sample_rate:.6g} Hz, is not "
            f"what its time column reads ({read:.6g} Hz); the times were used and the rate "
            "ignored: if the times are wrong, import again without the time column (a "
            "column map entry ['skip', '-']) and with the right rate")


def sampling_notes(records: Sequence[SeriesRecord], sample_rate: float | None = None
                   ) -> list[str]:
    """The notes of :func:`rate_note` (when a rate was given) and :func:`gap_note` for each
    record of an import."""
    notes = []
    for r in records:
        for note in (rate_note(r, sample_rate) if sample_rate is not None else None,
                     gap_note(r)):
            if note is not None:
                notes.append(note)
    return notes


def uniform_rate(record: SeriesRecord) -> float:
    """The record's sample rate [Hz] (:attr:`SeriesRecord.sample_rate`) for a reader that
    needs uniform samples; an :class:`InputError` on ``t`` saying where the first step off
    the median is, when it has none ("not uniformly sampled" alone left an analyst to find
    the one dropped sample of 30 cycles)."""
    rate = record.sample_rate
    if rate is not None:
        return rate
    dt = np.diff(record.t)
    if dt.size == 0:
        raise InputError(f"record {record.name!r} has a single sample", field="t")
    step = float(np.median(dt))
    k = int(np.argmax(np.abs(dt - step) > STEP_TOLERANCE * step))
    raise InputError(
        f"record {record.name!r} is not uniformly sampled: its step after t = "
        f"{float(record.t[k]):.6g} s is {float(dt[k]):.4g} s where its median step is "
        f"{step:.4g} s (a logger dropout?); this reader needs uniform samples: resample the "
        "record onto its median step, or leave it out", field="t")
