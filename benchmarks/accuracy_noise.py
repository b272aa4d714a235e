"""The accuracy study's instruments-as-they-are suites (:mod:`benchmarks.accuracy`).

The diagnosis weighs every reading by the uncertainty its record states (or its
instrument's class), and its goodness-of-fit test, its ambiguity set and its intervals are
only as right as those statements.  The main suites draw every error within the stated
class; instruments in service are not always that good, nor their errors independent.
Here, with the records still stating the class:

* **noisier than stated**: in-library faults (the main suites' draws, preset and
  differential rig in turn) with every error — each reading's, the stated load's and oil
  temperature's — uniform within 1.5 × and 2 × the class bound, and Gaussian of the
  class's σ (the stated σ, with tails beyond the bound;
  :class:`benchmarks.accuracy_cases.Noise`);
* **what a misfit looks like**: the main beyond-range and mis-specified suites' answers at
  the class's noise, for comparison of the result's ``uncertainty_factor`` (the common
  factor on every uncertainty at which the best fit would pass,
  :func:`diagnostics.goodness.uncertainty_factor`) between readings that are noisier than
  stated and readings the library does not describe;
* **units mistaken**: the same in-library draws with every pressure stated absolute (an
  atmosphere of 95-103 kPa added) or the oil temperature stated in °F, where the records
  ask gauge pressures and °C — how often the answer names the mistake
  (:mod:`diagnostics.unit_mistakes`), and, in every other suite, how often it names one
  that was not made;
* **errors shared by a visit's records**: joint visits whose three records share each
  instrument's error (a calibration error, drawn once per visit:
  :class:`benchmarks.accuracy_joint.VisitInstruments`), diagnosed as independent records
  and with each record stating ``calibration_share`` 1 (:mod:`diagnostics.shared_errors`),
  next to visits with independent errors; and commissionings from records that share
  their instruments' errors, likewise both ways
  (:func:`benchmarks.accuracy_joint.shared_commissioning`).

Figures per sensor set: cases, grouped top-1, truth in the ambiguity set, share not
explained (all cases, and the healthy rigs), and for the answers not explained the median
uncertainty factor and the share of them whose factor is at most 2 (a reader who takes
"≤ 2" for noise), and the share of answers that name a mistake in the units.  Nothing here tunes anything.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from benchmarks.accuracy_cases import Noise
from benchmarks.accuracy_figures import summarise
from benchmarks.accuracy_joint import StoredFn, joint_suite, shared_commissioning

__all__ = ["NOISIER", "noise_study"]

Rows = dict[str, list[dict[str, Any]]]
RunFn = Callable[[dict[str, int], np.random.Generator, Noise], tuple[Rows, int]]

#: the error draws of the noisier-than-stated suites, and of the mistaken units, by label
NOISIER = {"1.5 × class, uniform": Noise(1.5), "2 × class, uniform": Noise(2.0),
           "class σ, Gaussian": Noise(1.0, "gauss"),
           "pressures absolute": Noise(mistake="absolute_pressure"),
           "temperature in °F": Noise(mistake="fahrenheit")}

#: an uncertainty factor at most this reads as noise to the figure's reader [-]
NOISE_LIKE = 2.0


def _factors(rows: list[dict[str, Any]]) -> list[float]:
    return [float(r["detail"]["uncertainty_factor"]) for r in rows
            if r["error"] is None and r["top"] == "unexplained"
            and r["detail"]["uncertainty_factor"] is not None]


def _figures(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The module docstring's figures of one sensor set's ``rows``."""
    s = summarise(rows)
    ok = [r for r in rows if r["error"] is None]
    healthy = [r for r in ok if r["truth"] == "healthy"]
    fac = _factors(rows)
    return {"n": s["n"], "server_errors": s["server_errors"],
            "input_errors": s["input_errors"],
            "top1_grouped": s.get("top1_grouped"),
            "truth_in_ambiguity_set": s.get("truth_in_ambiguity_set"),
            "not_explained": s.get("not_explained"),
            "healthy_not_explained": (float(np.mean([r["top"] == "unexplained"
                                                      for r in healthy]))
                                      if healthy else None),
            "unexplained_factor_median": float(np.median(fac)) if fac else None,
            "unexplained_noise_like": (float(np.mean([f <= NOISE_LIKE for f in fac]))
                                       if fac else None),
            "unit_mistake_named": (float(np.mean([bool(r["detail"]["unit_mistakes"])
                                                  for r in ok])) if ok else None)}


