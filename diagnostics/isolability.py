"""What the present sensors cannot tell apart, and which added measurement would.

Three statements accompany every ranking:

* the **ambiguity set**: every observable hypothesis the data cannot reject — its best
  fit passes a χ² goodness-of-fit test at the 1 % level (χ² ≤ χ²₀.₉₉ with
  ``max(n − k, 1)`` degrees of freedom, n readings, k fitted parameters).  It is empty
  when nothing fits (:mod:`diagnostics.goodness`).  These are the
  hypotheses the present sensors cannot separate; the **credible set** (the most probable
  hypotheses adding up to 95 %) is the sharper, prior-dependent answer to "which first";
* **parallel signatures**: pairs of single-fault hypotheses whose effect on the present
  readings points the same way (cosine ≥ 0.995 between their σ-scaled signatures at a
  moderate fault), so no amount of data from these sensors at these conditions separates
  them — a structural limit, independent of the values measured (bond-graph fault
  signature matrices, Samantaray et al. 2006);
* for each hypothesis in the ambiguity set besides the first, the **added measurement**
  that would separate it from the first: the sensor (not in the record) whose predicted
  readings under the two fitted hypotheses differ by the most standard uncertainties of
  its default instrument class.  Below 2 σ, no listed sensor separates them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.stats import chi2 as chi2_dist

from diagnostics.evidence import opening_pressure
from diagnostics.hypotheses import PARAMETERS
from diagnostics.quantity import DEFAULT_INSTRUMENTS
from diagnostics.ranking import HypothesisFit, Ranker
from diagnostics.signatures import OBSERVABLES

__all__ = ["Isolability", "Separation", "isolability"]

#: moderate fault used for signatures, in each parameter's reported unit (× nominal for
#: clearances, factor for pump leakage, units of 1/R0 for seat leakage, × nominal Pset)
_REFERENCE = {"cc": 1.5, "cv": 1.5, "pump_leak": 3.0, "seat_leak": 1.0, "Pset": 0.5}


@dataclass
class Separation:
    """The added measurement that best separates two hypotheses.

    Attributes
    ----------
    first, other
        The hypotheses.
    sensor
        Best sensor not in the records (``None`` if every listed sensor is present).
    sigma
        Predicted difference of its readings in standard uncertainties of its default
        instrument class.
    """

    first: str
    other: str
    sensor: str | None
    sigma: float


@dataclass
class Isolability:
    """Isolability statement of a diagnosis (see module docstring)."""

    ambiguity_set: list[str]
    credible_set: list[str]
    not_observable: list[str]
    parallel: list[tuple[str, str, float]]
    separations: list[Separation]
    statements: list[str]


@lru_cache(maxsize=256)
def _chi2_limit(dof: int, alpha: float) -> float:
    return float(chi2_dist.ppf(1.0 - alpha, dof))


def _consistent_set(fits: list[HypothesisFit], n_obs: int, alpha: float = 0.01,
                    at_fit: Mapping[str, float] | None = None) -> list[str]:
    retest = at_fit or {}
    out = []
    for f in fits:
        if not f.observable:
            continue
        dof = max(n_obs - len(f.hypothesis.parameters), 1)
        if min(f.chi2, retest.get(f.name, math.inf)) <= _chi2_limit(dof, alpha):
            out.append(f.name)
    return out  # empty: nothing fits (diagnostics.goodness states it)


def _credible_set(fits: list[HypothesisFit], level: float = 0.95) -> list[str]:
    out, total = [], 0.0
    for f in fits:
        if not f.observable:
            continue
        out.append(f.name)
        total += f.probability
        if total >= level:
            break
    return out


def _u_default(sensor: str, value: float, model_rel: float) -> float:
    u = DEFAULT_INSTRUMENTS[sensor].reading(abs(value) if value else 1e-12).u
    return math.hypot(u, model_rel * value)


def _separation(ranker: Ranker, a: HypothesisFit, b: HypothesisFit, present: set[str],
                model_rel: float) -> Separation:
    best_sensor, best = None, 0.0
    for sensor in OBSERVABLES:
        if sensor in present or (sensor == "velocity_ratio"
                                 and {"speed_work", "speed_return"} <= present):
            continue
        acc = 0.0
        for pa, pb in zip(a.predicted, b.predicted, strict=True):
            u = _u_default(sensor, 0.5 * (pa[sensor] + pb[sensor]), model_rel)
            acc += ((pa[sensor] - pb[sensor]) / u) ** 2
        if math.sqrt(acc) > best:
            best_sensor, best = sensor, math.sqrt(acc)
    return Separation(a.name, b.name, best_sensor, best)


def _signature(ranker: Ranker, name: str) -> np.ndarray:
    """σ-scaled change of the present readings at a moderate fault, all records."""
    parts = []
    for m in ranker.models:
        hm = m.maps.maps[name]
        (p,) = hm.params
        ref = _REFERENCE[p.name]
        value = ref if p.name in ("pump_leak", "seat_leak") else ref * p.nominal_value(ranker.rig)
        k = int(np.argmin(np.abs(hm.axes[0] - p.to_z(value))))
        parts.append((hm.pred[k, m.idx] - m.maps.nominal[m.idx]) / m.sigma)
    return np.concatenate(parts)


def isolability(ranker: Ranker, fits: list[HypothesisFit], model_rel: float = 0.002,
                at_fit: Mapping[str, float] | None = None) -> Isolability:
    """Isolability statement for ranked ``fits`` of ``ranker``'s records; ``at_fit``: the
    χ² of one-parameter fits with the stated condition's sensitivity at their estimates
    (:func:`diagnostics.condition_interval.check_singles`), which keeps a fit its own χ²
    rejects in the ambiguity set when it passes."""
    present = {n for m in ranker.models for n in m.obs.names}
    amb = _consistent_set(fits, ranker.n_obs, at_fit=at_fit)
    cred = _credible_set(fits)
    statements: list[str] = []
    not_obs = [f.name for f in fits if not f.observable]
    for f in fits:
        if f.observable:
            continue
        if f.name == "relief_setting":
            p_max = max(pred["pump_pressure"] for pred in f.predicted)
            pset = PARAMETERS["Pset"].nominal_value(ranker.rig)
            lo = PARAMETERS["Pset"].low
            # the model's pressure, not a reading: it was quoted as "the pump pressure"
            # beside a measured one 3 bar lower, and for records without one (an
            # engineer's pass)
            measured = [float(m.obs.values[list(m.obs.names).index("pump_pressure")])
                        for m in ranker.models if "pump_pressure" in m.obs.names]
            read = (f"; measured {max(measured) / 1e5:.1f} bar" if measured else "")
            statements.append(
                f"relief_setting: not observable within its prior here — the model's pump "
                f"pressure at this condition ({p_max / 1e5:.1f} bar{read}) stays below even a "
                f"setting drifted to {lo:.0%} of its {pset / 1e5:.0f} bar, so no setting in "
                "that range opens (a lower one is tested when nothing else explains the "
                "readings: goodness_of_fit.beyond_range); check the setting by reading the "
                "pump pressure with the piston held on its end stop, or at a load that "
                "brings the pressure near the setting")
        else:
            statements.append(f"{f.name}: not observable with these sensors at these conditions "
                              f"(its largest effect is {f.detectability:.2f} σ)")
    setting = next((f for f in fits if f.name == "relief_setting" and f.observable), None)
    p_open = opening_pressure(ranker)
    pset_hi = PARAMETERS["Pset"].worn_bounds(ranker.rig)[1]
    if setting is not None and math.isfinite(p_open) and p_open < pset_hi:
        statements.append(
            f"relief_setting: a setting drifted to between {p_open / 1e5:.1f} and "
            f"{pset_hi / 1e5:.1f} bar does not open at these conditions and leaves the "
            "readings as the healthy rig's: these readings cannot see it (the probability "
            "of relief_setting is that of a setting that opens); check the setting with the "
            "piston held on its end stop")
    singles = [f.name for f in fits if len(f.hypothesis.parameters) == 1 and f.observable]
    sigs = {n: _signature(ranker, n) for n in singles}
    parallel: list[tuple[str, str, float]] = []
    for i, a in enumerate(singles):
        for b in singles[i + 1:]:
            va, vb = sigs[a], sigs[b]
            na, nb = float(np.linalg.norm(va)), float(np.linalg.norm(vb))
            if na == 0 or nb == 0:
                continue
            cos = abs(float(va @ vb)) / (na * nb)
            if cos >= 0.995:
                parallel.append((a, b, cos))
                statements.append(f"{a} and {b} move the present readings the same way "
                                  f"(signature cosine {cos:.4f}): these sensors cannot separate "
                                  "them at these conditions")
    seps: list[Separation] = []
    top = next((f for f in fits if f.observable), None)
    if top is not None:
        for f in fits:
            if f is top or f.name not in cred:
                continue
            sep = _separation(ranker, top, f, present, model_rel)
            seps.append(sep)
            if sep.sensor is not None and sep.sigma >= 2.0:
                statements.append(
                    f"{top.name} ({top.probability:.0%}) vs {f.name} ({f.probability:.0%}): adding "
                    f"{sep.sensor} would separate them by {sep.sigma:.1f} standard uncertainties")
            else:
                best = (f" (best: {sep.sensor}, {sep.sigma:.1f} σ)" if sep.sensor else
                        " (every listed sensor is already in the records)")
                statements.append(
                    f"{top.name} vs {f.name}: no listed sensor separates them at these "
                    f"conditions{best}; test at another load or temperature, or isolate the "
                    "component")
    if len(amb) > 1:
        statements.insert(0, "consistent with the readings (not separable by them): "
                          + ", ".join(amb))
    return Isolability(amb, cred, not_obs, parallel, seps, statements)
