"""Loss models of a variable-displacement piston pump from a single-temperature efficiency map.

Paper 000's gear-pump model (eq. 6) has a slip ``Cs·D·Δp/μ`` without a speed term; the
leakage of an axial-piston pump (piston/bore, slipper and valve-plate gaps, and the oil
compressed in the cylinders) grows with speed as well.  At one (unrecorded) temperature μ is
a constant, so the losses are fitted as linear combinations of physical terms, each with the
sign physics gives, per displacement setting ``D`` [m³/rad]:

flow loss  ``q_L = D·ω − q`` [m³/s]::

    q_L = a₁·Δp          laminar leakage (paper 000 eq. 6, Cs·D/μ at fixed μ)     a₁ ≥ 0
        + a₂·Δp·ω        compression of the cylinder dead volume, D·ω·Δp/β_ef      a₂ ≥ 0
                         (paper 000 eq. 8; paper 001 Table 1, Zarotti and Nevegna)
        + a₃·ω           displacement error of the set swash angle (either sign)
        + a₄             offset (either sign)
        + a₅·Δp²         leakage through a gap that opens or closes with pressure
                         (paper 001 Table 1, Manring 2016; either sign)
        + a₆·Δp²·ω       leakage growing with speed (paper 001 Table 1, Dorey 1988
                         B-part; either sign)
        + a₇·ω²          incomplete filling of the cylinders at speed              a₇ ≥ 0

torque loss ``T_L = T − D·Δp`` [N·m]::

    T_L = b₁·Δp          Coulomb friction ∝ load (paper 000 eq. 18, Cf)             b₁ ≥ 0
        + b₂·ω           viscous friction (eq. 17, Cv)                              b₂ ≥ 0
        + b₃·ω²          churning (paper 001 Table 1, Ivantysyn)                    b₃ ≥ 0
        + b₄             constant friction (paper 000 eq. 10, Te)                   b₄ ≥ 0
        + b₅·Δp²         load-dependent friction (paper 001 Table 1, Jeong 2007;
                         either sign)
        + b₆·Δp·ω        Coulomb friction that changes with speed (mixed to fluid
                         film, Stribeck; either sign)
        + b₇·√ω          friction of a full fluid film under a constant load: the     b₇ ≥ 0
                         cylinder block held on the valve plate by its spring.  A
                         hydrodynamic film under a load W settles at h ∝ √(μ·U/W), so
                         its friction μ·U·A/h ∝ √(μ·U·W): ∝ √ω at constant W and μ
                         (slider-bearing theory, e.g. Hamrock, *Fundamentals of Fluid
                         Film Lubrication*, ch. 8; not a seed paper)

The terms beyond paper 000's (a₅-a₇, b₅-b₇) are what the V32HL56 map showed the
constant-coefficient model misses: its flow loss at 4,500 rpm is about 3× that at 1,000 rpm at
the same Δp, and grows faster than linearly in Δp at high speed (``make real-data``).

Where the map has a case-drain flow, it *is* the measured leakage; :func:`fit_losses` can
fit the flow loss to it (``target="drain"``) and predicts ``q = D·ω − q_L`` either way.

Every subset of the terms is fitted by least squares; subsets with a coefficient of the
wrong sign are refused; the smallest AIC among the rest is chosen (paper 001 §3: AIC).
:func:`held_out_speed` leaves one speed level out at a time and reports the error of the
held-out prediction as S [% of the setting's largest flow or torque] and R², next to a plain
quadratic polynomial in (Δp, n) fitted on the same split.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import numpy.typing as npt
import pandas as pd

from diagnostics.pump.levels import cluster_levels
from sim.errors import InputError
from sim.units import to_si

__all__ = ["FLOW_LOSS_TERMS", "TORQUE_LOSS_TERMS", "HeldOut", "LossFit", "LossTerm",
           "PistonMap", "bench_frame", "fit_losses", "held_out_speed", "read_efficiency_map"]

Arr = npt.NDArray[np.float64]


@dataclass(frozen=True)
class PistonMap:
    """Steady points of an efficiency map in SI units.

    Attributes
    ----------
    dp
        Pressure rise [Pa].
    omega
        Shaft speed [rad/s].
    q
        Delivered flow [m³/s].
    torque
        Shaft torque [N·m].
    D
        Set displacement of each point [m³/rad].
    q_drain
        Case-drain flow [m³/s], or None.
    """

    dp: Arr
    omega: Arr
    q: Arr
    torque: Arr
    D: Arr
    q_drain: Arr | None = None

    def __len__(self) -> int:
        return int(self.dp.size)

    def subset(self, mask: npt.ArrayLike) -> PistonMap:
        """The points selected by ``mask``."""
        m = np.asarray(mask)
        return PistonMap(self.dp[m], self.omega[m], self.q[m], self.torque[m], self.D[m],
                         None if self.q_drain is None else self.q_drain[m])

    def settings(self) -> list[float]:
        """Displacement settings [m³/rad], smallest first."""
        _, lev = cluster_levels(self.D, field="Displacement")
        return [float(v) for v in lev]


#: the quantity (canonical SI unit, :data:`sim.units.UNITS`) of each column of a map
_MAP_UNITS = {"Deltap": "Pa", "Speed": "rad/s", "QOut": "m^3/s", "QDr": "m^3/s",
              "Torque": "N*m", "Displacement": "m^3/rad"}


def read_efficiency_map(path: str | Path) -> PistonMap:
    """Read an efficiency map in the V32HL56 layout (``../shared/data/real/pump-efficiency-V32HL56``).

    Columns used: ``Speed`` [rpm], ``Torque`` [N·m], ``Deltap`` [MPa], ``QOut`` [l/min],
    ``QDr`` [l/min] (optional), ``Displacement`` [cm³/rev].  The units are those the
    source's ``SOURCE.md`` infers from the file's own identities (PowerIn, PowerOut, Etav);
    a header that states its unit (``Deltap [bar]``) is read in that unit.

    Raises
    ------
    InputError
        Unreadable file, a missing column, a non-numeric or non-finite value, or a
        non-positive speed, flow or displacement (the error names the column).
    """
    try:
        frame = pd.read_csv(path)
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read {path}: {exc}", field="file") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    # a header may state its unit, "Deltap [MPa]" or "Deltap [bar]" (the help shows the
    # columns so, and a map with those headers was refused: a pump maker's pass)
    stated: dict[str, str] = {}
    for c in list(frame.columns):
        if (m := re.fullmatch(r"(\w+)\s*\[(.+)\]", c)) is not None:
            stated[m.group(1)] = m.group(2).strip()
            frame = frame.rename(columns={c: m.group(1)})

    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            head = [fh.readline() for _ in range(20)]
    except OSError:
        head = []
    bench = any("p_out [" in ln and "q [" in ln for ln in head)

    def col(name: str, scale: float, positive: bool = True) -> Arr:
        if name in stated:  # the header's unit instead of the layout's
            canonical = _MAP_UNITS[name]
            scale = to_si(1.0, stated[name], canonical, field=name)
        if name not in frame.columns:
            # the reverse of the bench reader's hint (a user pass gave a bench CSV here)
            raise InputError("column missing" + (
                "; this is a pump-bench CSV (p_out, q with units): 'hydrodiag calibrate "
                "pump FILE' reads it" if bench else ""), field=name)
        try:
            v = pd.to_numeric(frame[name], errors="raise").to_numpy(dtype=float)
        except (ValueError, TypeError):
            raise InputError("a value is not a number", field=name) from None
        if not np.all(np.isfinite(v)):
            raise InputError("NaN or infinite value", field=name)
        if positive and np.any(v <= 0):
            raise InputError("values must be positive", field=name)
        return v * scale

    rpm = 2.0 * math.pi / 60.0
    lpm = 1e-3 / 60.0
    return PistonMap(dp=col("Deltap", 1e6), omega=col("Speed", rpm), q=col("QOut", lpm),
                     torque=col("Torque", 1.0), D=col("Displacement", 1e-6 / (2.0 * math.pi)),
                     q_drain=col("QDr", lpm, positive=False) if "QDr" in frame.columns
                     else None)


@dataclass(frozen=True)
class LossTerm:
    """One term of a loss model: name, its column from (Δp [Pa], ω [rad/s]), and its sign.

    ``sign`` is +1 (coefficient must be ≥ 0), or 0 (either sign).
    """

    name: str
    column: Callable[[Arr, Arr], Arr]
    sign: int


FLOW_LOSS_TERMS: tuple[LossTerm, ...] = (
    LossTerm("dp", lambda p, w: p, +1),
    LossTerm("dp*omega", lambda p, w: p * w, +1),
    LossTerm("omega", lambda p, w: w, 0),
    LossTerm("1", lambda p, w: np.ones_like(p), 0),
    LossTerm("dp^2", lambda p, w: p * p, 0),
    LossTerm("dp^2*omega", lambda p, w: p * p * w, 0),
    LossTerm("omega^2", lambda p, w: w * w, +1),
)
TORQUE_LOSS_TERMS: tuple[LossTerm, ...] = (
    LossTerm("dp", lambda p, w: p, +1),
    LossTerm("omega", lambda p, w: w, +1),
    LossTerm("omega^2", lambda p, w: w * w, +1),
    LossTerm("1", lambda p, w: np.ones_like(p), +1),
    LossTerm("dp^2", lambda p, w: p * p, 0),
    LossTerm("dp*omega", lambda p, w: p * w, 0),
    LossTerm("sqrt(omega)", lambda p, w: np.sqrt(w), +1),
)


@dataclass(frozen=True)
class LossFit:
    """A chosen loss model: terms, coefficients [SI], AIC, and the subsets refused for sign."""

    kind: str
    terms: tuple[str, ...]
    coef: Arr
    aic: float
    refused_for_sign: int
    _columns: tuple[LossTerm, ...]

    def loss(self, dp: Arr, omega: Arr) -> Arr:
        """Predicted loss [m³/s or N·m] at Δp [Pa], ω [rad/s]."""
        x = np.column_stack([t.column(dp, omega) for t in self._columns])
        return np.asarray(x @ self.coef, dtype=np.float64)


def _best_subset(kind: str, terms: tuple[LossTerm, ...], dp: Arr, w: Arr, y: Arr) -> LossFit:
    n = y.size
    best: LossFit | None = None
    refused = 0
    for k in range(1, len(terms) + 1):
        for sub in itertools.combinations(terms, k):
            x = np.column_stack([t.column(dp, w) for t in sub])
            scale = np.max(np.abs(x), axis=0)
            scale[scale == 0] = 1.0
            c, *_ = np.linalg.lstsq(x / scale, y, rcond=None)
            c = c / scale
            if any(t.sign > 0 and v < 0 for t, v in zip(sub, c, strict=True)):
                refused += 1
                continue
            rss = float(np.sum((y - x @ c) ** 2))
            aic = n * math.log(max(rss, 1e-300) / n) + 2 * (k + 1)
            if best is None or aic < best.aic:
                best = LossFit(kind, tuple(t.name for t in sub), c, aic, 0, sub)
    if best is None:
        raise InputError(f"no {kind} loss model with physical signs fits these data",
                         field="data")
    return LossFit(best.kind, best.terms, best.coef, best.aic, refused, best._columns)


def fit_losses(data: PistonMap, D: float, *, target: Literal["deficit", "drain"] = "deficit"
               ) -> tuple[LossFit, LossFit]:
    """Flow- and torque-loss models of one displacement setting ``D`` [m³/rad].

    Raises
    ------
    InputError
        Fewer than 2 speeds or 2 pressure levels (degenerate data, ``field="Speed"`` /
        ``"Deltap"``), or ``target="drain"`` without a drain column.
    """
    _, w_lev = cluster_levels(data.omega, field="Speed")
    _, p_lev = cluster_levels(data.dp, field="Deltap")
    if w_lev.size < 2:
        raise InputError(f"{w_lev.size} speed level(s): speed-dependent losses need ≥ 2",
                         field="Speed")
    if p_lev.size < 2:
        raise InputError(f"{p_lev.size} pressure level(s): the models need ≥ 2",
                         field="Deltap")
    if target == "drain":
        if data.q_drain is None:
            raise InputError("the map has no case-drain flow", field="QDr")
        y_q = data.q_drain
    else:
        y_q = D * data.omega - data.q
    flow = _best_subset("flow", FLOW_LOSS_TERMS, data.dp, data.omega, y_q)
    torque = _best_subset("torque", TORQUE_LOSS_TERMS, data.dp, data.omega,
                          data.torque - D * data.dp)
    return flow, torque


def _quadratic(dp: Arr, w: Arr) -> Arr:
    return np.column_stack([np.ones_like(dp), dp, w, dp * dp, dp * w, w * w])


@dataclass(frozen=True)
class HeldOut:
    """Held-out-speed errors of one setting: S [% of max] and R² [-], model and quadratic.

    ``flow_pred`` [m³/s] and ``torque_pred`` [N·m] are the held-out predictions at every
    point (each from the fit without its speed); ``flow_full`` [m³/s] and ``torque_full``
    [N·m] are the setting's largest measured flow and torque, the scales of S; ``flow`` and
    ``torque`` are the models fitted on all the setting's points; ``flow_pred_quadratic``
    [m³/s] and ``torque_pred_quadratic`` [N·m] the quadratic's held-out predictions.
    """

    D: float
    speeds: int
    flow_S: float
    flow_R2: float
    flow_S_quadratic: float
    flow_R2_quadratic: float
    torque_S: float
    torque_R2: float
    torque_S_quadratic: float
    torque_R2_quadratic: float
    flow_terms: tuple[str, ...]
    torque_terms: tuple[str, ...]
    flow_pred: Arr
    torque_pred: Arr
    flow_full: float
    torque_full: float
    flow: LossFit
    torque: LossFit
    flow_pred_quadratic: Arr
    torque_pred_quadratic: Arr
    fold_flow_terms: tuple[tuple[str, ...], ...] = ()
    fold_torque_terms: tuple[tuple[str, ...], ...] = ()


def _s_r2(y: Arr, pred: Arr, full: float) -> tuple[float, float]:
    res = y - pred
    s = 100.0 * math.sqrt(float(np.mean(res ** 2))) / full
    r2 = 1.0 - float(np.sum(res ** 2)) / float(np.sum((y - y.mean()) ** 2))
    return s, r2


def held_out_speed(data: PistonMap, D: float, *,
                   target: Literal["deficit", "drain"] = "deficit") -> HeldOut:
    """Leave one speed level out at a time (module docstring) for the setting ``D`` [m³/rad]."""
    w_idx, w_lev = cluster_levels(data.omega, field="Speed")
    if w_lev.size < 3:
        raise InputError(f"{w_lev.size} speed levels: leaving one out needs ≥ 3",
                         field="Speed")
    pq, pt, qq, qt = (np.zeros(len(data)) for _ in range(4))
    f_terms: list[tuple[str, ...]] = []
    t_terms: list[tuple[str, ...]] = []
    for k in range(w_lev.size):
        test = w_idx == k
        train = data.subset(~test)
        flow, torque = fit_losses(train, D, target=target)
        f_terms.append(flow.terms)
        t_terms.append(torque.terms)
        dp, w = data.dp[test], data.omega[test]
        pq[test] = D * w - flow.loss(dp, w)
        pt[test] = D * dp + torque.loss(dp, w)
        xt = _quadratic(train.dp, train.omega)
        scale = np.max(np.abs(xt), axis=0)
        cq = np.linalg.lstsq(xt / scale, train.q, rcond=None)[0] / scale
        ct = np.linalg.lstsq(xt / scale, train.torque, rcond=None)[0] / scale
        qq[test] = _quadratic(dp, w) @ cq
        qt[test] = _quadratic(dp, w) @ ct
    q_full, t_full = float(np.max(data.q)), float(np.max(data.torque))
    fs, fr = _s_r2(data.q, pq, q_full)
    fsq, frq = _s_r2(data.q, qq, q_full)
    ts, tr = _s_r2(data.torque, pt, t_full)
    tsq, trq = _s_r2(data.torque, qt, t_full)
    flow, torque = fit_losses(data, D, target=target)
    return HeldOut(D, int(w_lev.size), fs, fr, fsq, frq, ts, tr, tsq, trq, flow.terms,
                   torque.terms, pq, pt, q_full, t_full, flow, torque, qq, qt,
                   tuple(f_terms), tuple(t_terms))


def bench_frame(data: PistonMap, theta: float) -> pd.DataFrame:
    """The map as a bench CSV table (:mod:`diagnostics.pump.csvio`) at an assumed θ [°C].

    The map's Δp becomes ``p_out`` over ``p_in = 0`` (only Δp enters the models); ``theta``
    is the oil temperature *assumed* for the whole map, since the file records none.
    """
    return pd.DataFrame({"p_in [Pa]": np.zeros(len(data)), "p_out [Pa]": data.dp,
                         "n [rad/s]": data.omega, "theta [degC]": np.full(len(data), theta),
                         "q [m^3/s]": data.q, "T [N*m]": data.torque})
