"""Field duty cycle of paper 000 §4-5: the gear pump on a machine, driven by measured signals.

The circuit is paper 000's Figure 7 (sections of Figure 5)::

    pump (Figure 7 fragment) ─ hose 2 ─ 0[meter] ─ hose 3 ─ 0[block] ─ MSe SYSTEM p(t)
                                        flowmeter,          │ relief valve (section 4)
                                        transducer

* **Section 1**, the pump: :mod:`sim.components.gear_pump_fragment` at the engine speed.
* **Sections 2 and 3**, hoses pump → instrumentation and instrumentation → control block:
  :mod:`sim.components.hose` (R, C, I from bore, length and β, paper 000 §4).
* **Section 4**, the relief valve of the control block: :mod:`sim.components.relief_valve`
  (the maker's p-Q graph is not in the copy: a linear law above the setting).
* **MSe SYSTEM**: the measured pressure, a table of time (``tbl:system.P``) — the "SYSTEM
  file" of paper 000 §4.

Temperature: the measured oil temperature θ(t) becomes the viscosity table ``pump.mu``,
``μ(θ(t_k))`` from :class:`sim.fluid.Fluid` at each sample and linear in between (with θ
changing by < 0.1 K per sample, μ's interpolation error is < 1e-5 relative).  The pump's
laminar slip (eq. 4) and viscous torque (eq. 14) read it at every instant.  The hoses'
laminar resistance uses μ at the record's mean temperature: it only sets the small pressure
drop pump → block (≈ 0.2 bar at 20 L/min), whose change over a ±5 K drift moves the pump
pressure by < 0.02 bar and the slip by < 1e-5 of the flow.

The flowmeter is a *counting* meter: its reading at ``t_k`` is the volume that passed the
instrumentation point since ``t_{k−1}`` divided by the interval (auxiliary state
``meter.V``).  Because the volume the hose compliance stores between two instants depends
only on the two pressures, a model driven by the sampled pressure reproduces that reading
without having to resolve the pressure between samples.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from sim.bondgraph import BondGraph, CompiledModel, MSe, Zero, compile_graph
from sim.bondgraph.laws import table_lookup
from sim.components import gear_pump_fragment, hose, relief_valve
from sim.components.base import Derivation
from sim.components.effects import get_effect
from sim.components.effects.base import FIELD_CIRCUIT
from sim.components.gear_pump import GearPump, dynamic_viscosity
from sim.components.gear_pump_map import stand_in_pump
from sim.errors import InputError, SimulationError
from sim.params import Param

__all__ = ["CIRCUIT", "CIRCUIT_VALUES", "TABLE_POINTS", "DutyCycleModel", "DutyCycleRun", "build_graph",
           "duty_cycle_model", "rpm"]

Arr = npt.NDArray[np.float64]

#: name of this circuit in the effect library (:mod:`sim.components.effects`)
CIRCUIT = FIELD_CIRCUIT

#: Table size of the compiled circuits [points]: 81 s of input at 10 ms, 122 s at 15 ms (a
#: 30 ms record upsampled twice), 245 s at 30 ms.  A longer series is resampled
#: (:func:`sim.bondgraph.fit_table`).
TABLE_POINTS = 8192

#: Circuit values of the field rig (paper 000 Figure 5 is lost: chosen, with reasons).
CIRCUIT_VALUES: tuple[Param, ...] = (
    Param("hose2.d", "m", 0.0191, "chosen: 3/4-inch hose (Figure 5 lost)", "bore of section 2"),
    Param("hose2.L", "m", 2.0, "chosen: pump on the LS pump's rear cover to the instruments "
          "(paper 000 Fig. 4b)", "length of section 2"),
    Param("hose3.d", "m", 0.0191, "chosen: 3/4-inch hose", "bore of section 3"),
    Param("hose3.L", "m", 5.0, "chosen: instruments to the control block", "length of section 3"),
    Param("relief.Pset", "Pa", 250e5, "paper 000 §3.2.2: LS relief of the mast foot ≈ 250 bar",
          "relief setting"),
    Param("relief.Rrv", "Pa*s/m^3", 2.5e9, "chosen: paper 002's value (the maker's p-Q graph "
          "is not in the copy of paper 000)", "relief resistance above the setting"),
)


def _values(prefix: str) -> dict[str, float]:
    return {p.name.split(".", 1)[1]: p.default for p in CIRCUIT_VALUES
            if p.name.startswith(prefix + ".")}


def build_graph(*, points: int | None = None,
                library: tuple[str, ...] = ()) -> tuple[BondGraph, list[Derivation]]:
    """The duty-cycle circuit (module docstring) and its parameter derivations.

    Parameters
    ----------
    points
        Size of the pressure and viscosity tables (default :data:`TABLE_POINTS`).
    library
        Library effects of circuit :data:`CIRCUIT` to add (``("side_plate_lag",)``,
        :mod:`sim.components.effects`): the documented gaps of paper 000 §5 (side-plate lag,
        slip hysteresis), for generating records the base model does not explain and for
        the discrepancy workflow; off until their strength is set (parameters
        ``side_plate_lag.tau`` …).

    Raises
    ------
    RigFileError
        An unknown effect, or one of another circuit.
    """
    n = TABLE_POINTS if points is None else points
    lib = tuple(library)
    tag = "".join(f"_{e}" for e in lib)
    g = BondGraph("duty_cycle" + tag)
    for k, unit in (("mu", "Pa*s"), ("rho", "kg/m^3"), ("beta", "Pa")):
        g.parameter(f"fluid.{k}", {"mu": 0.04, "rho": 865.0, "beta": 1.5e9}[k], unit,
                    "hoses: from the oil at the record's mean temperature")
    pump = gear_pump_fragment.build(g, "pump", viscosity_points=n)
    h2 = hose.build(g, "hose2", pump.ports["out"], _values("hose2"))
    g.add(Zero("meter", description="instrumentation point: flowmeter, transducer"))
    g.connect(h2.ports["line"], "meter")
    h3 = hose.build(g, "hose3", "meter", _values("hose3"))
    g.add(Zero("block", description="control block"))
    g.connect(h3.ports["line"], "block")
    relief_valve.build(g, "relief", "block", _values("relief"))
    P = g.table("system.P", n, value=20e5, unit="Pa", source="measured pressure (SYSTEM file)")
    g.add(MSe("system", table_lookup, "t", P, description="MSe SYSTEM: measured pressure"))
    g.connect("system", "block", label="system")
    g.integrate("meter.V", "flow:hose2.line", scale=1e-4, unit="m^3")
    g.output("Q_meter", "flow:hose2.line", "m^3/s", "flow at the instrumentation point")
    g.output("p_meter", "effort:meter", "Pa", "pressure at the instrumentation point")
    for name in lib:
        get_effect(name, CIRCUIT, field="library").build(g)
    return g, [d for d in (pump.derive, h2.derive, h3.derive) if d is not None]


@dataclass
class DutyCycleRun:
    """A simulated duty cycle, at the sample times.

    Attributes
    ----------
    t
        Sample times [s].
    q_meter
        Counting-flowmeter reading: volume since the previous sample / interval [m³/s].
    outputs
        Every model output at the sample instants (``"pump.Q"`` [m³/s], ``"pump.torque"``
        [N·m], ``"pump.p_core"`` [Pa], ``"pump.Q_s"`` …; units in ``units``).
    units
        Unit of each output.
    steps
        Accepted solver steps.
    """

    t: Arr
    q_meter: Arr
    outputs: dict[str, Arr]
    units: dict[str, str] = field(default_factory=dict)
    steps: int = 0


@dataclass
class DutyCycleModel:
    """The compiled circuit with the helpers to drive it by a record."""

    model: CompiledModel
    derivations: list[Derivation]
    library: tuple[str, ...] = ()

    def params(self, t: Arr, pressure: Arr, theta: Arr, speed: float, pump: GearPump,
               overrides: Mapping[str, float] | None = None) -> Arr:
        """Parameter vector of the circuit driven by a record.

        Parameters
        ----------
        t
            Input times [s] (the tables' time axis).
        pressure
            Pressure imposed by the system (MSe SYSTEM) [Pa] at ``t``.
        theta
            Oil temperature [°C] at ``t``; the table ``pump.mu`` holds μ(θ) [Pa·s], the hoses
            take μ at the mean temperature (module docstring).
        speed
            Engine speed [rad/s].
        pump
            D, ρ, β_ef, the four coefficient surfaces and the oil.
        overrides
            Graph parameters by full name (``{"side_plate_lag.tau": 0.3}``), applied before the
            derived parameters are computed and again after them (so a derived value can
            be overridden too).
        """
        g = self.model.system.graph
        v = {k: prm.value for k, prm in g.parameters.items()}
        v.update(gear_pump_fragment.pump_values(pump, "pump"))
        theta_mean = float(np.mean(theta))
        v["pump.speed"] = float(speed)
        v["fluid.mu"] = pump.fluid.dynamic_viscosity(theta_mean)
        v["fluid.rho"] = pump.rho
        v.update(overrides or {})
        for d in self.derivations:
            v.update(d(v))
        v.update(overrides or {})
        mu = dynamic_viscosity(pump.fluid, theta)
        return self.model.params(v, tables={"system.P": (t, pressure), "pump.mu": (t, mu)})

    def initial_state(self, p: Arr, pressure0: float, flow0: float) -> Arr:
        """Steady state of the circuit at ``t = 0`` [SI per state].

        Newton's method from a guess: every C state and auxiliary pressure state (library
        effects' memories) at ``pressure0`` [Pa], every I state (flows) at ``flow0``
        [m³/s], other auxiliary states at 0; :attr:`frozen` states
        keep their guess.
        """
        guess = np.array([pressure0 if s.kind == "C" or (s.kind == "aux" and s.unit == "Pa")
                          else flow0 if s.kind == "I" else 0.0
                          for s in self.model.system.states])
        return self.model.steady(guess, p, frozen=self.frozen)

    @property
    def frozen(self) -> tuple[str, ...]:
        """States held in a steady solution: the meter volume and the states the library
        effects hold (:attr:`sim.components.effects.Effect.frozen`: the hysteresis memory,
        every value within its band being an equilibrium; it starts at the pressure, i.e.
        with no remembered direction)."""
        return ("meter.V", *(s for e in self.library for s in get_effect(e).frozen))

    def simulate(self, t: npt.ArrayLike, pressure: npt.ArrayLike, theta: npt.ArrayLike,
                 speed: float, pump: GearPump | None = None, *,
                 overrides: Mapping[str, float] | None = None, sample_every: int = 1,
                 rtol: float = 1e-6) -> DutyCycleRun:
        """Drive the circuit by a pressure and temperature record.

        The system starts at its steady state one sample interval before ``t[0]`` and runs
        to ``t[-1]``; the reading of the counting meter and the outputs are returned at
        every ``sample_every``-th input time (the input may be finer than the samples).

        Parameters
        ----------
        t
            Input times [s], increasing, equally spaced or not.
        pressure, theta
            Pressure imposed by the system [Pa] and oil temperature [°C] at ``t``.
        speed
            Engine (pump) speed [rad/s].
        pump
            Pump model (default: the stand-in map, not bench data).
        overrides
            Graph parameters set last.
        sample_every
            Output at ``t[::sample_every]``.
        rtol
            Relative tolerance of the ROS2 integrator.

        Raises
        ------
        InputError
            Inputs of different lengths, fewer than 2 times, times not increasing.
        SimulationError
            The integrator failed.
        """
        ta = np.asarray(t, dtype=np.float64).ravel()
        pa = np.asarray(pressure, dtype=np.float64).ravel()
        th = np.asarray(theta, dtype=np.float64).ravel()
        if not (ta.size == pa.size == th.size) or ta.size < 2:
            raise InputError("t, pressure and theta need equal lengths ≥ 2", field="t")
        if np.any(np.diff(ta) <= 0.0):
            raise InputError("times must increase", field="t")
        pm = pump if pump is not None else stand_in_pump()
        out_idx = np.arange(0, ta.size, sample_every)
        t_out = ta[out_idx]
        lead = t_out[1] - t_out[0] if t_out.size > 1 else ta[1] - ta[0]
        shift = lead - ta[0]          # internal clock: the record starts at `lead` > 0
        p = self.params(ta + shift, pa, th, speed, pm, overrides)
        y = self.initial_state(p, float(pa[0]), pm.D * speed)
        iv = self.model.state_index("meter.V")
        ys = np.empty((t_out.size + 1, y.size))
        ys[0] = y
        t_prev, h, steps = 0.0, 1e-5, 0
        for k, tk in enumerate(t_out + shift):
            res = self.model.integrate(y, p, float(tk), t0=t_prev, rtol=rtol, h0=h,
                                       hmax=float(tk - t_prev), capacity=100_000)
            if not res.success or res.t[-1] < tk - 1e-12 * max(1.0, tk):
                raise SimulationError(f"duty cycle: integration failed before t = "
                                      f"{tk - shift:.4g} s (status {res.status})")
            y = res.y[-1]
            ys[k + 1] = y
            steps += res.t.size - 1
            # next first step: the last untruncated step of this interval
            h = max(float(res.t[-2] - res.t[-3]) if res.t.size > 2 else float(tk - t_prev), 1e-6)
            t_prev = float(tk)
        t_all = np.concatenate([[0.0], t_out + shift])
        q = np.diff(ys[:, iv]) / np.diff(t_all)
        out = self.model.outputs(t_out + shift, np.ascontiguousarray(ys[1:]), p)
        outputs = {n: out[:, i] for i, n in enumerate(self.model.output_names)}
        units = dict(zip(self.model.output_names, self.model.output_units, strict=True))
        return DutyCycleRun(t_out, q, outputs, units, steps)

    def quasi_static(self, t: npt.ArrayLike, pressure: npt.ArrayLike, theta: npt.ArrayLike,
                     speed: float, pump: GearPump | None = None) -> Arr:
        """Meter flow [m³/s] of the same circuit solved at steady state at each sample.

        Each sample's pressure and viscosity are held constant and Newton's method solves
        for the steady state from the previous one: no hose storage, no dynamics.  Used as
        the baseline of the duty-cycle timing and to show what the dynamics add.  The
        steady solver evaluates the model at ``t = 0``, where the tables (time axis from 0)
        return their first value, so only that entry is changed from sample to sample.

        Parameters
        ----------
        t, pressure, theta
            Sample times [s], system pressure [Pa] and oil temperature [°C].
        speed
            Engine speed [rad/s].
        pump
            The pump model (default: the stand-in map).
        """
        ta = np.asarray(t, dtype=np.float64).ravel()
        pa = np.asarray(pressure, dtype=np.float64).ravel()
        th = np.asarray(theta, dtype=np.float64).ravel()
        pm = pump if pump is not None else stand_in_pump()
        p = self.params(ta - ta[0], pa, th, speed, pm)
        mu = dynamic_viscosity(pm.fluid, th)
        (op, n_p), (om, n_m) = (self.model.table_block("system.P"),
                                self.model.table_block("pump.mu"))
        op, om = op + n_p, om + n_m      # first value of each table
        iq = self.model.output_names.index("Q_meter")
        y = self.initial_state(p, float(pa[0]), pm.D * speed)
        q = np.empty(ta.size)
        out = np.empty((1, len(self.model.output_names)))
        for k in range(ta.size):
            p[op] = pa[k]
            p[om] = mu[k]
            y = self.model.steady(y, p, frozen=self.frozen)
            self.model.module.outputs(0.0, y, p, out[0])
            q[k] = out[0, iq]
        return q


def duty_cycle_model(library: tuple[str, ...] = ()) -> DutyCycleModel:
    """The compiled duty-cycle circuit (once per process and effect set; the machine code is
    cached on disk); ``library`` as in :func:`build_graph`, in any order."""
    return _model(tuple(sorted(set(library))))


@lru_cache(maxsize=8)
def _model(library: tuple[str, ...]) -> DutyCycleModel:
    g, derivations = build_graph(library=library)
    return DutyCycleModel(compile_graph(g), derivations, library)


def rpm(n: float) -> float:
    """Speed [rad/s] of ``n`` revolutions per minute."""
    return n * 2.0 * math.pi / 60.0
