"""The stored pump re-fitted with named effects on steady rows (the pump-bench workflow).

A stored pump is never exact (DISCREPANCY.md, item 3), so :mod:`~diagnostics.discrepancy.steady`
fits each candidate effect together with corrections of the pump's own laminar slip
(``1/Rlp``, column ``P``) and displacement (``Vp``, column ``ω``) to the residual of the stored
pump, paper 002 eqs. 1-5 at steady state::

    ω·(Vp − ΔVp) − q = P·(1/Rlp + ΔG) + Σ k·x_k

by least squares with White's errors on columns scaled to unit RMS (:func:`robust_ols`).
Here: that fit, the flow it predicts, the re-fitted pump, the effects' coefficients restated
for it (what the augmented rig must carry to deliver the fitted flow), the rig document
with the re-fitted pump, and the ``base drift`` test of the pump re-fitted alone.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from diagnostics.discrepancy.balances import carried
from diagnostics.discrepancy.drift import BaseDrift, Drift
from diagnostics.discrepancy.gap import GapRow
from diagnostics.discrepancy.regression import hac_cov
from diagnostics.discrepancy.signals import Signals
from diagnostics.discrepancy.verdict import OUTPUT_GAP
from sim.components.effects import EFFECTS
from sim.units import from_si

__all__ = ["BASE", "MAX_DISPLACEMENT_CHANGE", "base_change", "bench_drift", "combined", "drifted",
           "effect_flow", "model_flow",
           "on_refitted", "refitted_pump", "robust_ols", "stored_effects", "stored_fit",
           "with_base"]

Arr = npt.NDArray[np.float64]


def stored_effects(values: Mapping[str, float]) -> dict[str, float]:
    """The pump-outlet effects the stored rig already carries (effect → its coefficient
    [SI]): part of the stored pump a bench table is checked against
    (:func:`~diagnostics.discrepancy.balances.carried`)."""
    return carried(values, "pump_flow")


def effect_flow(s: Signals, coefs: Mapping[str, float]) -> Arr:
    """Σ k·x_k over ``coefs`` (effect → coefficient) [m³/s] at the rows of ``s``."""
    c = s.values
    q = np.zeros_like(c["speed"], dtype=float)
    for name, k in coefs.items():
        q = q + k * np.asarray(EFFECTS[name].entry.regressor(c), dtype=float)
    return q


def model_flow(values: Mapping[str, float], s: Signals, coefs: Mapping[str, float],
               base: Mapping[str, float] | None = None) -> Arr:
    """Flow of the stored pump (its own slip and displacement and the effects it carries,
    :func:`stored_effects`) plus effects ``coefs`` (effect → coefficient added) [m³/s],
    with the corrections ``base`` of its own parameters (:data:`BASE`: a laminar
    conductance added to 1/Rlp [m³/(s·Pa)], a displacement taken off Vp [m³/rad]) where
    given."""
    c = s.values
    b = base or {}
    q = (c["speed"] * (c["Vp"] - b.get("pump.Vp", 0.0))
         - c["P_pump"] * (1.0 / values["pump.Rlp"] + b.get("pump.Rlp", 0.0)))
    return np.asarray(q - effect_flow(s, combined(values, coefs)), dtype=float)


def combined(values: Mapping[str, float], coefs: Mapping[str, float]) -> dict[str, float]:
    """The stored effects' coefficients with ``coefs`` added (effect → coefficient [SI]):
    what a rig augmented by ``coefs`` carries at the stored displacement."""
    out = stored_effects(values)
    for name, k in coefs.items():
        out[name] = out.get(name, 0.0) + k
    return out


def robust_ols(X: Arr, y: Arr) -> tuple[Arr, Arr]:
    """Least-squares coefficients of ``y`` on the columns of ``X`` and their White (HC1)
    standard errors.

    The columns are scaled to unit RMS first (DISCREPANCY.md, item 4): the regressors of the
    pump balance differ by up to 10¹⁶ in size (P·ω·Vp against P²/μ), and the normal matrix
    of the raw columns is then singular to machine precision — its pseudo-inverse set the
    smaller column's error to zero, which passed any coefficient as significant (seen on
    the V32HL56 map, ``make real-data``).
    """
    scale = np.sqrt(np.mean(X * X, axis=0))
    scale[~(scale > 0)] = 1.0
    Xs = X / scale
    coef, *_ = np.linalg.lstsq(Xs, y, rcond=None)
    n, k = Xs.shape
    cov = hac_cov(Xs, y - Xs @ coef, 0) * n / max(n - k, 1)  # HC0 → HC1
    return coef / scale, np.sqrt(np.maximum(np.diag(cov), 0.0)) / scale


#: the pump's own parameters re-fitted with an effect (DISCREPANCY.md, item 3): the column
#: of each in the pump balance — the laminar slip 1/Rlp ∝ P, the displacement Vp ∝ ω
BASE = ("pump.Rlp", "pump.Vp")


def stored_fit(values: Mapping[str, float], s: Signals, names: list[str]
               ) -> tuple[dict[str, float], dict[str, float], dict[str, float]]:
    """Coefficients of ``names`` [SI] and their errors, fitted with corrections of the
    stored pump's laminar slip and displacement (:data:`BASE`, in :func:`model_flow`'s form)
    to the residual of the stored pump (OLS, White errors)."""
    coef, se = _residual_fit(values, s, names)
    return ({n: float(coef[2 + i]) for i, n in enumerate(names)},
            {n: float(se[2 + i]) for i, n in enumerate(names)},
            dict(zip(BASE, (float(coef[0]), float(coef[1])), strict=True)))


def _residual_fit(values: Mapping[str, float], s: Signals, names: list[str]
                  ) -> tuple[Arr, Arr]:
    """OLS coefficients and White errors of the stored pump's flow residual on the base
    corrections (1/Rlp: column P, Vp: column ω) and the effects ``names`` [SI]."""
    c = s.values
    r = (c["speed"] * c["Vp"] - c["Q_meter_B"] - c["P_pump"] / values["pump.Rlp"]
         - effect_flow(s, stored_effects(values)))
    X = np.column_stack([c["P_pump"], c["speed"]]
                        + [EFFECTS[n].entry.regressor(c) for n in names])
    return robust_ols(X, r)


def refitted_pump(values: Mapping[str, float], base: Mapping[str, float]) -> dict[str, float]:
    """The pump's Rlp [Pa·s/m³] and Vp [m³/rad] with the corrections ``base``
    (:func:`model_flow`'s form)."""
    return {"pump.Rlp": 1.0 / (1.0 / values["pump.Rlp"] + base["pump.Rlp"]),
            "pump.Vp": values["pump.Vp"] - base["pump.Vp"]}


def on_refitted(values: Mapping[str, float], base: Mapping[str, float], s: Signals,
                coefs: Mapping[str, float], errs: Mapping[str, float]
                ) -> tuple[dict[str, float], dict[str, float]]:
    """The effect coefficients and their errors restated for the re-fitted pump.

    :func:`stored_fit` fits each ``k·x_k`` with ``x_k`` evaluated at the *stored* Vp; the
    augmented rig evaluates its element with the *re-fitted* Vp (the compressibility loss
    ``k_b·P·Vp·ω``, the viscous slip ``C·P·Vp/μ``, the speed offset ``δω·Vp``).  So that
    the stored rig delivers the flow that was fitted, ``k`` becomes ``k·x_old/x_new`` —
    a constant, since a regressor is proportional to Vp or does not read it (least squares
    over the rows, exact then).  Without this a rig whose stored displacement was 3× off
    (the reference rig checked against a V32HL56 setting) carried a loss 3× too large.
    """
    new = dict(s.values)
    new["Vp"] = np.full_like(s.values["Vp"], refitted_pump(values, base)["pump.Vp"])
    out_k: dict[str, float] = {}
    out_e: dict[str, float] = {}
    for name, k in coefs.items():
        reg = EFFECTS[name].entry.regressor
        x_old = np.asarray(reg(s.values), dtype=float)
        x_new = np.asarray(reg(new), dtype=float)
        nn = float(x_new @ x_new)
        f = float(x_old @ x_new) / nn if nn > 0.0 else 1.0
        out_k[name], out_e[name] = k * f, errs[name] * abs(f)
    return out_k, out_e


def with_base(doc: Mapping[str, Any], values: Mapping[str, float],
              base: Mapping[str, float]) -> dict[str, Any]:
    """A copy of ``doc`` whose pump carries the re-fitted Rlp and Vp (in the document's
    own units), their sources saying so."""
    out = copy.deepcopy(dict(doc))
    params = out["components"]["pump"]["parameters"]
    for key, v in refitted_pump(values, base).items():
        name = key.partition(".")[2]
        entry = params[name] if isinstance(params[name], dict) else {"value": params[name]}
        params[name] = {**entry, "value": float(entry["value"]) * v / values[key],
                        "source": "re-fitted with the named effect by hydrodiag discover "
                                  "(steady pump-bench table)"}
    return out


def drifted(values: Mapping[str, float], alone: Mapping[str, float], rmse_alone: float,
            sigma: float) -> bool:
    """Whether the pump re-fitted alone (``alone``: :func:`stored_fit`'s corrections) is
    still a pump and brings the held-out flow RMSE [m³/s] within
    :data:`~diagnostics.discrepancy.verdict.OUTPUT_GAP` σ — the steady form of the
    transient workflow's ``base drift``."""
    return (all(v > 0.0 for v in refitted_pump(values, alone).values())
            and rmse_alone <= OUTPUT_GAP * sigma)


#: a re-fit that moves a pump's displacement by more than this share is neither wear nor
#: drift: the data come from another pump (a V32HL56 bench checked against rig 1 stored
#: its 17.5 cm³/rev pump as 57) [-]
MAX_DISPLACEMENT_CHANGE = 0.10

def base_change(values: Mapping[str, float], base: Mapping[str, float]) -> str:
    """``pump re-fitted: Rlp 6e+11 → 5.8e+11 Pa·s/m³, Vp 17.50 → 17.62 cm³/rev``: the pump
    re-fitted by ``base``, the displacement per revolution as datasheets state it; a
    displacement moved by more than :data:`MAX_DISPLACEMENT_CHANGE` is flagged (it does not
    wear: the data are of another pump, or the rig is the wrong one)."""
    new = refitted_pump(values, base)
    vp0, vp1 = values["pump.Vp"], new["pump.Vp"]
    text = (f"pump re-fitted: Rlp {values['pump.Rlp']:.4g} → {new['pump.Rlp']:.4g} Pa·s/m³, "
            f"Vp {from_si(vp0, 'cm^3/rev', 'm^3/rad'):.4g} → "
            f"{from_si(vp1, 'cm^3/rev', 'm^3/rad'):.4g} cm³/rev")
    change = vp1 / vp0 - 1.0
    if abs(change) > MAX_DISPLACEMENT_CHANGE:
        text += (f" (the displacement moved {100 * change:+.0f} %: a displacement does not "
                 "wear, so the data come from another pump, or the rig is the wrong one)")
    return text


def bench_drift(values: Mapping[str, float], s: Signals, gap_after: list[GapRow],
                sigma_flow: float) -> Drift:
    """The pump re-fitted alone (:func:`stored_fit` without effects) as a
    :class:`~diagnostics.discrepancy.drift.Drift`: Rlp and Vp stored and re-fitted, each
    with its White error carried through ``1/Rlp + c`` and ``Vp − c`` [SI], and the
    held-out flow gap with them.  The cycle path reported this in ``base_drift``; a bench
    table's "base drift" once said it only in its message."""
    coef, se = _residual_fit(values, s, [])
    new = refitted_pump(values, dict(zip(BASE, (float(coef[0]), float(coef[1])), strict=True)))
    rlp_error = new["pump.Rlp"] ** 2 * float(se[0])   # |∂Rlp/∂c| = Rlp²
    parameters = [
        BaseDrift("pump.Rlp", "Pa*s/m^3", "internal leakage: wear, or a stored value that "
                  "never matched this pump", values["pump.Rlp"], new["pump.Rlp"], rlp_error),
        BaseDrift("pump.Vp", "m^3/rad", "displacement: does not wear; a change is another "
                  "pump or a wrong stored value", values["pump.Vp"], new["pump.Vp"],
                  float(se[1]))]
    return Drift(parameters, gap_after, [], {"Q_meter_B": gap_after[0].rmse / sigma_flow},
                 accepted=True, reason="")
