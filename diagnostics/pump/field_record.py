"""Generated field records of a gear pump on a machine (SIMULATED; paper 000 §3.2 and §5).

**A test and demonstration tool.**  A :class:`FieldRecord` from :func:`generate_field_record`
carries ``simulated=True`` and the list of hidden effects it contains; never present it as
measured.  It imitates paper 000's in-field test: pressure, oil temperature and flow sampled
every 30 ms at the instrumentation point, the pump driven at a constant engine speed.

How a record is made:

1. **Pressure** (:func:`duty_profile`): the mast-foot / jib movements of paper 000 §3.2.2 —
   stand-by ≈ 11-20 bar, lowering ≈ 90-110 bar, raising ≈ 130-160 bar, held 2-5 s, joined
   by raised-cosine ramps of 0.15-0.4 s, with the operator's slow oscillation (±2-3 bar,
   0.3-1 Hz) while a movement runs.  The next movement is drawn at random, so a level is
   reached both from below and from above.  Knots every 10 ms.
2. **Temperature**: a linear drift between two values [°C].
3. **Truth**: the duty-cycle circuit of :mod:`sim.duty_cycle` *with* the documented gaps
   (:class:`HiddenEffects`: the library entries ``side_plate_lag`` and ``slip_hysteresis``
   of :mod:`sim.components.effects`; off unless asked) driven by the 10 ms pressure, read
   by a counting flowmeter every 30 ms.
4. **Instruments** (bounds read as rectangular distributions, GUM §4.3.7, as
   :mod:`diagnostics.quantity` does): the flowmeter's ±1 % of reading (paper 000 §3.2.1) is
   drawn independently for every sample — the flowmeter noise.  The transducer's ±0.25 % is
   a class bound; by default it is one gain error per record, drawn within the bound
   (``transducer_noise=False``).  Drawn per sample instead, it would make the pressure
   record jagged, and the model driven by it would turn every jag into a compressibility
   flow ``C·Δp/Δt`` of the hose (≈ 0.1 % of the flow rms at 135 bar, alternating in sign:
   a residual structure that belongs to the input, not to the pump).  The thermometer and
   the engine-speed display are read without error (paper 000 §3.2.2: "very exact").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from diagnostics.quantity import DEFAULT_INSTRUMENTS, InstrumentClass
from sim.components.gear_pump import GearPump
from sim.components.gear_pump_map import stand_in_pump
from sim.duty_cycle import duty_cycle_model, rpm
from sim.errors import InputError

__all__ = ["LIBRARY", "SAMPLE_INTERVAL", "FieldRecord", "HiddenEffects", "duty_profile",
           "generate_field_record"]

FloatArray = npt.NDArray[np.float64]

#: Field sampling interval [s] (paper 000 §3.2.2: "acquisition ... every 30 ms").
SAMPLE_INTERVAL = 0.03
_KNOT = 0.01  # pressure knots of the generated truth [s]; the samples are every 3rd knot

#: library effects of the field circuit the generator's truth holds (:class:`HiddenEffects`)
LIBRARY = ("side_plate_lag", "slip_hysteresis")

#: Pressure levels of the movements [Pa] (paper 000 §3.2.2; seeds README).
LEVELS: dict[str, tuple[float, float]] = {"standby": (11e5, 20e5), "lowering": (90e5, 110e5),
                                          "raising": (130e5, 160e5)}


@dataclass(frozen=True, slots=True)
class HiddenEffects:
    """The documented model gaps a generated record may contain (paper 000 §5).

    Parameters
    ----------
    side_plate_lag
        Time constant τ [s] of the side-plate lag: the slip responds to pressure changes as
        a first-order lag (0: absent).  Paper 000 Fig. 10: "the real flow was slightly
        delayed versus the modeled flow".
    hysteresis
        Relative change ``h`` [-] of the slip with the direction of the last pressure
        change: ``(1 + h)`` after a rise, ``(1 − h)`` after a fall (0: absent).  Paper 000
        §5: "different flow measured with the same working conditions"; the plate "stuck"
        after a pressure peak gives less slip (more flow) on the way down.
    band
        Half-width [Pa] of the play that remembers the direction.
    """

    side_plate_lag: float = 0.0
    hysteresis: float = 0.0
    band: float = 3.0e5

    def __post_init__(self) -> None:
        if not (self.side_plate_lag >= 0.0 and math.isfinite(self.side_plate_lag)):
            raise InputError("the lag time constant must be ≥ 0", field="side_plate_lag")
        if not (-1.0 < self.hysteresis < 1.0):
            raise InputError("hysteresis must lie in (−1, 1)", field="hysteresis")
        if not self.band > 0.0:
            raise InputError("band must be > 0", field="band")

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the effects present."""
        return tuple(n for n, on in (("side-plate lag", self.side_plate_lag > 0.0),
                                     ("hysteresis", self.hysteresis != 0.0)) if on)

    def overrides(self) -> dict[str, float]:
        """Parameters of the library effects (:data:`LIBRARY`) in the duty-cycle circuit."""
        return {"side_plate_lag.tau": self.side_plate_lag, "slip_hysteresis.h": self.hysteresis,
                "slip_hysteresis.w_h": self.band}


