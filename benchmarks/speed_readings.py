"""A phase's piston speed read three ways: stroke over duration, the encoder's slope, the steady model.

``.venv/bin/python -m benchmarks.speed_readings`` (a few seconds): on the paper-002 rig and a
63/36 mm differential cylinder at 160 bar, three loads each, the transient cycle's stroke
over its phase duration and its least-squares slope over 10-90 % of the travel
(:func:`sim.phase_reading.steady_slope`, the summary's speed since 2026-11-30 and the
reading of a measured cycle), each against the steady model's speed, in %.  The last line
is one JSON object with the largest of each.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Iterator

from sim.cycle import run_cycle
from sim.phase_reading import steady_slope, steady_window
from sim.rigs import Condition, Rig, load_rig, reference_rig, reference_rig_document
from sim.steady import steady_cycle


def _rigs() -> Iterator[tuple[str, Rig, tuple[float, ...]]]:
    yield "paper-002", reference_rig(), (2100.0, 4200.0, 6300.0)
    doc = copy.deepcopy(reference_rig_document())
    doc["name"] = "press-63-36"
    cyl = doc["components"]["cylinder"]["parameters"]
    cyl["bore"] = {"value": 63.0, "unit": "mm"}
    cyl["rod1"] = {"value": 0.0, "unit": "mm"}
    cyl["rod2"] = {"value": 36.0, "unit": "mm"}
    cyl["stroke"] = {"value": 400.0, "unit": "mm"}
    doc["components"]["relief"]["parameters"]["Pset"] = {"value": 160.0, "unit": "bar"}
    yield "63/36 mm at 160 bar", load_rig(doc), (5e3, 15e3, 30e3)


def main() -> None:
    """Print the table and the JSON line."""
    print(f"{'rig':<22}{'load [N]':>9}  {'phase':<8}{'stroke/duration [%]':>21}"
          f"{'slope [%]':>11}")
    worst = {"stroke_over_duration_pct": 0.0, "slope_pct": 0.0}
    for name, rig, loads in _rigs():
        for load in loads:
            cond = Condition(load=load, oil_temperature=40.0)
            res = run_cycle(rig, {}, cond, method="rodas4", sample_rate=1000.0)
            steady = steady_cycle(rig, {}, cond)
            ts = res.timeseries
            assert ts is not None
            for phase, summary, model in (("working", res.working, steady.working),
                                          ("return", res.return_, steady.return_)):
                rows = ts[ts["phase"] == phase]
                t, x = rows["t [s]"].to_numpy(), rows["x [m]"].to_numpy()
                window = steady_window(x)
                travel = abs(float(x[-1] - x[0]))
                by_duration = 100 * (travel / summary["duration"] / model["speed"] - 1)
                by_slope = 100 * (steady_slope(t[window], x[window]) / model["speed"] - 1)
                worst["stroke_over_duration_pct"] = max(worst["stroke_over_duration_pct"],
                                                        abs(by_duration))
                worst["slope_pct"] = max(worst["slope_pct"], abs(by_slope))
                print(f"{name:<22}{load:>9g}  {phase:<8}{by_duration:>+21.3f}{by_slope:>+11.4f}")
    print(json.dumps({k: round(v, 5) for k, v in worst.items()}))


if __name__ == "__main__":
    main()
