"""Equation-error residuals: the rig's bond-graph constraints evaluated with measured signals.

Each balance is one junction equation of the paper-002 circuit written with measured
signals (DISCREPANCY.md §1; Samantaray, Medjaher, Ould Bouamama et al., *Simulation
Modelling Practice and Theory* 14, 2006, analytical redundancy relations), split into

* a *target* ``y`` computed from measured signals and known geometry,
* *base columns* whose coefficients are the base model's own parameters, re-fitted
  unpenalised so that a drifted parameter is not blamed on new physics,
* the *candidate columns* of the library effects that enter this balance
  (:attr:`sim.components.effects.EffectEntry.balance`).

==================  =====================================================================
balance             equation (residual = Σ candidate coefficient × regressor)
==================  =====================================================================
``piston_force``    A1·P1 − A2·P2 − F_load = Fu·tanh(ẋ/v_s) + Kf·ẋ + m·ẍ + …   [N]
                    (1-junction of the piston, paper 002 eqs. 35-38)
``chamber_flow``    Q_C − A2·ẋ = a·(P1 − P2)/μ + b·ẋ − V2(x)/β·Ṗ2 − c·Ṗ2 + …   [m³/s]
                    (0-junction of chamber 2, eqs. 34, 36, 50)
``valve_flow``      working: Q_B − Q_C − (A1 − A2)·ẋ, return: Q_B + Q_C
                    = compressibility of the sides + a·(P_P − P_T)/μ + …   [m³/s]
                    (0-junctions of port P and the chambers, eqs. 23-24, P_T = PRvt; the
                    piston leakage cancels)
``pump_flow``       ω·Vp − Q_B = P/Rlp + Cp·Ṗ + b·ω + …   [m³/s]
                    (0-junction of the pump outlet, eqs. 1-5; relief closed)
``relief_flow``     ω·Vp − Q_B − (P − Pset)⁺/Rrv = P/Rlp + Cp·Ṗ + b·ω + a·o + r·(P − Pset)⁺
                    + …   [m³/s] (the same junction with the relief valve, eq. 6, over the
                    closed samples of ``pump_flow`` and the samples where the relief
                    passes flow, o = 1: a dwell at the end stop; a, r re-fit the
                    relief's setting and slope)
``hose_pressure``   ∫(P2 − P_B) dt − I_B·ΔQ_C = R_B·∫Q_C dt + …   [Pa·s] over the last
                    20 ms (1-junction of hose B, :mod:`sim.components.hose`; needs the
                    pressure at valve port B, not on paper 002's logger; every window of
                    the record, switches and end stops included, whose trapezoid error
                    bound is small, :func:`~diagnostics.discrepancy.signals.hose_integrals`)
==================  =====================================================================

End-stop contact (x within 6 mm of either end: the stop plus the smoothing window at the
working speed) is left out of the force balance, where the stop force is unmeasured.  The
two flow balances keep the samples of a piston *held* at its stop (a dwell record), from
:data:`HELD_SETTLE` after it came within 6 mm of the stop to :data:`SETTLE` before the
phase ends (:func:`_held`): there ẋ = 0 and the chamber and valve junctions hold exactly —
meter C is the piston leak at the full working pressure, B − C the spool leak — and the
stop force does not enter them; the arrival (deceleration into the stop, the pressure
rising to the relief setting) is left out like a switch.  The force balance also leaves
out the piston at rest (|ẋ| < 5 mm/s, where friction is whatever holds it); the first
50 ms after each valve switch are left out (the derivative window and the hoses' wave
transient); the pump balance uses the samples
below 80 % of the relief setting.  The relief balance adds the samples above
:data:`RELIEF_OPEN` × the setting from :data:`OPEN_SETTLE` after the relief opened (a piston
held at its stop); it is evaluated only when at least :data:`MIN_OPEN` such samples exist
(records with a dwell at the stop, :mod:`diagnostics.discrepancy.simulate`), since
otherwise its candidate column is zero.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from diagnostics.discrepancy.signals import HOSE_WINDOW, Signals
from sim.components.effects import EFFECTS, Effect

__all__ = ["BALANCES", "Balance", "BalanceData", "balance_data", "carried", "effects_of"]

Arr = npt.NDArray[np.float64]

#: distance from either end stop left out [m] (contact plus the smoothing window)
END_MARGIN = 6e-3
#: piston speed below which the force balance is not used [m/s]
MOVING = 5e-3
#: time after each valve switch left out [s]: the Savitzky-Golay window and the
#: switching transient (hose waves) that the lumped balances do not describe
SETTLE = 0.05
#: gauge chamber pressure below which samples are left out [Pa] (0.5 bar absolute): the
#: rig model has no cavitation, and near vacuum the compliance regressors (entrained air's
#: (p_a/p_abs)^(1/n)/p_abs) grow without bound and a few samples would set the fit
VACUUM = -0.5e5
#: time left out after the switch that ends a dwell at the stop [s]: the chambers
#: decompress from the relief pressure, a switching transient ten times the usual step
DWELL_SETTLE = 0.15
#: time after a piston came within :data:`END_MARGIN` of a stop where it stays before its
#: held samples are used by the flow balances [s]: the arrival (≈ 30 ms to the contact, the
#: chamber pressures settling within ≈ 80 ms on the reference rig) and the smoothing window
HELD_SETTLE = 0.15
#: fraction of the relief setting below which the relief valve counts as closed
RELIEF_MARGIN = 0.8
#: fraction of the relief setting above which the relief valve counts as open (0.35 bar,
#: 7 σ of the pressure sensor, above the setting of paper 002's 70 bar valve)
RELIEF_OPEN = 1.005
#: time after the relief opened before its samples are used [s] (the pressure rise at the
#: arrival at the stop, and the smoothing window)
OPEN_SETTLE = 0.1
#: fewest relief-open samples for the relief balance
MIN_OPEN = 200
#: the hose balance keeps windows whose trapezoid-error bound (``hose.hf``) is below this
#: fraction of its full scale plus twice the median bound (the noise's share)
HOSE_HF_LIMIT = 0.01


@dataclass(frozen=True)
class Balance:
    """One junction equation of the circuit (module docstring)."""

    name: str
    unit: str
    channels: tuple[str, ...]
    full_scale: Callable[[dict[str, float]], float]
    build: Callable[[Signals, dict[str, float]], tuple[Arr, dict[str, Arr]]]


@dataclass
class BalanceData:
    """A balance evaluated on the data: target, base and candidate columns, kept samples."""

    balance: Balance
    y: Arr
    base: dict[str, Arr]
    candidates: dict[str, Arr]
    mask: npt.NDArray[np.bool_]
    full_scale: float
    base_signs: dict[str, float]
    #: which kept rows are a piston held at its stop (:func:`_held`); ``None``: none
    held: npt.NDArray[np.bool_] | None = None
    #: RMS that the sensors' white noise alone gives the residual once averaged over
    #: :data:`STRUCTURE_SMOOTH` samples [unit of the balance]; 0 where it is far below the
    #: practical size (every balance but the hose's, whose windowed integral of a pressure
    #: difference carries 18 Pa·s of 0.05 bar noise against a practical size of 3.2 Pa·s)
    noise_floor: float = 0.0
    #: the effects the rig carries (:func:`carried`): name → (stored coefficient [SI],
    #: its column on the kept samples), whose term ``k·x`` is moved into ``y``
    carried: dict[str, tuple[float, Arr]] = field(default_factory=dict)


def _inside(s: Signals, v: dict[str, float]) -> npt.NDArray[np.bool_]:
    if "x" not in s.values:
        return np.ones(s.t.size, dtype=bool)
    x = s.values["x"]
    return np.asarray((x > END_MARGIN) & (x < v["cylinder.stroke"] - END_MARGIN), dtype=bool)


def _piston(s: Signals, v: dict[str, float]) -> tuple[Arr, dict[str, Arr]]:
    c = s.values
    y = v["cylinder.A1"] * c["P1"] - v["cylinder.A2"] * c["P2"] - c["load"]
    base = {"cylinder.Fu": np.tanh(c["v"] / v["cylinder.v_s"]), "cylinder.Kf": c["v"],
            "cylinder.mass": c["dv"]}
    return y, base


def _chamber(s: Signals, v: dict[str, float]) -> tuple[Arr, dict[str, Arr]]:
    c = s.values
    y = c["Q_meter_C"] - v["cylinder.A2"] * c["v"]
    vol2 = v["cylinder.V02"] + v["cylinder.A2"] * (v["cylinder.stroke"] - c.get("x", 0.0 * c["v"]))
    base = {"cylinder.cc (laminar)": (c["P1"] - c["P2"]) / c["mu"], "cylinder.cc (Couette)": c["v"],
            "fluid.beta (chamber 2)": vol2 * c["dP2"], "hose_B compliance": c["dP2"]}
    return y, base


def _valve(s: Signals, v: dict[str, float]) -> tuple[Arr, dict[str, Arr]]:
    c = s.values
    work = (s.phase != "return").astype(float)
    ret = 1.0 - work
    # working: Q_B feeds chamber 1 (and hose A), Q_C leaves chamber 2;
    # return: Q_B feeds hose B and chamber 2, so Q_C (out of chamber 2) is −(inflow)
    y = work * (c["Q_meter_B"] - c["Q_meter_C"]
                - (v["cylinder.A1"] - v["cylinder.A2"]) * c["v"]) \
        + ret * (c["Q_meter_B"] + c["Q_meter_C"])
    x = c.get("x", 0.0 * c["v"])
    vol1 = v["cylinder.V01"] + v["cylinder.A1"] * x
    vol2 = v["cylinder.V02"] + v["cylinder.A2"] * (v["cylinder.stroke"] - x)
    # the spool leaks across P_P − P_T, the T port at PRvt (paper 002 eqs. 23-24)
    base = {"valve.cv (laminar)": (c["P_valve_P"] - c.get("PRvt", 0.0)) / c["mu"],
            "fluid.beta (chamber 1)": work * vol1 * c["dP1"], "hose_A compliance": work * c["dP1"],
            "fluid.beta (chamber 2)": work * vol2 * c["dP2"], "hose_B compliance": ret * c["dP2"]}
    return y, base


def _pump(s: Signals, v: dict[str, float]) -> tuple[Arr, dict[str, Arr]]:
    c = s.values
    y = c["speed"] * c["Vp"] - c["Q_meter_B"]
    base = {"pump.Rlp": c["P_pump"], "pump.Cp": c["dP_pump"], "pump.Vp": c["speed"]}
    return y, base


def _relief(s: Signals, v: dict[str, float]) -> tuple[Arr, dict[str, Arr]]:
    c = s.values
    d = np.maximum(c["P_pump"] - v["relief.Pset"], 0.0)
    opened = (c["P_pump"] > RELIEF_OPEN * v["relief.Pset"]).astype(float)
    y = c["speed"] * c["Vp"] - c["Q_meter_B"] - d / v["relief.Rrv"] \
        - v.get("relief.Gseat", 0.0) * c["P_pump"]
    base = {"pump.Rlp": c["P_pump"], "pump.Cp": c["dP_pump"], "pump.Vp": c["speed"],
            "relief.Pset": opened, "relief.Rrv": opened * d}
    return y, base


def _hose(s: Signals, v: dict[str, float]) -> tuple[Arr, dict[str, Arr]]:
    c = s.values
    y = c["hose.int_dp"] - v["hose_B.I"] * c["hose.dq"]
    # R = 128·μ·L/(π·d⁴): the column μ·∫Q re-fits 128·L/(π·d⁴) (bore, length, viscosity)
    return y, {"hose_B.R": c["mu"] * c["hose.int_q"]}


def _held(s: Signals, v: dict[str, float]) -> npt.NDArray[np.bool_]:
    """Samples of a piston held at a stop (module docstring): within :data:`END_MARGIN` of
    either end in the run of such samples that lasts to the end of its record's phase, at
    least :data:`HELD_SETTLE` after that run began and :data:`SETTLE` before the phase ends.
    A stroke switched by its stop has a run of a few milliseconds: nothing is kept."""
    out = np.zeros(s.t.size, dtype=bool)
    if "x" not in s.values:
        return out
    near = ~_inside(s, v)
    for rec in np.unique(s.record):
        for ph in np.unique(s.phase):
            m = np.flatnonzero((s.record == rec) & (s.phase == ph))
            if m.size == 0 or not near[m[-1]]:
                continue
            away = np.flatnonzero(~near[m])
            run = m[away[-1] + 1:] if away.size else m
            t = s.t[run]
            out[run] = (t - t[0] >= HELD_SETTLE) & (t[-1] - t >= SETTLE)
    return out


def _after_dwell(s: Signals, v: dict[str, float]) -> npt.NDArray[np.bool_]:
    """Return-phase samples within :data:`DWELL_SETTLE` of the switch of a record whose
    working phase ended with the relief open (a dwell at the stop)."""
    out = np.zeros(s.t.size, dtype=bool)
    if "P_pump" not in s.values or "relief.Pset" not in v:
        return out
    since = s.since_phase_start()
    for rec in np.unique(s.record):
        work = np.flatnonzero((s.record == rec) & (s.phase == "working"))
        if work.size and s.values["P_pump"][work[-1]] > RELIEF_OPEN * v["relief.Pset"]:
            out |= (s.record == rec) & (s.phase == "return") & (since < DWELL_SETTLE)
    return out


def _relief_open(s: Signals, v: dict[str, float]) -> npt.NDArray[np.bool_]:
    """Working-phase samples where the relief passes flow, from :data:`OPEN_SETTLE` after
    it opened to :data:`SETTLE` before the phase ends (the pressure spike of a valve switch
    in the return phase and the smoothing window's edge at the switch are left out)."""
    opened = (s.values["P_pump"] > RELIEF_OPEN * v["relief.Pset"]) & (s.phase != "return")
    keep = np.zeros(s.t.size, dtype=bool)
    for rec in np.unique(s.record):
        for ph in np.unique(s.phase):
            m = np.flatnonzero((s.record == rec) & (s.phase == ph))
            o = m[opened[m]]
            if o.size:
                keep[o] = (s.t[o] - s.t[o[0]] >= OPEN_SETTLE) & (s.t[m].max() - s.t[o] >= SETTLE)
    return keep


#: base columns whose re-fitted coefficient must stay ≥ 0 (friction, conductances): a
#: subset that drives one negative trades off against the base model.  ``pump.Vp`` is not
#: here: the pump balance's target already subtracts the stated ω·Vp, so its column's
#: coefficient is a *correction* of the displacement, of either sign (a sign check on it
#: rejected every true pump-slip explanation whose re-fit moved Vp down by 0.002 %)
BASE_SIGNS: dict[str, float] = {
    "cylinder.Fu": 1.0, "cylinder.Kf": 1.0, "cylinder.cc (laminar)": 1.0,
    "valve.cv (laminar)": 1.0, "pump.Rlp": 1.0,
}
#: the unit of each signed base column's coefficient (balance unit / column unit): friction
#: force, viscous friction, the laminar gaps' k of Q = k·Δp/μ, the pump's leakage conductance
BASE_UNITS: dict[str, str] = {
    "cylinder.Fu": "N", "cylinder.Kf": "N·s/m", "cylinder.cc (laminar)": "m³",
    "valve.cv (laminar)": "m³", "pump.Rlp": "m³/(s·Pa)",
}

BALANCES: tuple[Balance, ...] = (
    Balance("piston_force", "N", ("P1", "P2", "v"),
            lambda v: v["cylinder.A1"] * v["relief.Pset"], _piston),
    Balance("chamber_flow", "m^3/s", ("P1", "P2", "v", "Q_meter_C"),
            lambda v: v["pump.speed"] * v["pump.Vp"], _chamber),
    Balance("valve_flow", "m^3/s", ("P1", "P2", "v", "Q_meter_B", "Q_meter_C", "P_valve_P"),
            lambda v: v["pump.speed"] * v["pump.Vp"], _valve),
    Balance("pump_flow", "m^3/s", ("Q_meter_B", "P_pump"),
            lambda v: v["pump.speed"] * v["pump.Vp"], _pump),
    Balance("relief_flow", "m^3/s", ("Q_meter_B", "P_pump"),
            lambda v: v["pump.speed"] * v["pump.Vp"], _relief),
    # full scale: hose B's inertial pressure impulse for a reversal of the pump flow
    Balance("hose_pressure", "Pa*s", ("P2", "P_valve_B", "Q_meter_C", "hose.int_dp"),
            lambda v: 2.0 * v["hose_B.I"] * v["pump.speed"] * v["pump.Vp"], _hose),
)


def effects_of(balance: str) -> list[Effect]:
    """The library effects that enter ``balance``."""
    return [e for e in EFFECTS.values() if e.entry.balance == balance]


def carried(values: Mapping[str, float], balance: str) -> dict[str, float]:
    """The effects of ``balance`` the rig already carries, with their coefficients [SI]
    (the non-zero ones; ``values``: :meth:`sim.rigs.assembly.Rig.values`).

    They are part of the model the data are checked against: their term ``k·x`` moves to
    the target and they are no candidates.  A rig that ``hydrodiag discover`` augmented
    was once checked as if it had none: the same data then named the stored effect again,
    and a new one would have been fitted beside a residual that still held the old one
    (s41 real-data pass, on a pump bench table).
    """
    out: dict[str, float] = {}
    for e in effects_of(balance):
        k = values.get(f"{e.name}.{e.entry.coefficient}", 0.0)
        if k != 0.0:
            out[e.name] = float(k)
    return out


def balance_data(s: Signals, values: dict[str, float]) -> list[BalanceData]:
    """Every balance the measured channels allow, evaluated on the kept samples.

    ``values`` are the rig's parameter values (:meth:`sim.rigs.assembly.Rig.values`).
    """
    out: list[BalanceData] = []
    # samples away from the end stops, settled after a switch (and after a dwell's switch),
    # and resting on measured samples (not across a logger's gap: signals._measured)
    measured = s.values["measured"] > 0.5 if "measured" in s.values else np.ones(s.t.size, bool)
    settled = (_inside(s, values) & (s.since_phase_start() >= SETTLE) & ~_after_dwell(s, values)
               & measured)
    # the flow balances also keep a piston held at its stop (a dwell)
    held = _held(s, values) & measured
    for b in BALANCES:
        if not s.has(*b.channels):
            continue
        if b.name == "relief_flow" and "relief.Rrv" not in values:
            continue
        if b.name == "hose_pressure":
            if "hose_B.I" not in values:
                continue
            ok = s.values["hose.ok"] > 0.5
            hf = s.values["hose.hf"]
            limit = HOSE_HF_LIMIT * b.full_scale(values) + 2.0 * float(np.median(hf[ok]))
            mask = ok & (hf <= limit)
        else:
            mask = settled | held if b.name in ("chamber_flow", "valve_flow") else settled.copy()
            for ch in ("P1", "P2"):
                if ch in b.channels:
                    mask &= s.values[ch] > VACUUM
        if b.name in ("pump_flow", "relief_flow"):
            mask &= s.values["P_pump"] < RELIEF_MARGIN * values["relief.Pset"]
        if b.name == "relief_flow":
            opened = _relief_open(s, values)
            if opened.sum() < MIN_OPEN:
                continue
            mask |= opened & measured
        if b.name == "piston_force":
            # at rest the friction is whatever holds the piston (stiction): unmeasured
            mask &= np.abs(s.values["v"]) > MOVING
        sub = s.subset(mask)
        y, base = b.build(sub, values)
        stored = carried(values, b.name)
        columns: dict[str, tuple[float, Arr]] = {}
        for name, k in stored.items():
            x = np.asarray(EFFECTS[name].entry.regressor(sub.values), dtype=float)
            y = y - k * x
            columns[name] = (k, x)
        cands = {e.name: e.entry.regressor(sub.values) for e in effects_of(b.name)
                 if e.name not in stored}
        out.append(BalanceData(b, y, base, cands, mask, b.full_scale(values),
                               {k: v for k, v in BASE_SIGNS.items() if k in base},
                               held[mask] if held[mask].any() else None,
                               _hose_noise(sub) if b.name == "hose_pressure" else 0.0,
                               columns))
    return out


#: samples over which a residual is averaged before its size is judged (50 ms at 1 kHz,
#: :func:`diagnostics.discrepancy.verdict.structured`)
STRUCTURE_SMOOTH = 51


def _hose_noise(s: Signals) -> float:
    """RMS of the hose balance's residual from the pressure sensors' white noise alone,
    averaged over :data:`STRUCTURE_SMOOTH` samples [Pa·s]: the windowed integral is
    h·Σ over n samples of the noise (σ_dp each), and the average of
    :data:`STRUCTURE_SMOOTH` overlapping windows weighs each sample by their overlap, so
    the RMS is σ_dp·h·‖box(n) ∗ box(51)‖/51 (the largest σ_dp of the records)."""
    if s.t.size == 0:
        return 0.0
    h = 1.0 / s.rate
    n = max(round(HOSE_WINDOW / h), 1)
    weights = np.convolve(np.ones(n), np.ones(STRUCTURE_SMOOTH)) / STRUCTURE_SMOOTH
    return float(np.max(s.values["hose.sigma_dp"]) * h * np.sqrt(np.sum(weights ** 2)))
