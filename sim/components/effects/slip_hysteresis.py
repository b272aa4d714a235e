"""Rate-dependent hysteresis of the gear-pump slip: the leakage remembers the last direction.

Paper 000 §5: "an appreciable hysteresis (different flow measured with the same working
conditions)"; after a pressure peak "the plate did not separate with the same magnitude of
the gears".  The base model (eq. 6) gives one slip per (Δp, ω, μ).

Law: a play (backlash) operator of half-width ``w_h`` [Pa] on the core pressure keeps a
memory ``m`` [Pa] that follows the pressure with time constant ``τ_h`` [s] once the pressure
leaves the band ±w_h around it (rate-dependent: a fast swing inside the band leaves no
trace); the direction of the last change is ``s = clip((Δp − m)/w_h, −1, 1)`` (+1 after a
rise, −1 after a fall) and the slip is scaled by ``1 + h·s``::

    dm/dt = dz(Δp − m, w_h)/τ_h                (dead zone dz, :func:`play_rate`)
    Q_slip = (1 + h·s)·[Q_s(Δp) + Q_st(Δp)]    (paper 000 eqs. 4, 5, 9)

Bond-graph change on the gear-pump fragment of paper 000 Figure 7, at ``pump.core``::

    0[pump.core] ── MSf(ΔQ)        ΔQ = −h·s·[Q_s(Δp) + Q_st(Δp)]
        m: auxiliary state (held in steady solutions: every m within the band is one)

h = 0 switches the source off exactly.  h > 0: more slip after a rise, less after a fall
(the plate "stuck" after a peak, paper 000 §5).

Equation-error signature on a field record (balance ``field_flow``):
``r ≈ −h·s·(Q_s + Q_st)/Q`` with ``s`` from the same play on the measured pressure.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, MSf, call
from sim.bondgraph.laws import law, table_lookup
from sim.components.base import declare
from sim.components.effects.base import FIELD_CIRCUIT, Arr, EffectEntry
from sim.components.gear_pump_laws import _direction, _laminar, _turbulent, direction, play_rate
from sim.params import Param

__all__ = ["ENTRY", "FROZEN", "PARAMETERS", "build", "hysteresis_flow", "memory_rate"]

NAME = "slip_hysteresis"

#: auxiliary states held at their guess in a steady solution (relative names)
FROZEN = ("m",)

PARAMETERS: tuple[Param, ...] = (
    Param("h", "1", 0.0, "effect strength, fitted (0 = off); paper 000 §5 'appreciable "
          "hysteresis'", "relative change of the slip with the direction of the last "
          "pressure change", lower=-0.9, upper=0.9, lower_inclusive=True),
    Param("w_h", "Pa", 3.0e5, "chosen: 3 bar play of the side-plate memory (paper 000 gives "
          "no value)", "half-width of the hysteresis band", lower=1e3, upper=1e7),
    Param("tau_h", "s", 0.02, "chosen: fast relaxation of the play operator (below the "
          "30 ms field sampling)", "time constant of the hysteresis memory", lower=1e-4,
          upper=10.0),
)


@law
def memory_rate(p: float, m: float, w: float, tau: float) -> float:
    """dm/dt of the play operator [Pa/s] (:func:`~sim.components.gear_pump_laws.play_rate`)."""
    return play_rate(p - m, w, tau)


@law
def hysteresis_flow(dp: float, m: float, h: float, w: float, omega: float, t: float, p: Arr,
                    off: int, n: int, D: float, rho: float, dp_s: float,
                    *c: float) -> float:
    """ΔQ = −h·s·[Q_s(Δp) + Q_st(Δp)] [m³/s]; ``c`` holds the Cs then the Cst surface
    (each ``p_ref, omega_ref, c00 … c33``); 0 at h = 0."""
    if h == 0.0:
        return 0.0
    mu = table_lookup(t, p, off, n)
    cs = c[0:18]
    cst = c[18:36]
    q = (_laminar(dp, omega, mu, D, cs[0], cs[1], cs[2:])
         + _turbulent(dp, omega, rho, D, dp_s, cst[0], cst[1], cst[2:]))
    return -h * _direction(dp, m, w) * q


def _surface(pump: str, k: str) -> tuple[str, ...]:
    return (f"p:{pump}.{k}.p_ref", f"p:{pump}.{k}.omega_ref",
            *(f"p:{pump}.{k}.c{i}{j}" for i in range(4) for j in range(4)))


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None, *,
          pump: str = "pump") -> None:
    """Add the memory state and the flow source at ``{pump}.core`` (module docstring)."""
    declare(g, name, PARAMETERS, values)
    core, P = f"effort:{pump}.core", f"p:{pump}."
    w, tau = f"p:{name}.w_h", f"p:{name}.tau_h"
    m = g.integrate(f"{name}.m", call(memory_rate, core, f"x:{name}.m", w, tau),
                    scale=1e5, unit="Pa")
    g.add(MSf(f"{name}.Sf", hysteresis_flow, core, m, f"p:{name}.h", w, f"flow:{pump}.shaft",
              "t", f"tbl:{pump}.mu", f"{P}D", f"{P}rho", f"{P}dp_s", *_surface(pump, "Cs"),
              *_surface(pump, "Cst"), description="ΔQ = −h·s·(Q_s + Q_st)"))
    g.connect(f"{name}.Sf", f"{pump}.core", label=f"{name}.Sf")
    g.output(f"{name}.dQ", f"f:{name}.Sf", "m^3/s", "flow returned to the core, −h·s·Q_slip")
    g.output(f"{name}.direction", call(direction, core, m, w), "1",
             "direction of the last pressure change (+1 rising, −1 falling)")


def _regressor(s: Mapping[str, Arr]) -> Arr:
    return np.asarray(-s["direction"] * (s["Q_s"] + s["Q_st"]) / s["Q"], dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="the side plates remember the last pressure change: more slip after a rise, "
                "less after a fall at the same pressure (play of half-width w_h)",
    reference="paper 000 §5 (hysteresis in the ISO 4409 tests and the field)",
    circuit=FIELD_CIRCUIT, balance="field_flow", coefficient="h",
    signature="−s·(Q_s + Q_st)/Q, s = direction of the last pressure change",
    regressor=_regressor, sign=1.0, plausible=(0.0, 0.5))
