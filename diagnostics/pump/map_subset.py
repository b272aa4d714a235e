"""Paper 001's best-subset models on a single-temperature efficiency map, one speed left out.

Paper 001 §3 fits the delivered flow ``Q`` [m³/s] (and, for the motor, the shaft torque
``T`` [N·m]) as a constant plus the displacement term plus a best subset of the physical
loss terms of its Table 1 (:mod:`diagnostics.pump.terms`), chosen by AIC among the subsets
that pass a VIF screen, and reports the mean standard error S and R² (in-sample).  Here the
same selection runs on one displacement setting of a measured map at one assumed viscosity,
with the terms' expected signs checked (:func:`diagnostics.pump.selection.best_subset`),
and each speed level is left out in turn: the model chosen on the other speeds predicts it.

At one temperature μ is a constant, so some Table 1 columns become proportional to others
(Vi·Δp/μ and Vi·Δp/β; Δp²/μ and Δp²; μ·ω² and ρ·Vi^(5/3)·ω²): only the first of each
proportional group is kept (:func:`distinct_columns`), the others are not identifiable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from diagnostics.pump.levels import cluster_levels
from diagnostics.pump.piston import PistonMap
from diagnostics.pump.selection import RegressionModel, best_subset
from diagnostics.pump.terms import (
    FLOW_TERMS,
    TORQUE_TERMS,
    Term,
    TermContext,
    design_columns,
    expected_signs,
)
from sim.components.gear_pump import dynamic_viscosity
from sim.errors import InputError
from sim.fluid import Fluid

__all__ = ["SubsetHeldOut", "distinct_columns", "subset_held_out"]

Arr = npt.NDArray[np.float64]

#: VIF screen of paper 001 §3.1 (models with collinear terms are not admissible) [-].
MAX_VIF = 10.0


def distinct_columns(columns: dict[str, Arr], *, rtol: float = 1e-9) -> dict[str, Arr]:
    """The columns without those proportional to an earlier one (not identifiable)."""
    kept: dict[str, Arr] = {}
    for name, col in columns.items():
        unit = col / (np.linalg.norm(col) or 1.0)
        if all(abs(abs(float(unit @ (k / (np.linalg.norm(k) or 1.0)))) - 1.0) > rtol
               for k in kept.values()):
            kept[name] = col
    return kept


@dataclass(frozen=True)
class SubsetHeldOut:
    """Paper 001's selection on one setting.

    Attributes
    ----------
    response
        ``"flow"`` or ``"torque"``.
    model
        The model chosen on all the setting's points (its ``S`` [m³/s or N·m], ``r2``,
        ``vif`` are paper 001's in-sample figures).
    S_pct, r2
        In-sample S [% of the setting's largest response] and R² [-].
    held_out_S_pct, held_out_r2
        RMS error [% of the setting's largest response] and R² [-] of the predictions at each
        speed left out in turn.
    not_identifiable
        Table 1 terms dropped as proportional to a kept one at one temperature.
    """

    response: str
    model: RegressionModel
    S_pct: float
    r2: float
    held_out_S_pct: float
    held_out_r2: float
    not_identifiable: tuple[str, ...]


def _select(terms: tuple[Term, ...], forced: str, ctx: TermContext, y: Arr,
            max_terms: int) -> tuple[RegressionModel, dict[str, Arr], tuple[str, ...]]:
    all_cols = design_columns(terms, ctx)
    cols = distinct_columns(all_cols)
    dropped = tuple(n for n in all_cols if n not in cols)
    sel = best_subset(cols, y, forced=(forced,), max_terms=max_terms, max_vif=MAX_VIF,
                      signs={k: v for k, v in expected_signs(terms).items() if k in cols})
    return sel.best, cols, dropped


def subset_held_out(data: PistonMap, D: float, *, response: str = "flow",
                    theta: float = 50.0, max_terms: int = 4, rho: float = 865.0,
                    beta: float = 1.5e9, fluid: Fluid | None = None) -> SubsetHeldOut:
    """Paper 001's best subset on one setting ``D`` [m³/rad], one speed left out at a time.

    Parameters
    ----------
    data
        The setting's points.
    D
        Its displacement [m³/rad] (Vi of the terms).
    response
        ``"flow"`` (forced: constant and ω·Vi) or ``"torque"`` (constant and Vi·Δp).
    theta
        Assumed oil temperature [°C] (μ of the terms; enters only their scale).
    max_terms
        Largest number of loss terms beside the forced ones [-] (paper 001: 4-6).
    rho, beta, fluid
        Density [kg/m³], effective bulk modulus [Pa], and the oil for μ(θ).

    Raises
    ------
    InputError
        Fewer than 3 speed levels, or no subset passes the screen.
    """
    if response not in ("flow", "torque"):
        raise InputError("response must be 'flow' or 'torque'", field="response")
    w_idx, w_lev = cluster_levels(data.omega, field="Speed")
    if w_lev.size < 3:
        raise InputError(f"{w_lev.size} speed levels: leaving one out needs ≥ 3", field="Speed")
    mu = float(dynamic_viscosity(fluid if fluid is not None else Fluid(), theta))
    terms, forced = ((FLOW_TERMS, "disp") if response == "flow"
                     else (TORQUE_TERMS, "coul_wilson"))
    y = data.q if response == "flow" else data.torque

    def ctx(m: PistonMap) -> TermContext:
        return TermContext(dp=m.dp, omega=m.omega, mu=np.full(len(m), mu), rho=rho,
                           beta=beta, Vi=D)

    pred = np.zeros(len(data))
    for k in range(w_lev.size):
        test = w_idx == k
        model, _, _ = _select(terms, forced, ctx(data.subset(~test)), y[~test], max_terms)
        cols = design_columns(terms, ctx(data.subset(test)))
        pred[test] = model.predict(cols)
    model, _, dropped = _select(terms, forced, ctx(data), y, max_terms)
    full = float(np.max(y))
    res = y - pred
    sst = float(np.sum((y - y.mean()) ** 2))
    return SubsetHeldOut(response, model, 100.0 * model.S / full, model.r2,
                         100.0 * math.sqrt(float(np.mean(res**2))) / full,
                         1.0 - float(np.sum(res**2)) / sst, dropped)
