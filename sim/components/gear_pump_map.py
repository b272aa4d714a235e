"""A STAND-IN coefficient map for the 14.7 cm³/rev gear pump of paper 000.

**This is not bench data.**  The copy of paper 000 has lost Figure 3 (the four loss
coefficients versus pressure and speed); only its description survives (§3.1).  Until real
ISO 4409 results exist, hydrodiag uses the map below: polynomial surfaces C(Δp, ω) whose
*shapes* follow that description and whose *magnitudes* were chosen so that the pump
behaves like a healthy 14.7 cm³/rev external gear pump on ISO VG 46 oil.  Every figure
derived from it (virtual bench data, studies) is a demonstration, never a measurement.

Variables of the surfaces: ``x = Δp / 100 bar`` and ``y = n / 1000 rpm``
(:data:`~sim.components.gear_pump.P_REF`, :data:`~sim.components.gear_pump.OMEGA_REF`).
Domain: Δp = 20..250 bar (the paper dropped its 5 and 10 bar points from the fits, §5;
250 bar is the highest relief setting of the field test), n = 600..2400 rpm (the speeds the
paper names, §3.1 and §5), oil 22..60 °C (the two ISO 4409 temperatures).

What Figure 3 shows (paper 000 §3.1) and how each surface follows it:

* **Cs** (laminar slip) falls with pressure (side plates pressed on the gears, eq. 4) and
  falls slightly with speed; at high speed, low pressure it turns negative (2200 and
  2400 rpm), because dragged Couette flow exceeds Poiseuille slip.  Built as a film part
  minus an apparent Couette part that fades with pressure and grows with speed::

      Cs = [2.0 + 4.3(1 − x/2.5)²]·[1 − 0.05(y − 0.6)]·1e-9 − 9.0e-9·(1 − x/2.5)³·(y/2.4)³

  (Cs ≈ 5.5e-9 at 20 bar / 600 rpm, 2.0e-9 at 250 bar, −1.9e-9 at 20 bar / 2400 rpm.)
* **Cst** (turbulent slip) grows up to about 150 bar, then levels off::

      Cst = 4.0e-5·(1 + 1.2x − 0.4x²)·[1 − 0.04(y − 1.5)]        (maximum at x = 1.5)

* **Cv** (viscous friction) rises as the films thin, i.e. with pressure and with speed::

      Cv = 2.0e4·(1 + 0.25x)·[1 + 0.08(y − 1.5)]

* **Cf** (Coulomb friction) falls quickly from 0 to 100 bar, then little (72 % of its fall
  happens below 100 bar), slightly lower at high speed::

      Cf = [0.035 + 0.09(1 − x/2.5)³]·[1 − 0.03(y − 1.5)]

Magnitudes (chosen, not measured): with D = 14.7 cm³/rev and ISO VG 46 oil the map gives a
volumetric efficiency between about 92 % (250 bar, 600 rpm, 60 °C) and 99.9 % over the
domain, i.e. above 90 % everywhere as the paper reports, and a hydro-mechanical efficiency of
0.89-0.96 at 100-250 bar, down to 0.72 at 20 bar / 2400 rpm / 22 °C where viscous torque
dominates.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import polynomial as npoly

from sim.components.gear_pump import CoefficientSurface, FloatArray, GearPump
from sim.fluid import Fluid

__all__ = [
    "MAP_OMEGA_RANGE",
    "MAP_P_RANGE",
    "MAP_TEMPERATURES",
    "stand_in_coefficients",
    "stand_in_pump",
]

#: Pressure-rise domain of the stand-in map [Pa] (20..250 bar).
MAP_P_RANGE: tuple[float, float] = (20e5, 250e5)
#: Speed domain of the stand-in map [rad/s] (600..2400 rpm).
MAP_OMEGA_RANGE: tuple[float, float] = (600 * 2 * math.pi / 60, 2400 * 2 * math.pi / 60)
#: The two ISO 4409 oil temperatures of paper 000 [°C].
MAP_TEMPERATURES: tuple[float, float] = (22.0, 60.0)


def _p(*c: float) -> FloatArray:
    return np.array(c, dtype=np.float64)


def _pow(base: FloatArray, k: int) -> FloatArray:
    out = _p(1.0)
    for _ in range(k):
        out = np.asarray(npoly.polymul(out, base), dtype=np.float64)
    return out


def _add(a: FloatArray, b: FloatArray) -> FloatArray:
    out = np.zeros((max(a.shape[0], b.shape[0]), max(a.shape[1], b.shape[1])))
    out[: a.shape[0], : a.shape[1]] += a
    out[: b.shape[0], : b.shape[1]] += b
    return out


def stand_in_coefficients() -> dict[str, CoefficientSurface]:
    """The four stand-in surfaces ``{"Cs", "Cst", "Cv", "Cf"}`` (formulas in the module doc).

    Returns
    -------
    dict of str to CoefficientSurface
        Surfaces in ``x = Δp/100 bar`` and ``y = n/1000 rpm`` [-].
    """
    fade = _p(1.0, -1.0 / 2.5)  # (1 − x/2.5)
    film = np.asarray(npoly.polyadd(_p(2.0e-9), 4.3e-9 * _pow(fade, 2)), dtype=np.float64)
    couette = -9.0e-9 * _pow(fade, 3)
    cs = _add(np.outer(film, _p(1.0 + 0.05 * 0.6, -0.05)),
              np.outer(couette, _p(0.0, 0.0, 0.0, 1.0 / 2.4**3)))
    cst = np.outer(4.0e-5 * _p(1.0, 1.2, -0.4), _p(1.0 + 0.04 * 1.5, -0.04))
    cv = np.outer(2.0e4 * _p(1.0, 0.25), _p(1.0 - 0.08 * 1.5, 0.08))
    coulomb = np.asarray(npoly.polyadd(_p(0.035), 0.09 * _pow(fade, 3)), dtype=np.float64)
    cf = np.outer(coulomb, _p(1.0 + 0.03 * 1.5, -0.03))
    return {name: CoefficientSurface(c) for name, c in
            (("Cs", cs), ("Cst", cst), ("Cv", cv), ("Cf", cf))}


def stand_in_pump(fluid: Fluid | None = None) -> GearPump:
    """The stand-in 14.7 cm³/rev gear pump (STAND-IN map, not bench data; see module doc).

    Parameters
    ----------
    fluid
        Oil (default :class:`sim.fluid.Fluid`, ISO VG 46 as in paper 000).

    Returns
    -------
    GearPump
        D = 14.7 cm³/rev [m³/rad], ρ = 865 kg/m³, β_ef = 1.5e9 Pa, surfaces of
        :func:`stand_in_coefficients`, valid over :data:`MAP_P_RANGE` × :data:`MAP_OMEGA_RANGE`.
    """
    c = stand_in_coefficients()
    return GearPump(
        Cs=c["Cs"], Cst=c["Cst"], Cv=c["Cv"], Cf=c["Cf"],
        fluid=fluid if fluid is not None else Fluid(),
        p_range=MAP_P_RANGE, omega_range=MAP_OMEGA_RANGE,
        note="STAND-IN map following the description of paper 000 Figure 3; not bench data",
    )