@dataclass(frozen=True, eq=False)
class FieldRecord:
    """A field record sampled at fixed times.

    Attributes
    ----------
    t
        Sample times [s].
    pressure
        Pump-line pressure readings [Pa] (gauge).
    theta
        Oil temperature readings [°C].
    flow
        Flowmeter readings [m³/s].
    speed
        Engine (pump) speed [rad/s], one value for the record.
    simulated
        True for generated records; False (the default) for a record built from
        measurements.
    effects
        Hidden effects the generator put in (empty: none).
    provenance
        How the record was made.
    truth
        Generated records only: noise-free signals at the samples (``"flow"`` [m³/s],
        ``"pressure"`` [Pa], ``"direction"`` [-] with effects).
    """

    t: FloatArray
    pressure: FloatArray
    theta: FloatArray
    flow: FloatArray
    speed: float
    simulated: bool = False
    effects: tuple[str, ...] = ()
    provenance: str = ""
    truth: dict[str, FloatArray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = self.t.size
        for name in ("pressure", "theta", "flow"):
            a = getattr(self, name)
            if a.shape != (n,) or not np.all(np.isfinite(a)):
                raise InputError(f"{name} must be finite, one value per sample", field=name)
        if n < 3 or np.any(np.diff(self.t) <= 0.0):
            raise InputError("at least 3 samples at increasing times", field="t")
        if not self.speed > 0.0:
            raise InputError("speed must be > 0", field="speed")

    @property
    def interval(self) -> float:
        """Median sampling interval [s]."""
        return float(np.median(np.diff(self.t)))


def _raised_cosine(x: FloatArray) -> FloatArray:
    return 0.5 - 0.5 * np.cos(np.pi * np.clip(x, 0.0, 1.0))


def duty_profile(duration: float, *, seed: int | np.random.Generator = 0,
                 levels: dict[str, tuple[float, float]] | None = None,
                 ripple: float = 2.5e5) -> tuple[FloatArray, FloatArray]:
    """Pressure of a random sequence of movements (module docstring, step 1).

    Parameters
    ----------
    duration
        Length [s].
    seed
        Seed or generator.
    levels
        Movement → (low, high) pressure range [Pa]; a level is drawn in it.  Default
        :data:`LEVELS`; give equal bounds for fixed levels.
    ripple
        Amplitude [Pa] of the operator's oscillation during a movement.

    Returns
    -------
    tuple of ndarray
        Knot times every 10 ms [s] and pressures [Pa].
    """
    if not duration > 0.0:
        raise InputError("duration must be > 0", field="duration")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    lv = LEVELS if levels is None else levels
    t = np.arange(0.0, duration + 0.5 * _KNOT, _KNOT)
    p = np.empty_like(t)
    start, current = 0.0, "standby"
    level = rng.uniform(*lv[current])
    p_prev = level
    while start < duration:
        hold = rng.uniform(1.5, 3.5) if current == "standby" else rng.uniform(2.0, 5.0)
        ramp = rng.uniform(0.15, 0.4)
        seg = (t >= start) & (t < start + ramp + hold)
        x = t[seg] - start
        base = p_prev + (level - p_prev) * _raised_cosine(x / ramp)
        if current != "standby":
            f1, f2 = rng.uniform(0.3, 1.0, 2)
            ph = rng.uniform(0, 2 * np.pi, 2)
            osc = ripple * (0.6 * np.sin(2 * np.pi * f1 * x + ph[0])
                            + 0.4 * np.sin(2 * np.pi * f2 * x + ph[1]))
            base = base + osc * _raised_cosine(x / ramp)
        p[seg] = base
        start += ramp + hold
        p_prev = float(p[seg][-1]) if seg.any() else p_prev
        current = str(rng.choice([k for k in lv if k != current]))
        level = rng.uniform(*lv[current])
    return t, p


def _read(rng: np.random.Generator, instrument: InstrumentClass, x: FloatArray) -> FloatArray:
    """Readings of ``instrument``: errors uniform within its bound (rectangular, GUM 4.3.7)."""
    half = instrument.relative_bound * np.abs(x) + instrument.absolute_bound
    return np.asarray(x + half * rng.uniform(-1.0, 1.0, x.size), dtype=np.float64)


def generate_field_record(duration: float = 60.0, *, speed: float = rpm(1467),
                          theta: tuple[float, float] = (40.0, 43.0),
                          effects: HiddenEffects | None = None, pump: GearPump | None = None,
                          seed: int = 0, levels: dict[str, tuple[float, float]] | None = None,
                          ripple: float = 2.5e5,
                          flowmeter: InstrumentClass = DEFAULT_INSTRUMENTS["pump_flow"],
                          transducer: InstrumentClass = DEFAULT_INSTRUMENTS["pump_pressure"],
                          transducer_noise: bool = False) -> FieldRecord:
    """A SIMULATED field record (module docstring).

    Parameters
    ----------
    duration
        Record length [s] (≤ 81 s keeps the 10 ms truth input unresampled).
    speed
        Engine speed [rad/s] (default 1467 rpm, paper 000 §5).
    theta
        Oil temperature at the start and at the end [°C] (linear drift).
    effects
        Hidden effects (default none).
    pump
        The pump that runs (default the stand-in map; a worn pump for a campaign).
    seed
        Seed of the profile and of the instrument errors.
    levels, ripple
        Pressure ranges of the movements and the operator's oscillation [Pa]
        (:func:`duty_profile`).
    flowmeter, transducer
        Instrument classes (default paper 000 §3.2.1: ±1 %, ±0.25 %).
    transducer_noise
        Draw the transducer error per sample instead of once per record.
    """
    eff = effects if effects is not None else HiddenEffects()
    pm = pump if pump is not None else stand_in_pump()
    rng = np.random.default_rng(seed)
    t_k, p_k = duty_profile(duration, seed=rng, levels=levels, ripple=ripple)
    th_k = theta[0] + (theta[1] - theta[0]) * t_k / t_k[-1]
    every = round(SAMPLE_INTERVAL / _KNOT)
    run = duty_cycle_model(LIBRARY).simulate(t_k, p_k, th_k, speed, pm,
                                             overrides=eff.overrides(), sample_every=every)
    t_s = run.t
    p_true = p_k[::every]
    o = run.outputs
    # net slip: the base elements less what the lag holds back and the hysteresis returns
    truth = {"flow": run.q_meter, "pressure": p_true, "direction": o["slip_hysteresis.direction"],
             "q_slip": o["pump.Q_s"] + o["pump.Q_st"] - o["side_plate_lag.dQ_s"]
             - o["side_plate_lag.dQ_st"] - o["slip_hysteresis.dQ"]}
    note = (f"SIMULATED field record: {duration:g} s at {speed * 60 / (2 * math.pi):.0f} rpm, "
            f"oil {theta[0]:g}->{theta[1]:g} degC, samples every {SAMPLE_INTERVAL * 1e3:g} ms, "
            f"flowmeter +-{flowmeter.relative_bound:g} per sample, transducer "
            f"+-{transducer.relative_bound:g} of reading "
            f"{'per sample' if transducer_noise else 'per record (gain)'} (rectangular); "
            f"hidden effects: "
            f"{', '.join(eff.names) or 'none'}; pump: {pm.note or 'given'}; seed {seed}")
    if transducer_noise:
        p_read = _read(rng, transducer, p_true)
    else:
        p_read = p_true * (1.0 + transducer.relative_bound * rng.uniform(-1.0, 1.0))
    return FieldRecord(t=t_s, pressure=np.asarray(p_read, dtype=np.float64),
                       theta=np.asarray(th_k[::every], dtype=np.float64),
                       flow=_read(rng, flowmeter, run.q_meter), speed=float(speed),
                       simulated=True, effects=eff.names, provenance=note, truth=truth)