def _line(label: str, sname: str, f: dict[str, Any]) -> str:
    def num(v: float | None) -> str:
        return "     -" if v is None else f"{v:6.3f}"

    med = f["unexplained_factor_median"]
    return (f"{label:24s} {sname:16s} {f['n']:4d} {f['input_errors']:4d} "
            f"{num(f['top1_grouped'])} "
            f"{num(f['truth_in_ambiguity_set'])} {num(f['not_explained'])} "
            f"{num(f['healthy_not_explained'])}  {'    -' if med is None else f'{med:5.2f}'} "
            f"{num(f['unexplained_noise_like'])} {num(f['unit_mistake_named'])}")


def noise_study(n: int, n_joint: int, rng: np.random.Generator, run: RunFn, main_rows: Rows,
                stored: StoredFn, n_commission: int = 0) -> dict[str, Any]:
    """The module docstring's suites: ``n`` in-library cases per error draw (``run``:
    :func:`benchmarks.accuracy.run_suites`), the main study's ``main_rows`` as the
    class's own and the misfits' reference, ``n_joint`` visits with shared and with
    independent errors, ``n_commission`` commissionings from records whose instruments
    share their errors (their own draws, after the others).  Prints a table; returns its
    figures."""
    out: dict[str, Any] = {"cases": n, "noise_like_factor": NOISE_LIKE, "in_library": {},
                           "misfit_suites": {}}
    print(f"\ninstruments as they are ({n} in-library cases per draw, preset and differential "
          "in turn; the records state the class; benchmarks/accuracy_noise.py): 'factor' = "
          "median uncertainty factor of the answers not explained, '≤2' = share of those "
          "at most 2, 'unit' = share of the answers that name a mistake in the units "
          "(diagnostics/unit_mistakes.py); 422 = records refused as input errors (an oil "
          "temperature above 150 °C)")
    print(f"{'errors':24s} {'sensor set':16s} {'n':>4s} {'422':>4s} {'top-1*':>6s} "
          f"{'in amb':>6s} "
          f"{'misfit':>6s} {'healthy':>6s}  {'factor':>5s} {'≤2':>6s} {'unit':>6s}")
    draws: dict[str, Rows] = {"class, uniform (main)": {
        s: [r for r in rs if r["suite"] in ("preset", "differential")]
        for s, rs in main_rows.items()}}
    half = n // 2
    for label, noise in NOISIER.items():
        draws[label] = run({"preset": n - half, "differential": half}, rng, noise)[0]
    for label, rows in draws.items():
        out["in_library"][label] = {}
        for sname, rs in rows.items():
            f = _figures(rs)
            out["in_library"][label][sname] = f
            print(_line(label, sname, f))
    for suite in ("beyond_range", "misspecified"):
        out["misfit_suites"][suite] = {}
        for sname, rs in main_rows.items():
            f = _figures([r for r in rs if r["suite"] == suite])
            out["misfit_suites"][suite][sname] = f
            print(_line(f"{suite} (main)", sname, f))
    print(f"joint visits ({n_joint}), each instrument's error shared by the visit's records:")
    shared = joint_suite(n_joint, rng, stored, shared=True)
    print(f"another {n_joint} visits, errors independent between records (what the diagnosis "
          "assumes):")
    independent = joint_suite(n_joint, rng.spawn(1)[0], stored)
    out["joint"] = {"visits": n_joint, "shared": shared, "independent": independent}
    if n_commission:
        print(f"{n_commission} commissionings (six healthy records of a rig built off its "
              "document), each instrument's error shared by the records:")
        out["commissioning_shared"] = shared_commissioning(n_commission, rng.spawn(1)[0])
    return out
