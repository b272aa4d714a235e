"""Propagation of measurement uncertainty through an inversion.

Two methods, validated against each other in ``tests/diagnostics/test_inversion.py``:

* **Delta method** (GUM §5.1.2, law of propagation of uncertainty, independent inputs):
  ``u²(y) = Σ (∂f/∂x_i)² u²(x_i)`` with the sensitivities ``∂f/∂x_i`` from central
  differences of step ``1e-4·u(x_i)`` (the linearisation is over the scale the data are
  uncertain on).  The 95 % interval is ``y ± 1.96·u(y)``, clipped to the physical domain.
* **Monte Carlo** (GUM Supplement 1): each input is drawn from its distribution (normal,
  or rectangular of half-width ``√3·u`` for instrument-class bounds), the model is
  evaluated on all draws at once, ``u(y)`` is the standard deviation of the finite outputs
  and the 95 % interval the 2.5 and 97.5 percentiles (probabilistically symmetric).  The
  reported value is the model at the measured inputs, as for the delta method, so the two
  methods differ only in their spread.

``method="auto"`` (:func:`propagate`, the default of the inversions) uses the delta method
while the result is nearly linear and Monte Carlo beyond :data:`AUTO_RELATIVE_LIMIT`.  Two
findings of the coverage simulations behind that choice: with instrument-class (rectangular)
inputs the symmetric ±1.96·u interval of the delta method *over*-covers a well-determined
clearance (≈ 99 % for cc, because a sum of two rectangles has shorter tails than a normal),
while Monte Carlo's percentiles cover 95 %; and for a bypass flow comparable to the
flowmeter's uncertainty it *under*-covers (≈ 82 %).

A model is a vectorised function ``f(inputs) -> y`` of a mapping from input names to equal
shaped float arrays.  It returns ``nan`` where a draw has no solution; the fraction of
finite outputs is reported as ``valid_fraction``.  Inputs are taken as uncorrelated.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from diagnostics.quantity import Quantity
from sim.errors import InputError

__all__ = [
    "AUTO_RELATIVE_LIMIT",
    "Estimate",
    "Method",
    "Model",
    "delta_method",
    "monte_carlo",
    "propagate",
]

FloatArray = NDArray[np.float64]
Model = Callable[[Mapping[str, FloatArray]], FloatArray]
Method = Literal["delta", "monte-carlo", "auto"]
EstimateMethod = Literal["delta", "monte-carlo"]

#: two-sided 95 % coverage factor of the normal distribution
Z95 = 1.959963984540054

#: Relative standard uncertainty above which ``method="auto"`` switches from the delta
#: method to Monte Carlo.  Checked by simulation (tests/diagnostics/test_inversion.py): at
#: 5 % the delta intervals of cc and cv still cover ≈ 95 %; at 19 % (the nominal rig of
#: paper 002, bypass ≈ the flowmeter's uncertainty) the delta interval of cc covers 82 %,
#: Monte Carlo's 95 %.
AUTO_RELATIVE_LIMIT = 0.05


@dataclass(frozen=True, slots=True)
class Estimate:
    """An estimated parameter with its uncertainty.

    Attributes
    ----------
    quantity
        Name (``"cc"``, ``"cv"``, ``"Cs"``).
    unit
        SI unit of ``value``.
    value
        Estimate at the measured inputs [unit].
    u
        Standard uncertainty [unit].
    low, high
        Bounds of the 95 % interval [unit].
    method
        ``"delta"`` or ``"monte-carlo"`` (what produced ``u``, ``low``, ``high``).
    sensitivities
        ``∂value/∂input`` [unit/input unit] at the measured inputs (delta method; kept
        when ``"auto"`` switched to Monte Carlo).
    contributions
        Each input's share of ``u²`` [-] to first order, summing to 1 (as above).
    valid_fraction
        Fraction of Monte Carlo draws with a solution (1 for the delta method).
    derived
        Intermediate results at the measured inputs (bypass flow, viscosity...) [SI].
    notes
        Warnings a reader must see (ambiguous root, clipped draws...).
    """

    quantity: str
    unit: str
    value: float
    u: float
    low: float
    high: float
    method: EstimateMethod
    sensitivities: Mapping[str, float] = field(default_factory=dict)
    contributions: Mapping[str, float] = field(default_factory=dict)
    valid_fraction: float = 1.0
    derived: Mapping[str, float] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    @property
    def relative(self) -> float:
        """Relative standard uncertainty u/|value| [-]."""
        return self.u / abs(self.value) if self.value != 0.0 else math.inf


def _evaluate(model: Model, values: Mapping[str, FloatArray]) -> FloatArray:
    return np.asarray(model(values), dtype=np.float64)


def delta_method(model: Model, inputs: Mapping[str, Quantity], *, quantity: str, unit: str,
                 lower: float | None = None) -> Estimate:
    """First-order propagation (GUM §5.1.2) with numerical sensitivities.

    Parameters
    ----------
    model
        Vectorised model (module docstring).
    inputs
        Input quantities by name, taken as uncorrelated.
    quantity, unit
        Name and unit of the output.
    lower
        Physical lower bound of the output [unit] (0 for a clearance): the interval is
        clipped to it.

    Returns
    -------
    Estimate
        With ``sensitivities`` and ``contributions``.
    """
    names = list(inputs)
    x0 = np.array([inputs[n].value for n in names])
    steps = np.array([_step(inputs[n]) for n in names])
    k = len(names)
    # one vectorised call: the nominal point, then +h and −h for each input
    grid = np.repeat(x0[:, None], 2 * k + 1, axis=1)
    for i in range(k):
        grid[i, 1 + 2 * i] += steps[i]
        grid[i, 2 + 2 * i] -= steps[i]
    y = _evaluate(model, {n: grid[i] for i, n in enumerate(names)})
    value = float(y[0])
    sens = {n: float((y[1 + 2 * i] - y[2 + 2 * i]) / (2.0 * steps[i])) for i, n in
            enumerate(names)}
    terms = {n: (sens[n] * inputs[n].u) ** 2 for n in names}
    var = sum(terms.values())
    u = math.sqrt(var)
    contributions = {n: (t / var if var > 0.0 else 0.0) for n, t in terms.items()}
    low, high = value - Z95 * u, value + Z95 * u
    if lower is not None:
        low = max(low, lower)
    notes = () if math.isfinite(value) else ("the model has no solution at the measured inputs",)
    return Estimate(quantity, unit, value, u, low, high, "delta", sens, contributions, 1.0,
                    notes=notes)


def _step(q: Quantity) -> float:
    if q.u > 0.0:
        return 1e-4 * q.u
    return 1e-7 * abs(q.value) if q.value != 0.0 else 1e-12


def monte_carlo(model: Model, inputs: Mapping[str, Quantity], *, quantity: str, unit: str,
                n: int = 20_000, rng: np.random.Generator | None = None) -> Estimate:
    """Monte Carlo propagation (GUM Supplement 1).

    Parameters
    ----------
    model
        Vectorised model (module docstring).
    inputs
        Input quantities by name, uncorrelated; each drawn from its ``distribution``.
    quantity, unit
        Name and unit of the output.
    n
        Number of draws.
    rng
        Random generator; default ``np.random.default_rng(0)`` so results are reproducible.
    """
    if n < 100:
        raise InputError(f"Monte Carlo propagation needs at least 100 draws, got {n}", field="n")
    gen = np.random.default_rng(0) if rng is None else rng
    draws: dict[str, FloatArray] = {}
    for name, q in inputs.items():
        if q.distribution == "rectangular":
            noise = gen.uniform(-math.sqrt(3.0), math.sqrt(3.0), n)
        else:
            noise = gen.standard_normal(n)
        draws[name] = q.value + q.u * noise
    y = _evaluate(model, draws)
    finite = y[np.isfinite(y)]
    value = float(_evaluate(model, {k: np.array([q.value]) for k, q in inputs.items()})[0])
    valid = finite.size / n
    notes: list[str] = []
    if valid < 1.0:
        notes.append(f"{100 * (1 - valid):.2g} % of draws had no solution and were left out")
    if finite.size < 2:
        return Estimate(quantity, unit, value, math.nan, math.nan, math.nan, "monte-carlo",
                        valid_fraction=valid, notes=(*notes, "no usable draws"))
    low, high = np.percentile(finite, [2.5, 97.5])
    return Estimate(quantity, unit, value, float(np.std(finite, ddof=1)), float(low),
                    float(high), "monte-carlo", valid_fraction=valid, notes=tuple(notes))


def propagate(model: Model, inputs: Mapping[str, Quantity], *, quantity: str, unit: str,
              method: Method = "auto", lower: float | None = None, n: int = 20_000,
              rng: np.random.Generator | None = None, nonlinear: bool = False) -> Estimate:
    """Propagate by ``method``: ``"delta"``, ``"monte-carlo"`` or ``"auto"``.

    ``"auto"`` runs the delta method and keeps it while the relative standard uncertainty
    is at most :data:`AUTO_RELATIVE_LIMIT`; beyond, the curvature of the inversion makes the
    symmetric interval wrong (the cube root of a noisy bypass flow is skewed), and the
    Monte Carlo result is returned instead, carrying the delta method's sensitivities and
    contributions (still the right ranking of which sensor matters).  ``nonlinear=True``
    (the caller knows the estimate sits on a bound) makes ``"auto"`` choose Monte Carlo.
    """
    if method not in ("delta", "monte-carlo", "auto"):
        raise InputError(f"unknown propagation method {method!r}", field="method")
    if method == "monte-carlo":
        return monte_carlo(model, inputs, quantity=quantity, unit=unit, n=n, rng=rng)
    d = delta_method(model, inputs, quantity=quantity, unit=unit, lower=lower)
    linear = not nonlinear and math.isfinite(d.relative) and d.relative <= AUTO_RELATIVE_LIMIT
    if method == "delta" or linear:
        return d
    m = monte_carlo(model, inputs, quantity=quantity, unit=unit, n=n, rng=rng)
    return replace(m, sensitivities=d.sensitivities, contributions=d.contributions)
