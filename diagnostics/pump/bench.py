"""A virtual ISO 4409 test bench: steady test points from any pump model, with instrument noise.

**A test and demonstration tool.**  Its output is simulated; :class:`BenchData` from here
carries ``simulated=True`` and says so in its CSV header.  Never present it as measured.

What the virtual bench does at each set point (Δp, ω) and oil temperature θ:

1. The rig holds the set point exactly (true Δp, ω, θ = set values); the pump model gives
   the true flow and torque there.
2. Each instrument reads its quantity with an independent error, relative to the reading
   (temperature: absolute).  An accuracy "±a" is a bound (maximum permissible error) and is
   read as the project reads every instrument class (:mod:`diagnostics.quantity`, GUM
   §4.3.7): a rectangular distribution of half-width a, standard uncertainty u = a/√3.  The
   virtual bench draws each error uniformly within ±a, so its readings never leave the
   stated bound and their scatter is the u that the parameterisation propagates
   (:mod:`diagnostics.pump.coefficients`).

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
from diagnostics.quantity import InstrumentClass, Quantity
from sim.components.gear_pump import PumpModel
from sim.errors import InputError

__all__ = ["InstrumentNoise", "default_levels", "iso4409_grid", "run_virtual_bench"]

FloatArray = npt.NDArray[np.float64]

_RPM = 2.0 * math.pi / 60.0

#: Standard uncertainty of a unit bound: 1/√3 (rectangular, :meth:`Quantity.from_bound`).
_U_PER_BOUND = Quantity.from_bound(0.0, 1.0).u

_NAMES = {"flow": "flowmeter", "pressure": "pressure transducer", "torque": "torque transducer",
          "speed": "speed sensor", "temperature": "thermometer"}


@dataclass(frozen=True, slots=True)
class InstrumentNoise:
    """Instrument accuracies of a (virtual) test bench, stated as bounds.

    Parameters
    ----------
    flow, pressure, torque, speed
        Bound ±a as a fraction of the reading [-].
    temperature
        Bound ±a of the temperature sensor [K].
    flow_full_scale
        ``None``: the flow bound is a fraction of the reading; a flow [m³/s]: the flow bound
        is ``flow`` × this full scale, the same at every reading.

    Notes
    -----
    Each bound is read as a rectangular distribution (u = a/√3, GUM §4.3.7), exactly as
    :class:`diagnostics.quantity.InstrumentClass` reads the field instruments;
    :meth:`instrument` returns that class.
    """

    flow: float = 0.01
    pressure: float = 0.0025
    torque: float = 0.005
    speed: float = 0.001
    temperature: float = 1.0
    flow_full_scale: float | None = None

    def __post_init__(self) -> None:
        for name in _NAMES:
            if not getattr(self, name) >= 0:
                raise InputError("accuracy must be ≥ 0", field=name)
        if self.flow_full_scale is not None and not self.flow_full_scale > 0:
            raise InputError("full scale must be > 0", field="flow_full_scale")

    def instrument(self, name: str) -> InstrumentClass:
        """The instrument class of ``name`` (``"flow"``, ``"pressure"``, ``"torque"``,
        ``"speed"``, ``"temperature"``) in :mod:`diagnostics.quantity`'s terms."""
        a = float(getattr(self, name))
        if name == "temperature":
            return InstrumentClass(_NAMES[name], 0.0, a, "virtual bench (absolute bound, K)")
        if name == "flow" and self.flow_full_scale is not None:
            return InstrumentClass(_NAMES[name], 0.0, a * self.flow_full_scale,
                                   "virtual bench (fraction of full scale)")
        return InstrumentClass(_NAMES[name], a, 0.0, "virtual bench (fraction of reading)")

    def sigma(self, name: str) -> float:
        """Standard uncertainty of instrument ``name`` [-] (relative; temperature [K]): a/√3."""
        return self.instrument(name).reading(1.0).u

    def flow_sigma(self, q: npt.ArrayLike) -> FloatArray:
        """Standard uncertainty of flow readings ``q`` [m³/s] (bound/√3)."""
        return self._bound("flow", q) * _U_PER_BOUND

    def _bound(self, name: str, x: npt.ArrayLike) -> FloatArray:
        inst = self.instrument(name)
        return np.asarray(inst.relative_bound * np.abs(np.asarray(x, dtype=np.float64))
                          + inst.absolute_bound, dtype=np.float64)

    def read(self, name: str, x: FloatArray, rng: np.random.Generator) -> FloatArray:
        """Readings of true values ``x``: each error uniform within the bound (rectangular)."""
        return np.asarray(x + self._bound(name, x) * rng.uniform(-1.0, 1.0, x.size),
                          dtype=np.float64)

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

    p_in_true = np.full(dpt.size, p_in)
    p_in_m = nz.read("pressure", p_in_true, rng)
    p_out_m = nz.read("pressure", p_in_true + dpt, rng)
    w_m = nz.read("speed", wt, rng)
    th_m = nz.read("temperature", th, rng)
    q_m = nz.read("flow", q_true, rng)
    torque_m = None
    if with_torque:
        torque_m = nz.read("torque", np.asarray(model.torque(dpt, wt, th), dtype=np.float64),
                           rng)
    note = (f"virtual ISO 4409 bench: {n_pts} set points x {temps.size} temperatures x "
            f"{replicates} replicates; accuracy bounds flow +-{nz.flow:g}"
            f"{'' if nz.flow_full_scale is None else f' of {nz.flow_full_scale:g} m^3/s'}, "
            f"pressure +-{nz.pressure:g}, "
            f"torque +-{nz.torque:g}, speed +-{nz.speed:g} (fraction of reading), "
            f"temperature +-{nz.temperature:g} K; errors uniform within the bounds "
            f"(rectangular, u = a/sqrt(3), GUM 4.3.7)")
    if label:
        note += f"; {label}"
    return BenchData(p_in=p_in_m, p_out=p_out_m, omega=w_m, theta=th_m, q=q_m,
                     torque=torque_m, replicate=rep, simulated=True, provenance=note)
