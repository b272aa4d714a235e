"""A virtual ISO 4409 test bench: steady test points from any pump model, with instrument noise.

**A test and demonstration tool.**  Its output is simulated; :class:`BenchData` from here
carries ``simulated=True`` and says so in its CSV header.  Never present it as measured.

What the virtual bench does at each set point (Δp, ω) and oil temperature θ:

1. The rig holds the set point exactly (true Δp, ω, θ = set values); the pump model gives
   the true flow and torque there.
2. Each instrument reads its quantity with an independent Gaussian error, relative to the
   reading (temperature: absolute).  An accuracy "±a %" is read as an expanded uncertainty
   with coverage factor k = 2, i.e. σ = a/2 (the class limits of ISO 4409 are such bounds).

Default accuracies and where they come from:

=================  ========  ==============================================================
instrument         ±         source
=================  ========  ==============================================================
flowmeter          1 %       paper 000 §3.2.1 (Parker Serviceman Plus flowmeter)
pressure           0.25 %    paper 000 §3.2.1 (pressure transducer)
torque             0.5 %     ISO 4409 class A limit, as quoted in paper 001 §2.5
speed              0.1 %     chosen: an encoder on the drive shaft (class A allows 0.5 %)
temperature        1.0 K     ISO 4409 class A limit, as quoted in paper 001 §2.5
=================  ========  ==============================================================

The flowmeter error can instead be a fraction of a full scale (``flow_full_scale``): paper
001 §2.5 notes that sensor error is often stated that way, which makes it constant in m³/s
rather than proportional to the flow.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from diagnostics.pump.data import BenchData
from sim.components.gear_pump import PumpModel
from sim.errors import InputError

__all__ = ["InstrumentNoise", "default_levels", "iso4409_grid", "run_virtual_bench"]

FloatArray = npt.NDArray[np.float64]

_RPM = 2.0 * math.pi / 60.0


@dataclass(frozen=True, slots=True)
class InstrumentNoise:
    """Instrument accuracies of a (virtual) test bench.

    Parameters
    ----------
    flow, pressure, torque, speed
        Accuracy as a fraction of the reading [-] (±, expanded, k = ``coverage``).
    temperature
        Accuracy of the temperature sensor [K] (±, expanded).
    coverage
        Coverage factor k of the stated accuracies [-]; σ = accuracy / k.
    flow_full_scale
        ``None``: the flow error is a fraction of the reading; a flow [m³/s]: the flow error
        is ``flow`` × this full scale, the same at every reading.
    """

    flow: float = 0.01
    pressure: float = 0.0025
    torque: float = 0.005
    speed: float = 0.001
    temperature: float = 1.0
    coverage: float = 2.0
    flow_full_scale: float | None = None

    def __post_init__(self) -> None:
        for name in ("flow", "pressure", "torque", "speed", "temperature"):
            if not getattr(self, name) >= 0:
                raise InputError("accuracy must be ≥ 0", field=name)
        if not self.coverage > 0:
            raise InputError("coverage factor must be > 0", field="coverage")
        if self.flow_full_scale is not None and not self.flow_full_scale > 0:
            raise InputError("full scale must be > 0", field="flow_full_scale")

    def sigma(self, name: str) -> float:
        """Standard uncertainty of instrument ``name`` (relative [-], temperature [K])."""
        return float(getattr(self, name)) / self.coverage

    def flow_sigma(self, q: npt.ArrayLike) -> FloatArray:
        """Standard uncertainty of flow readings ``q`` [m³/s]."""
        qa = np.abs(np.asarray(q, dtype=np.float64))
        if self.flow_full_scale is None:
            return self.sigma("flow") * qa
        return np.full_like(qa, self.sigma("flow") * self.flow_full_scale)

    @classmethod
    def none(cls) -> InstrumentNoise:
        """Perfect instruments (for exactness tests)."""
        return cls(flow=0.0, pressure=0.0, torque=0.0, speed=0.0, temperature=0.0)


def iso4409_grid(pressures: npt.ArrayLike, speeds: npt.ArrayLike) -> tuple[FloatArray,
                                                                           FloatArray]:
    """Full factorial (orthogonal) grid of set points.

    Parameters
    ----------
    pressures
        Pressure-rise levels [Pa].
    speeds
        Speed levels [rad/s].

    Returns
    -------
    tuple of ndarray
        ``(dp, omega)`` of every combination [Pa], [rad/s], pressure varying fastest.
    """
    p = np.asarray(pressures, dtype=np.float64)
    w = np.asarray(speeds, dtype=np.float64)
    if p.size == 0 or w.size == 0:
        raise InputError("need at least one level of each factor", field="pressures")
    pp, ww = np.meshgrid(p, w)
    return pp.ravel(), ww.ravel()


def default_levels() -> tuple[FloatArray, FloatArray]:
    """Levels of the demonstration ISO 4409 grid: 8 pressures 20..250 bar [Pa] and 7 speeds
    600..2400 rpm [rad/s] (the domain of the stand-in map of paper 000's pump)."""
    return (np.array([20, 50, 80, 110, 140, 170, 210, 250], dtype=np.float64) * 1e5,
            np.array([600, 900, 1200, 1500, 1800, 2100, 2400], dtype=np.float64) * _RPM)


def run_virtual_bench(
    model: PumpModel,
    dp: npt.ArrayLike,
    omega: npt.ArrayLike,
    temperatures: Sequence[float] = (22.0, 60.0),
    *,
    noise: InstrumentNoise | None = None,
    replicates: int = 1,
    p_in: float = 0.0,
    seed: int | np.random.Generator = 0,
    with_torque: bool = True,
    label: str = "",
) -> BenchData:
    """Run the set points on a virtual ISO 4409 bench (SIMULATED data).

    Each set point is run at every temperature (temperature blocks, as in paper 000's 22 °C
    and 60 °C tests), ``replicates`` times.

    Parameters
    ----------
    model
        Any pump model with ``flow`` and ``torque`` (e.g. :class:`sim.components.gear_pump.
        GearPump`).
    dp, omega
        Set points: pressure rise [Pa] and speed [rad/s] (same length).
    temperatures
        Oil temperature blocks [°C].
    noise
        Instrument accuracies (default :class:`InstrumentNoise`).
    replicates
        Number of repeats of the whole plan [-], ≥ 1.
    p_in
        Inlet (gauge) pressure held by the rig [Pa].
    seed
        Seed or generator of the instrument noise.
    with_torque
        Whether a torque transducer is fitted.
    label
        Free text added to the provenance.

    Returns
    -------
    BenchData
        Rows ordered by replicate, temperature, set point; ``simulated=True``.
    """
    dp_s = np.asarray(dp, dtype=np.float64).ravel()
    w_s = np.asarray(omega, dtype=np.float64).ravel()
    if dp_s.size != w_s.size or dp_s.size == 0:
        raise InputError("dp and omega must be non-empty and of equal length", field="omega")
    if replicates < 1:
        raise InputError("at least one replicate", field="replicates")
    if len(temperatures) == 0:
        raise InputError("at least one temperature", field="temperatures")
    nz = noise if noise is not None else InstrumentNoise()
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    temps = np.asarray(temperatures, dtype=np.float64)
    n_pts = dp_s.size
    th = np.tile(np.repeat(temps, n_pts), replicates)
    dpt = np.tile(dp_s, temps.size * replicates)
    wt = np.tile(w_s, temps.size * replicates)
    rep = np.repeat(np.arange(replicates, dtype=np.int64), temps.size * n_pts)
    q_true = np.asarray(model.flow(dpt, wt, th), dtype=np.float64)
    size = dpt.size

    def rel(x: FloatArray, name: str) -> FloatArray:
        return x * (1.0 + nz.sigma(name) * rng.standard_normal(size))

    p_in_true = np.full(size, p_in)
    p_in_m = rel(p_in_true, "pressure")
    p_out_m = rel(p_in_true + dpt, "pressure")
    w_m = rel(wt, "speed")
    th_m = th + nz.sigma("temperature") * rng.standard_normal(size)
    q_m = q_true + nz.flow_sigma(q_true) * rng.standard_normal(size)
    torque_m = None
    if with_torque:
        torque_m = rel(np.asarray(model.torque(dpt, wt, th), dtype=np.float64), "torque")
    note = (f"virtual ISO 4409 bench: {n_pts} set points x {temps.size} temperatures x "
            f"{replicates} replicates; accuracies flow {nz.flow:g}"
            f"{'' if nz.flow_full_scale is None else f' of {nz.flow_full_scale:g} m^3/s'}, "
            f"pressure {nz.pressure:g}, "
            f"torque {nz.torque:g}, speed {nz.speed:g} (fraction of reading, k={nz.coverage:g}),"
            f" temperature {nz.temperature:g} K")
    if label:
        note += f"; {label}"
    return BenchData(p_in=p_in_m, p_out=p_out_m, omega=w_m, theta=th_m, q=q_m,
                     torque=torque_m, replicate=rep, simulated=True, provenance=note)
