"""Result identity of ``diagnose()`` across a speed change (issue 9).

``python -m benchmarks.diagnose_identity save FILE`` diagnoses 122 times — 60 records of
:mod:`benchmarks.diagnose_cases` (seeds 1-4: twelve on a random sensor set of
:data:`~benchmarks.diagnose_cases.SUBSETS` and three with all seven readings each), each
twice in a row (a new condition, then its maps cached), and two joint two-record visits —
and pickles every number and string of :meth:`Diagnosis.to_dict` by its path;
``python -m benchmarks.diagnose_identity compare FILE`` diagnoses them again and compares:
probabilities within 1e-9 absolute, every other number within 1e-9 relative, strings
equal.  Prints the largest differences; exit status 1 where anything is beyond them.  Save
before the change, compare after it (the file holds the reference's numbers, not its code).
"""

from __future__ import annotations

import math
import pickle
import sys
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.diagnose_cases import FULL, SUBSETS, random_records
from diagnostics.diagnose import diagnose
from sim.rigs import reference_rig

#: tolerances: a probability's absolute, any other number's relative difference [-]
PROBABILITY_TOL = 1e-9
RELATIVE_TOL = 1e-9


def _flat(obj: Any, path: str, out: dict[str, Any]) -> None:
    if isinstance(obj, dict):
        for k, v in obj.items():
            _flat(v, f"{path}.{k}", out)
    elif isinstance(obj, list | tuple):
        for i, v in enumerate(obj):
            _flat(v, f"{path}[{i}]", out)
    else:
        out[path] = obj


def outputs() -> list[dict[str, Any]]:
    """Every diagnosis of the module docstring, flattened (path → leaf)."""
    rig = reference_rig()
    res: list[dict[str, Any]] = []
    for seed in (1, 2, 3, 4):
        rng = np.random.default_rng(seed)
        for rec in random_records(rng, rig, 12, SUBSETS) + random_records(rng, rig, 3, [FULL]):
            for _ in range(2):
                flat: dict[str, Any] = {}
                _flat(diagnose(rig, [rec]).to_dict(), "", flat)
                res.append(flat)
    recs = random_records(np.random.default_rng(7), rig, 4, SUBSETS)
    for a, b in ((0, 1), (2, 3)):
        flat = {}
        _flat(diagnose(rig, [recs[a], recs[b]]).to_dict(), "", flat)
        res.append(flat)
    return res


def compare(ref: list[dict[str, Any]], new: list[dict[str, Any]]) -> list[tuple[Any, ...]]:
    """The differences of ``new`` from ``ref`` beyond the tolerances (printed: the largest
    absolute and relative difference of any number)."""
    worst_abs = worst_rel = 0.0
    bad: list[tuple[Any, ...]] = []
    if len(ref) != len(new):
        return [("count", len(ref), len(new))]
    for i, (x, y) in enumerate(zip(ref, new, strict=True)):
        if x.keys() != y.keys():
            bad.append((i, "fields", sorted(set(x) ^ set(y))))
            continue
        for k, u in x.items():
            v = y[k]
            if isinstance(u, float) and isinstance(v, float):
                if u == v or (math.isnan(u) and math.isnan(v)):
                    continue
                d = abs(u - v)
                r = d / max(abs(u), abs(v))
                worst_abs, worst_rel = max(worst_abs, d), max(worst_rel, r)
                if d > PROBABILITY_TOL if k.endswith(".probability") else r > RELATIVE_TOL:
                    bad.append((i, k, u, v))
            elif u != v:
                bad.append((i, k, u, v))
    print(f"compared {len(ref)} diagnoses: largest difference {worst_abs:.3g} absolute, "
          f"{worst_rel:.3g} relative; {len(bad)} beyond the tolerances")
    return bad


def main() -> None:
    if len(sys.argv) != 3 or sys.argv[1] not in ("save", "compare"):
        sys.exit("usage: python -m benchmarks.diagnose_identity save|compare FILE")
    path = Path(sys.argv[2])
    res = outputs()
    if sys.argv[1] == "save":
        path.write_bytes(pickle.dumps(res))
        print(f"saved {len(res)} diagnoses to {path}")
        return
    bad = compare(pickle.loads(path.read_bytes()), res)
    for b in bad[:30]:
        print("  ", *b)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
