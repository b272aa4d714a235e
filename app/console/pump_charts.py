"""Charts of a checked pump set: measured against model, from the points the set stores.

The quantities come from :mod:`app.services.pump_check` (``points_*``): each test point's
measured flow and torque and the loss model's prediction of it with that point's speed left
out of the fit.  Drawn per speed (and per oil-temperature level), against the pressure rise:

* flow [l/min]: measured (points) and model (dashed line);
* torque [N·m]: likewise;
* held-out residuals, measured − model, of flow [l/min] and torque [N·m];
* overall efficiency Δp·q/(T·ω) [%]: measured and model — the pump's efficiency map.

Built with :mod:`diagnostics.plots` like every other chart of the console and the reports.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from diagnostics.plots import PALETTE, Chart, Series, line_chart, shown_unit
from diagnostics.pump.levels import cluster_levels, group_keys

__all__ = ["pump_check_charts"]

# the plotting module's units, as every chart's: (l/min) per (m³/s), bar per Pa, rpm per
# (rad/s)
_LPM = shown_unit("m^3/s")[0]
_BAR = shown_unit("Pa")[0]
_RPM = shown_unit("rad/s")[0]
_NEEDED = ("points_dp", "points_omega", "points_theta", "points_q", "points_T",
           "points_q_held_out", "points_T_held_out")


def _groups(omega: npt.NDArray[np.float64], theta: npt.NDArray[np.float64]
            ) -> list[tuple[str, npt.NDArray[np.bool_]]]:
    """(legend label, mask) of each speed (and temperature, when there are several)."""
    w_idx, _ = cluster_levels(omega, field="omega")
    t_idx, t_lev = cluster_levels(theta, abs_gap=2.0, field="theta")
    keys = group_keys(t_idx, w_idx)
    out = []
    for k in np.unique(keys):
        m = keys == k
        label = f"{np.mean(omega[m]) * _RPM:.0f} rpm"
        if t_lev.size > 1:
            label += f", {np.mean(theta[m]):.0f} °C"
        out.append((label, m))
    return out


def _pair_chart(title: str, ylabel: str, dp: npt.NDArray[np.float64],
                measured: npt.NDArray[np.float64], model: npt.NDArray[np.float64],
                groups: list[tuple[str, npt.NDArray[np.bool_]]]) -> Chart:
    series: list[Series] = []
    for i, (label, m) in enumerate(groups):
        color = PALETTE[i % len(PALETTE)]
        order = np.argsort(dp[m])
        x = dp[m][order] * _BAR
        series.append(Series(x, measured[m][order], label, kind="points", color=color))
        series.append(Series(x, model[m][order], "", dashed=True, color=color))
    return line_chart(title, "Δp [bar]", ylabel, series, size=(7.0, 3.6))


def pump_check_charts(quantities: Mapping[str, Any]) -> list[Chart]:
    """Measured-vs-model charts of a pump set (module docstring); ``[]`` when it stores no
    checked points (a hand-made set, or one whose table could not be checked)."""
    try:
        v = {k: np.asarray(quantities[k]["value"], dtype=float) for k in _NEEDED}
    except (KeyError, TypeError, ValueError):
        return []
    n = v["points_q"].size
    if n == 0 or any(a.shape != (n,) for a in v.values()):
        return []
    dp, w = v["points_dp"], v["points_omega"]
    groups = _groups(w, v["points_theta"])
    note = " (dashed: model fitted without that speed)"
    charts = [
        _pair_chart("Flow: measured and model" + note, "q [l/min]", dp, v["points_q"] * _LPM,
                    v["points_q_held_out"] * _LPM, groups),
        _pair_chart("Torque: measured and model" + note, "T [N·m]", dp, v["points_T"],
                    v["points_T_held_out"], groups),
    ]
    for what, unit, scale, meas, model in (
            ("flow", "l/min", _LPM, v["points_q"], v["points_q_held_out"]),
            ("torque", "N·m", 1.0, v["points_T"], v["points_T_held_out"])):
        series = [Series(dp[m] * _BAR, (meas[m] - model[m]) * scale, label, kind="points",
                         color=PALETTE[i % len(PALETTE)])
                  for i, (label, m) in enumerate(groups)]
        charts.append(line_chart(f"Held-out {what} residual, measured − model", "Δp [bar]",
                                 f"{what} residual [{unit}]", series, hlines=[(0.0, "")],
                                 size=(7.0, 3.0)))
    with np.errstate(divide="ignore", invalid="ignore"):
        eff = 100.0 * dp * v["points_q"] / (v["points_T"] * w)
        eff_model = 100.0 * dp * v["points_q_held_out"] / (v["points_T_held_out"] * w)
    if np.all(np.isfinite(eff)) and np.all(np.isfinite(eff_model)):
        charts.append(_pair_chart("Overall efficiency Δp·q/(T·ω): measured and model",
                                  "η [%]", dp, eff, eff_model, groups))
    return charts
