"""Interleaved A/B of ``diagnose()`` speed between two source trees (issue 9).

``python -m benchmarks.diagnose_ab BASE [ROUNDS]`` times the fast path of this tree and of
the tree at ``BASE`` (a checkout of an older commit: ``git worktree add /tmp/base REV``)
in turn, ``ROUNDS`` times each (default 3), each round a fresh process of the same
interpreter with that tree first on its path.  A round: 300 records of
:mod:`benchmarks.diagnose_cases` (seed 13, all seven readings), each at its own condition
(maps built), then 30 of them ten times over (maps cached; the first pass not counted).
Alternating the trees round by round spreads the machine's drift over both, which two
``make diagnose-bench`` runs back to back do not (their medians move ±0.4 ms between runs
of the same code).  Prints a table of each round and, as the last line, one JSON object
with the means over rounds and their ratios (this tree over ``BASE``).
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

#: one round, run in a child process (its output: one JSON object)
_ROUND = """
import json, statistics, time
import numpy as np
from benchmarks.diagnose_cases import FULL, random_records
from diagnostics.diagnose import diagnose
from sim.rigs import reference_rig
rig = reference_rig()
rng = np.random.default_rng(13)
for r in random_records(rng, rig, 3, [FULL]):
    diagnose(rig, [r])
recs = random_records(rng, rig, 300, [FULL])
new = []
for r in recs:
    t = time.perf_counter(); diagnose(rig, [r]); new.append(time.perf_counter() - t)
cached = []
for k in range(10):
    for r in recs[:30]:
        t = time.perf_counter(); diagnose(rig, [r]); dt = time.perf_counter() - t
        if k:
            cached.append(dt)
print(json.dumps({"new_mean": 1e3 * statistics.mean(new),
                  "new_median": 1e3 * statistics.median(new),
                  "cached_mean": 1e3 * statistics.mean(cached),
                  "cached_median": 1e3 * statistics.median(cached)}))
"""


def _round(tree: Path) -> dict[str, float]:
    env = {**os.environ, "PYTHONPATH": str(tree)}
    out = subprocess.run([sys.executable, "-c", _ROUND], cwd=tree, env=env, check=True,
                         capture_output=True, text=True).stdout
    return dict(json.loads(out.strip().splitlines()[-1]))


def main() -> None:
    if len(sys.argv) < 2:
        sys.exit("usage: python -m benchmarks.diagnose_ab BASE_TREE [ROUNDS]")
    base = Path(sys.argv[1]).resolve()
    if not (base / "diagnostics" / "diagnose.py").is_file():
        sys.exit(f"{base}: not a hydrodiag source tree (no diagnostics/diagnose.py)")
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    here = Path(__file__).resolve().parent.parent
    runs: dict[str, list[dict[str, float]]] = {"base": [], "this": []}
    print(f"{'round':<8}{'tree':<6}{'new mean':>10}{'median':>9}{'cached mean':>13}"
          f"{'median':>9}  [ms]")
    for i in range(rounds):
        for name, tree in (("base", base), ("this", here)):
            got = _round(tree)
            runs[name].append(got)
            print(f"{i + 1:<8}{name:<6}{got['new_mean']:>10.3f}{got['new_median']:>9.3f}"
                  f"{got['cached_mean']:>13.3f}{got['cached_median']:>9.3f}")
    means = {name: {k: round(statistics.mean(r[k] for r in rs), 3) for k in rs[0]}
             for name, rs in runs.items()}
    print(json.dumps({"base": str(base), "rounds": rounds, "mean_over_rounds_ms": means,
                      "ratio_this_over_base": {k: round(means["this"][k] / means["base"][k], 3)
                                               for k in means["base"]}}))


if __name__ == "__main__":
    main()
