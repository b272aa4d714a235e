"""The working/return velocity ratio as an index of internal clearance (paper 002 §3-4).

Paper 002 proposes the ratio of the average piston speeds of the working and return
phases as a cheap indicator of internal leakage: it falls, as a cubic in the clearance,
when the piston seal or the valve spool wears.  For a rig and an operating condition the
signature maps (:mod:`diagnostics.signatures`) hold the simulated ratio against the
piston clearance cc, the spool clearance cv and the pump's leakage factor; this module
inverts them.

What a ratio alone cannot tell: every one of these faults lowers it (the signs and sizes
are computed from the model for the rig and condition at hand, and stated in the result),
so one ratio gives one equivalent clearance *per hypothesis*, never the faulty component.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from diagnostics.hypotheses import PARAMETERS
from diagnostics.quantity import Quantity
from diagnostics.signatures import OBSERVABLES, signature_maps
from sim.rigs import Condition, Rig

__all__ = ["RatioIndex", "RatioInversion", "ratio_index"]

_IR = OBSERVABLES.index("velocity_ratio")
_FAULTS = (("cylinder", "cc"), ("valve", "cv"), ("pump", "pump_leak"))


@dataclass
class RatioInversion:
    """The parameter value that alone would explain a ratio.

    Attributes
    ----------
    component, parameter, unit
        Which fault.
    value, low, high
        Value and 95 % interval from the ratio's uncertainty [unit]; ``nan`` when the
        ratio is outside what this fault can produce over its range.
    sensitivity
        d(ratio)/d(parameter) at the nominal value [1/unit].
    """

    component: str
    parameter: str
    unit: str
    value: float
    low: float
    high: float
    sensitivity: float


@dataclass
class RatioIndex:
    """Inversion of a velocity ratio on the simulated maps."""

    ratio: float
    u: float
    nominal_ratio: float
    inversions: list[RatioInversion]
    statement: str


def _invert(z: np.ndarray, r: np.ndarray, target: float) -> float:
    """z at which the ratio map r(z) crosses ``target`` (first crossing), else nan."""
    d = r - target
    sign = np.sign(d)
    idx = np.nonzero(sign[:-1] * sign[1:] <= 0)[0]
    if idx.size == 0:
        return float("nan")
    i = int(idx[0])
    if d[i] == d[i + 1]:
        return float(z[i])
    return float(z[i] + (z[i + 1] - z[i]) * d[i] / (d[i] - d[i + 1]))


def ratio_index(rig: Rig, condition: Condition, ratio: Quantity) -> RatioIndex:
    """Invert a measured velocity ratio into cc, cv or a pump leakage factor."""
    maps = signature_maps(rig, condition)
    nominal = float(maps.nominal[_IR])
    out: list[RatioInversion] = []
    parts = []
    for component, pname in _FAULTS:
        p = PARAMETERS[pname]
        hm = maps.maps[component]
        z, r = hm.axes[0], hm.pred[:, _IR]
        vals = np.array([p.from_z(float(zz)) for zz in z])
        sens = float((r[1] - r[0]) / (vals[1] - vals[0]))
        centre = _invert(z, r, ratio.value)
        a = _invert(z, r, ratio.value + 1.96 * ratio.u)
        b = _invert(z, r, ratio.value - 1.96 * ratio.u)
        lo_z = np.nanmin([a, b, centre]) if not np.all(np.isnan([a, b, centre])) else np.nan
        hi_z = np.nanmax([a, b, centre]) if not np.all(np.isnan([a, b, centre])) else np.nan
        value = p.from_z(centre) if np.isfinite(centre) else float("nan")
        low = p.from_z(float(lo_z)) if np.isfinite(lo_z) else float("nan")
        high = p.from_z(float(hi_z)) if np.isfinite(hi_z) else float("nan")
        out.append(RatioInversion(component, pname, p.unit, value, low, high, sens))
        scale, unit = (1e6, "µm") if p.unit == "m" else (1.0, "×")
        shown = f"{value * scale:.3g} {unit}" if np.isfinite(value) else "out of its range"
        per = f"{sens / scale:+.2e} per {unit}"
        parts.append(f"{component} ({pname} {shown}; ratio {per})")
    falling = [i.component for i in out if i.sensitivity < 0]
    rising = [i.component for i in out if i.sensitivity > 0]
    how = (f"{', '.join(falling)} wear all lower the ratio" if not rising else
           f"{', '.join(falling) or 'none'} lower and {', '.join(rising)} raise the ratio")
    statement = (f"At this condition the healthy ratio is {nominal:.4f}; {how}, so the ratio "
                 f"alone cannot name the component. Ratio {ratio.value:.4f} ± {ratio.u:.4f} "
                 f"means, if one component alone is worn: " + "; ".join(parts) + ".")
    return RatioIndex(ratio.value, ratio.u, nominal, out, statement)
