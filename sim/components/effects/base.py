"""What every candidate effect shares: its catalogue entry and the shared laws.

An *effect* is a physical mechanism a rig model may miss (the discrepancy workflow's
library, issue 8).  Each effect module declares

* ``ENTRY`` (:class:`EffectEntry`): name, one-line physics, reference, the regressor it
  leaves in the equation-error residual of the balance it enters, the sign and plausible
  range of its coefficient;
* ``PARAMETERS``: its :class:`~sim.params.Param` declarations (the strength defaults to 0,
  i.e. "off", so a rig with the effect at zero is the base rig exactly);
* ``build(g, name)``: the bond-graph change that adds it at named junctions of a circuit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sim.bondgraph.elements import LawCall, One, R, call
from sim.bondgraph.graph import BondGraph
from sim.bondgraph.laws import law
from sim.components.base import declare
from sim.errors import ModelStructureError
from sim.params import Param

__all__ = ["FIELD_CIRCUIT", "LEAKAGE_OUTPUTS", "PUMP_CIRCUITS", "EffectEntry", "Regressor",
           "flow_sum", "leak_across", "leak_to_tank", "signed_sqrt", "signed_sqrt_array"]

#: the paper-000 field duty cycle (gear pump of Figure 7, hoses, relief, measured pressure;
#: :mod:`sim.duty_cycle`): the circuit of the pump-slip dynamics entries
FIELD_CIRCUIT = "gear-pump-field"
#: the circuits that hold paper 002's pump at ``pump`` besides the paper-002 rig: where
#: the pump-outlet entries apply too (:attr:`EffectEntry.also`)
PUMP_CIRCUITS = ("pump-relief-orifice",)

Arr = npt.NDArray[np.float64]

#: builds the regressor column [unit of the balance per unit of the coefficient] from
#: measured signals in SI (``P1``, ``P2``, ``v``, ``mu`` ...)
Regressor = Callable[[Mapping[str, Arr]], Arr]
#: (the stated condition — ``load`` [N], ``back_pressure`` [Pa], ``oil_temperature``
#: [°C], ``pump_speed`` [rad/s] or None — and the rig version's parameter values) → what
#: a version carrying a stated-condition correction applies instead, or None
StatedNote = Callable[[Mapping[str, float | None], Mapping[str, float]], str | None]


@dataclass(frozen=True)
class EffectEntry:
    """Catalogue entry of one candidate effect.

    Attributes
    ----------
    name
        Identifier (rig files' ``effects:`` keys, reports).
    explanation
        One line of physics.
    reference
        Where the law comes from.
    circuit
        The circuit whose junctions the bond-graph change uses.
    also
        Further circuits that hold the same junctions and parameters: the pump entries
        (an element on the pump outlet ``pump.out`` reading only ``pump.*`` and
        ``fluid.*``) apply to every circuit built around :mod:`sim.components.pump` as
        ``pump`` (:data:`PUMP_CIRCUITS`).
    balance
        The bond-graph constraint whose equation-error residual the effect enters:
        ``"piston_force"`` (1-junction of the piston, [N]), ``"chamber_flow"`` (flow from
        chamber 1 to chamber 2 through the piston, [m³/s]), ``"pump_flow"`` (flow out of
        the pump outlet 0-junction, [m³/s]) or, on :data:`FIELD_CIRCUIT`, ``"field_flow"``
        (relative flow residual ``q_meas/q_model − 1`` of a field record, [-]; signals
        ``t``, ``P``, ``dP``, ``Q``, ``Q_s``, ``Q_st``, ``direction``, see
        :func:`diagnostics.pump.field.field_signals`).  An entry may name a balance the
        rig's logged channels do not allow (``"relief_flow"``, ``"hose_pressure"``): it
        is in the library — a rig file can add it, a re-fit by re-simulation can fit
        it — but the equation-error selection never proposes it.
    coefficient
        Name of the parameter the regressor multiplies (its strength).
    signature
        The regressor, in words (``"(P1 + P2)·sgn(ẋ)"``).
    regressor
        Computes the regressor column from measured signals.
    sign
        Expected sign of the coefficient (+1: the effect adds to the loss).
    plausible
        Plausible range of the coefficient [its unit].
    window
        Where the output-error confirmation compares model and data: ``"steady"``
        (10-90 % of each phase), ``"build-up"`` (0-90 %: the pressure build-up after a
        valve switch included, for an effect whose signature is there) or ``"slow"``
        (statistics of the timed slow strokes, where the piston stick-slips:
        :mod:`diagnostics.discrepancy.slow`).
    stated
        For an error of a stated condition (a load cell's gain, a speed reading): the note
        a simulation of a rig version carrying the effect adds, saying what it applies for
        the condition stated (the echoed condition would read as the one applied).
    """

    name: str
    explanation: str
    reference: str
    circuit: str
    balance: str
    coefficient: str
    signature: str
    regressor: Regressor
    sign: float
    plausible: tuple[float, float]
    window: str = "steady"
    also: tuple[str, ...] = ()
    stated: StatedNote | None = None

    def applies_to(self, circuit: str) -> bool:
        """Whether the bond-graph change finds its junctions in ``circuit``."""
        return circuit == self.circuit or circuit in self.also


BuildEffect = Callable[[BondGraph, str], None]


#: the component output that states the leakage leaving each 0-junction a leak path of the
#: library starts from (the pump's slip, the piston's 1 → 2 leak, the spool's P → T leak)
LEAKAGE_OUTPUTS = {"pump.out": "Q_pump_leak", "cylinder.c1": "Q_cyl_leak",
                   "valve.P": "Q_valve_leak"}


@law
def flow_sum(*q: float) -> float:
    """Σq [m³/s]: a component's leakage with the paths effects add beside its own."""
    total = 0.0
    for v in q:
        total += v
    return total


def _count_as_leakage(g: BondGraph, node: str, name: str) -> None:
    """Add the flow of the effect's R ``{name}.R`` from ``node`` to the component output
    that states the leakage there (:data:`LEAKAGE_OUTPUTS`): a worn piston that leaks
    through an orifice beside its gap leaks the sum, and a diagnosis that compares a
    measured leakage with ``Q_cyl_leak`` must see both."""
    output = g.outputs.get(LEAKAGE_OUTPUTS.get(node, ""))
    if output is None:
        return
    refs = (output.expr.args if isinstance(output.expr, LawCall)
            and output.expr.func is flow_sum else (output.expr,))
    if not all(isinstance(r, str) for r in refs):
        raise ModelStructureError(f"output {output.name!r} is no flow reference to add to",
                                  elements=(f"{name}.R",))
    g.output(output.name, call(flow_sum, *(str(r) for r in refs), f"f:{name}.R"),
             output.unit, output.description)


def leak_to_tank(g: BondGraph, name: str, node: str, parameters: tuple[Param, ...],
                 values: Mapping[str, float] | None, flow: LawCall, description: str, *,
                 leakage: bool = True) -> None:
    """Declare the effect's ``parameters`` and add its R ``{name}.R`` from the 0-junction
    ``node`` to the tank (gauge pressure 0, so the R's effort is the node's pressure) with
    the flow law ``flow``: the bond-graph change of every leak to tank in the library.
    Its flow counts in the leakage output of ``node`` (:data:`LEAKAGE_OUTPUTS`) unless
    ``leakage`` is false (a flow lost that no drain line carries: the pump's
    compressibility loss, paper 000 eq. 6)."""
    declare(g, name, parameters, values)
    g.add(R(f"{name}.R", flow=flow, description=description))
    g.connect(node, f"{name}.R", label=f"{name}.R")
    if leakage:
        _count_as_leakage(g, node, name)


def leak_across(g: BondGraph, name: str, high: str, low: str, parameters: tuple[Param, ...],
                values: Mapping[str, float] | None, flow: LawCall, description: str) -> None:
    """Declare the effect's ``parameters`` and add its R ``{name}.R`` on a new 1-junction
    ``{name}.path`` from 0-junction ``high`` to 0-junction ``low`` (the R's effort is the
    pressure difference, its flow positive from ``high`` to ``low``): every leak path
    across a gap in the library.  Its flow counts in the leakage output of ``high``."""
    declare(g, name, parameters, values)
    path = f"{name}.path"
    g.add(One(path, description=description))
    g.add(R(f"{name}.R", flow=flow, description=description))
    g.connect(high, path)
    g.connect(path, f"{name}.R", label=f"{name}.R")
    g.connect(path, low)
    _count_as_leakage(g, high, name)


@law
def signed_sqrt(dp: float, p_t: float) -> float:
    """sgn(Δp)·√|Δp| regularised below the transition pressure ``p_t`` [Pa^0.5].

    ``Δp / (Δp² + p_t²)^(1/4)``: equal to sgn·√|Δp| for |Δp| ≫ p_t and linear (laminar)
    for |Δp| ≪ p_t, so the Jacobian stays finite at Δp = 0 (orifice flow, Merritt,
    *Hydraulic Control Systems*, 1967, eq. 3-5 with a laminar core).
    """
    return dp / math.sqrt(math.sqrt(dp * dp + p_t * p_t))


def signed_sqrt_array(dp: Arr, p_t: float) -> Arr:
    """:func:`signed_sqrt` over an array (regressor columns)."""
    return np.asarray(dp / np.sqrt(np.sqrt(dp * dp + p_t * p_t)), dtype=float)
