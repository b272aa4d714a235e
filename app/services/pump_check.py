"""The checked part of a pump set: the loss model, its test points and its held-out error.

:func:`check_quantities` runs :func:`diagnostics.pump.check.check_losses` on a bench table at
the set's derived capacity and turns the result into named quantities with units, stored in
the set next to paper 000's coefficients (``GET /pump-sets/{id}`` reads them back; the
console's pumps page draws measured against model from them):

* ``points_dp`` [Pa], ``points_omega`` [rad/s], ``points_theta`` [degC], ``points_q``
  [m^3/s], ``points_T`` [N*m]: the test points the model was checked on;
* ``points_eta_v``, ``points_eta_hm`` [1]: each test point's volumetric and
  hydro-mechanical efficiency at the set's derived capacity;
* ``points_q_held_out`` [m^3/s], ``points_T_held_out`` [N*m]: each point predicted by the
  model fitted without that point's speed;
* ``check_flow_S``, ``check_torque_S`` [%]: their RMS error over the largest measured flow
  and torque;
* per oil-temperature level ``k``: ``lossK_theta`` [degC], ``lossK_flow_coef`` and
  ``lossK_torque_coef`` (the terms named in the description), ``lossK_flow_S``,
  ``lossK_flow_S_quadratic``, ``lossK_torque_S``, ``lossK_torque_S_quadratic`` [%].
"""

from __future__ import annotations

from typing import Any

import numpy as np

from diagnostics.pump.check import check_losses
from diagnostics.pump.data import BenchData
from diagnostics.pump.piston import LossFit
from sim.errors import InputError

__all__ = ["MAX_POINTS", "check_quantities"]

#: Most test points kept in a set (a larger table is checked, its points not stored) [-].
MAX_POINTS = 5000

_FLOW = "flow loss q_L = D·ω − q [m^3/s] = Σ cᵢ·termᵢ(Δp [Pa], ω [rad/s])"
_TORQUE = "torque loss T_L = T − D·Δp [N*m] = Σ cᵢ·termᵢ(Δp [Pa], ω [rad/s])"


def _q(value: Any, unit: str, description: str) -> dict[str, Any]:
    array = np.asarray(value, dtype=float)
    return {"value": array.tolist() if array.ndim else float(array), "unit": unit,
            "description": description}


def _model(fit: LossFit, what: str, theta: float, unit: str) -> dict[str, Any]:
    """A loss model's coefficients, unit "SI" (the store's word for a fit's coefficients):
    the description says each is in ``unit`` (the loss's) per its term's unit (a pump
    maker's pass read "SI" for coefficients of six different units)."""
    return _q(fit.coef, "SI", f"{what} at θ = {theta:.1f} °C; terms "
              f"{', '.join(fit.terms)}, each coefficient in [{unit}] per its term's unit "
              "(sign-checked, chosen by AIC; diagnostics.pump.piston)")


def _efficiencies(data: BenchData, D: float, m: Any) -> dict[str, dict[str, Any]]:
    """Volumetric and hydro-mechanical efficiency of each test point ``m`` at the set's
    derived capacity (paper 000 eqs. 1 and 13: ηv = q/(D·ω), ηhm = Δp·D/T): what a pump
    maker reads first from an ISO 4409 run (a pump maker's pass found them only as a
    console chart)."""
    out = {"points_eta_v": _q(data.q[m] / (D * data.omega[m]), "1",
                              "volumetric efficiency q/(D·ω) of each test point")}
    if data.torque is not None:
        out["points_eta_hm"] = _q(data.dp[m] * D / data.torque[m], "1",
                                  "hydro-mechanical efficiency Δp·D/T of each test point")
    return out


def check_quantities(data: BenchData, D: float) -> tuple[dict[str, dict[str, Any]], str]:
    """Quantities of the checked loss model (module docstring) and a note for the source.

    A table that cannot be checked (no torque, fewer than three speeds at every
    temperature) gives its points only, and the note says why.
    """
    try:
        check = check_losses(data, D)
    except InputError as exc:
        note = f"loss model not checked: {exc.message}"
        if len(data) > MAX_POINTS:
            return {}, note
        out = {"points_dp": _q(data.dp, "Pa", "pressure rise of each test point"),
               "points_omega": _q(data.omega, "rad/s", "speed of each test point"),
               "points_theta": _q(data.theta, "degC", "oil temperature of each test point"),
               "points_q": _q(data.q, "m^3/s", "measured flow of each test point")}
        if data.torque is not None:
            out["points_T"] = _q(data.torque, "N*m", "measured torque of each test point")
        return out | _efficiencies(data, D, slice(None)), note
    out = {}
    m = check.mask
    torque = data.torque
    assert torque is not None  # check_losses refuses a table without torque
    if int(m.sum()) <= MAX_POINTS:
        out.update({
            "points_dp": _q(data.dp[m], "Pa", "pressure rise of each checked test point"),
            "points_omega": _q(data.omega[m], "rad/s", "speed of each checked test point"),
            "points_theta": _q(data.theta[m], "degC",
                               "oil temperature of each checked test point"),
            "points_q": _q(data.q[m], "m^3/s", "measured flow of each checked test point"),
            "points_T": _q(torque[m], "N*m", "measured torque of each checked test point"),
            "points_q_held_out": _q(check.q_held_out, "m^3/s",
                                    "flow predicted with the point's speed left out of the fit"),
            "points_T_held_out": _q(check.torque_held_out, "N*m",
                                    "torque predicted with the point's speed left out of the "
                                    "fit"),
        } | _efficiencies(data, D, m))
    out["check_flow_S"] = _q(check.flow_S, "%", "RMS held-out flow error over the largest "
                             "measured flow, one speed left out at a time")
    out["check_torque_S"] = _q(check.torque_S, "%", "RMS held-out torque error over the "
                               "largest measured torque, one speed left out at a time")
    for k, level in enumerate(check.levels):
        h = level.held_out
        out[f"loss{k}_theta"] = _q(level.theta, "degC", "oil temperature of the level")
        out[f"loss{k}_flow_coef"] = _model(h.flow, _FLOW, level.theta, "m^3/s")
        out[f"loss{k}_torque_coef"] = _model(h.torque, _TORQUE, level.theta, "N*m")
        for key, value, what in (
                ("flow_S", h.flow_S, "held-out flow error of the loss model"),
                ("flow_S_quadratic", h.flow_S_quadratic,
                 "held-out flow error of a quadratic in (Δp, n), same split"),
                ("torque_S", h.torque_S, "held-out torque error of the loss model"),
                ("torque_S_quadratic", h.torque_S_quadratic,
                 "held-out torque error of a quadratic in (Δp, n), same split")):
            out[f"loss{k}_{key}"] = _q(value, "%", f"{what}, % of the level's largest value")
    notes = [f"loss model checked one speed out: flow S {check.flow_S:.3g} %, torque S "
             f"{check.torque_S:.3g} % of the largest measured", *check.skipped]
    return out, "; ".join(notes)
