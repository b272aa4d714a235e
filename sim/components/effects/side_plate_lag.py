"""Side-plate lag of the gear-pump slip: the leakage follows pressure steps late.

Paper 000 §5 (Figure 10, and the conclusions): "the measured flow shows the time required
for internal hydrodynamic adjustment of the pump parts, and therefore, a delay occurred";
the axial compensation presses the side plates against the gears with a delay, so the
slip after a pressure step is that of the *previous* balance for a while.  The base model
(paper 000 eq. 6) computes the slip from the instantaneous pressure.

Law: the side plates sit at the balance pressure ``p_sp`` [Pa], a first-order lag of the
core pressure Δp with time constant τ [s]; the slip is evaluated there::

    τ·dp_sp/dt = Δp − p_sp
    Q_slip = Q_s(p_sp) + Q_st(p_sp)          (paper 000 eqs. 4, 5, 9 at p_sp)

Bond-graph change on the gear-pump fragment of paper 000 Figure 7
(:mod:`sim.components.gear_pump_fragment`), at its core 0-junction ``pump.core``::

    0[pump.core] ── MSf(ΔQ)       ΔQ = [Q_s(Δp) − Q_s(p_sp)] + [Q_st(Δp) − Q_st(p_sp)]
        p_sp: auxiliary state, dp_sp/dt = (Δp − p_sp)/τ

The flow source returns to the core the slip the lag holds back (base slip elements stay
as they are), so the core's net slip is eq. 6 at ``p_sp``.  It is a source, not an R: while
the pressure rises it delivers flow (the plates still sit where the lower pressure put
them), so its power has either sign.  τ = 0 switches the source off exactly (the base
right-hand side bit for bit); the state then relaxes on a 1 s scale, decoupled, so that
the steady solution stays regular.

Equation-error signature on a field record (balance ``field_flow``: ``r = q_meas/q_model − 1``):
the held-back slip is ``(∂Q_slip/∂p)·(Δp − p_sp)`` and ``Δp − p_sp = τ·ṗ_sp``, the pressure
rate seen through the lag itself, so ``r ≈ τ·(Q_s + Q_st/2)/P·L(ṗ)/Q`` (laminar slip ∝ P,
turbulent ∝ √P) with ``L`` a first-order lag.  The regressor filters ṗ with the nominal
:data:`TAU_REF`: linear in τ, it keeps the shape of the signature (a decay after each step,
not a spike during the ramp, which is all a plain ṗ column has and which under-estimates τ
three-fold at τ = 0.3 s on 0.15-0.4 s ramps); the output-error fit then finds τ itself.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from sim.bondgraph import BondGraph, MSf, call
from sim.bondgraph.laws import law, table_lookup
from sim.components.base import declare
from sim.components.effects.base import FIELD_CIRCUIT, Arr, EffectEntry
from sim.components.gear_pump_laws import _laminar, _turbulent
from sim.params import Param

__all__ = ["ENTRY", "PARAMETERS", "TAU_OFF", "TAU_REF", "build", "lag_laminar", "lag_rate",
           "lag_turbulent", "lagged_rate"]

NAME = "side_plate_lag"

#: relaxation time of the (decoupled) lag state when τ = 0 [s]
TAU_OFF = 1.0

#: nominal time constant of the regressor's filter [s]: the generator's chosen τ of
#: :mod:`sim.components.gear_pump_fragment` ("time required for internal hydrodynamic
#: adjustment", paper 000 §5, visible at 30 ms sampling)
TAU_REF = 0.3

PARAMETERS: tuple[Param, ...] = (
    Param("tau", "s", 0.0, "effect strength, fitted (0 = off); paper 000 §5, Fig. 10",
          "time constant of the side-plate balance (first-order lag of the slip)",
          lower=0.0, upper=10.0, lower_inclusive=True),
)


@law
def lag_rate(p: float, x: float, tau: float) -> float:
    """dp_sp/dt = (Δp − p_sp)/τ [Pa/s]; with τ = 0, (Δp − p_sp)/:data:`TAU_OFF` (state unused)."""
    return (p - x) / (tau if tau > 0.0 else 1.0)


@law
def lag_laminar(dp: float, p_sp: float, tau: float, omega: float, t: float, p: Arr, off: int,
                n: int, D: float, p_ref: float, omega_ref: float, *c: float) -> float:
    """Laminar slip held back by the lag, Q_s(Δp) − Q_s(p_sp) [m³/s] (paper 000 eq. 4); 0 at τ = 0."""
    if tau <= 0.0:
        return 0.0
    mu = table_lookup(t, p, off, n)
    return (_laminar(dp, omega, mu, D, p_ref, omega_ref, c)
            - _laminar(p_sp, omega, mu, D, p_ref, omega_ref, c))


@law
def lag_turbulent(dp: float, p_sp: float, tau: float, omega: float, rho: float, D: float,
                  dp_s: float, p_ref: float, omega_ref: float, *c: float) -> float:
    """Turbulent slip held back by the lag, Q_st(Δp) − Q_st(p_sp) [m³/s] (paper 000 eqs. 5, 9)."""
    if tau <= 0.0:
        return 0.0
    return (_turbulent(dp, omega, rho, D, dp_s, p_ref, omega_ref, c)
            - _turbulent(p_sp, omega, rho, D, dp_s, p_ref, omega_ref, c))


def _surface(pump: str, k: str) -> tuple[str, ...]:
    return (f"p:{pump}.{k}.p_ref", f"p:{pump}.{k}.omega_ref",
            *(f"p:{pump}.{k}.c{i}{j}" for i in range(4) for j in range(4)))


def build(g: BondGraph, name: str = NAME, values: Mapping[str, float] | None = None, *,
          pump: str = "pump") -> None:
    """Add the lag state and the flow source at ``{pump}.core`` (module docstring)."""
    declare(g, name, PARAMETERS, values)
    core, P = f"effort:{pump}.core", f"p:{pump}."
    tau = f"p:{name}.tau"
    state = g.integrate(f"{name}.p_sp", call(lag_rate, core, f"x:{name}.p_sp", tau),
                        scale=1e5, unit="Pa")
    omega = f"flow:{pump}.shaft"
    g.add(MSf(f"{name}.lam", lag_laminar, core, state, tau, omega, "t", f"tbl:{pump}.mu",
              f"{P}D", *_surface(pump, "Cs"),
              description="ΔQ_s = Q_s(Δp) − Q_s(p_sp)"))
    g.add(MSf(f"{name}.turb", lag_turbulent, core, state, tau, omega, f"{P}rho", f"{P}D",
              f"{P}dp_s", *_surface(pump, "Cst"),
              description="ΔQ_st = Q_st(Δp) − Q_st(p_sp)"))
    g.connect(f"{name}.lam", f"{pump}.core", label=f"{name}.lam")
    g.connect(f"{name}.turb", f"{pump}.core", label=f"{name}.turb")
    g.output(f"{name}.p_sp", state, "Pa", "side-plate balance pressure")
    g.output(f"{name}.dQ_s", f"f:{name}.lam", "m^3/s", "laminar slip held back by the lag")
    g.output(f"{name}.dQ_st", f"f:{name}.turb", "m^3/s", "turbulent slip held back by the lag")


def lagged_rate(t: Arr, rate: Arr, tau: float = TAU_REF) -> Arr:
    """``rate`` through a first-order lag of time constant ``tau`` [s] (exact for a rate
    held over each sample interval), starting at 0; ``t`` the sample times [s]."""
    out = np.empty_like(rate)
    acc = 0.0
    for k in range(rate.size):
        dt = float(t[k] - t[k - 1]) if k else 0.0
        a = math.exp(-dt / tau)
        acc = a * acc + (1.0 - a) * float(rate[k])
        out[k] = acc
    return out


def _regressor(s: Mapping[str, Arr]) -> Arr:
    p = np.maximum(np.abs(s["P"]), 1e5)
    return np.asarray((s["Q_s"] + 0.5 * s["Q_st"]) / p * lagged_rate(s["t"], s["dP"]) / s["Q"],
                      dtype=float)


ENTRY = EffectEntry(
    name=NAME,
    explanation="the side plates settle late after a pressure change: the slip follows the "
                "pressure as a first-order lag (flow too high while pressure rises)",
    reference="paper 000 §5 (Fig. 10, conclusions: response time of the end side plates)",
    circuit=FIELD_CIRCUIT, balance="field_flow", coefficient="tau",
    signature="(Q_s + Q_st/2)/P · L(ṗ) / Q, L a first-order lag of 0.3 s", regressor=_regressor, sign=1.0,
    plausible=(0.0, 2.0))
