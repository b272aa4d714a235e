"""The compiled one-parameter fits (diagnostics.fastpath.singles) give the numbers of the
numpy form of Ranker.fit_single on the same maps: random records alone and in pairs, all
sensor subsets (a velocity ratio alone included, whose map masks the stalled points)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.diagnose_cases import random_record
from diagnostics.fastpath.fits import RecordPack
from diagnostics.hypotheses import HYPOTHESES
from diagnostics.measurement import MeasurementRecord
from diagnostics.observations import observe
from diagnostics.ranking import Ranker
from sim.rigs import reference_rig


class _NumpyRanker(Ranker):
    """The same maps and likelihood, the single fits by the numpy form."""

    def _record_pack(self) -> RecordPack | None:
        return None


def _records(rng: np.random.Generator, n: int) -> list[MeasurementRecord]:
    rig = reference_rig()
    out: list[MeasurementRecord] = []
    while len(out) < n:
        rec = random_record(rng, rig)
        if rec is not None:
            out.append(rec)
    return out


@pytest.mark.parametrize("per_ranking", [1, 2])
def test_compiled_single_fits_equal_the_numpy_form(per_ranking: int) -> None:
    rig = reference_rig()
    rng = np.random.default_rng(17 + per_ranking)
    singles = [h for h in HYPOTHESES if len(h.parameters) == 1]
    for _ in range(12):
        obs = [observe(r, rig) for r in _records(rng, per_ranking)]
        fast, ref = Ranker(rig, obs, method="fast"), _NumpyRanker(rig, obs, method="fast")
        assert fast._record_pack() is not None
        for h in singles:
            a, b = fast.fit_single(h), ref.fit_single(h)
            assert a.observable == b.observable
            assert a.detectability == pytest.approx(b.detectability, rel=1e-12)
            if math.isinf(b.chi2):
                assert math.isinf(a.chi2) and a.log_evidence == b.log_evidence == -math.inf
            else:
                assert a.chi2 == pytest.approx(b.chi2, rel=1e-10, abs=1e-10)
                assert a.log_evidence == pytest.approx(b.log_evidence, rel=1e-10, abs=1e-10)
            assert a.predicted == b.predicted
            (pa,), (pb,) = a.parameters, b.parameters
            for f in ("value", "low", "high"):
                assert getattr(pa, f) == pytest.approx(getattr(pb, f), rel=1e-9), (h.name, f)
            assert pa.at_bound == pb.at_bound
