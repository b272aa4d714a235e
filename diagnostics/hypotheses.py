"""Fault hypotheses of the pump-valve-cylinder rig and their parameters.

Each hypothesis names the components it blames and the parameters it frees; everything
else stays at the rig's nominal values.  Parameters are fitted in a transformed
coordinate ``z`` in which their prior is uniform (log-uniform for clearances and
leakage factors, which wear multiplies rather than adds to):

===============  ====================  =====================  ==================================
parameter        graph parameter       prior range            physical meaning
===============  ====================  =====================  ==================================
``cc``           ``cylinder.cc``       c0 … 4·c0, log         piston clearance (seal wear)
``cv``           ``valve.cv``          c0 … 4·c0, log         spool clearance (spool wear)
``pump_leak``    ``pump.Rlp`` = R0/k   k = 1 … 20, log        internal leakage factor of the pump
``Pset``         ``relief.Pset``       0.3 … 1.0 × P0, lin    relief setting drift
``seat_leak``    ``relief.Gseat``      s = 0.01 … 20, log     seat leak, in units of the nominal
                                                              pump leakage conductance 1/R0
===============  ====================  =====================  ==================================

The table gives the whole range of each parameter; a hypothesis blames *worn*
components, so its parameters start at the ``none`` severity limit (``WORN``: leakage
× 1.33, a setting 5 % down) — the healthy end belongs to ``healthy``.  Healthy, single
and pair hypotheses are then exclusive explanations and do not share one another's
probability (see :meth:`FaultParameter.worn_bounds`).
A relief setting counts only where it opens: at a record's conditions the part of its
range above the healthy pump pressure leaves every reading exactly healthy, so
``relief_setting`` means a setting that acts there (its evidence is taken over that part,
:func:`diagnostics.evidence.acting_relief_setting`; the rest is stated as not observable).
Prior probabilities of the hypotheses: :data:`diagnostics.evidence.FLEET_PRIOR`.
Four-times clearance means 64 times the laminar leakage, past any rig that still moves.
The relief setting reaches down to 0.3 × nominal: a setting that low is a real failure
(a broken spring, a wrong adjustment); below it, or beyond any other range, the goodness-of-fit test of
:mod:`diagnostics.goodness` reports the readings as not explained rather than naming the
nearest hypothesis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sim.rigs import Rig

__all__ = ["EXTENDED", "HYPOTHESES", "PARAMETERS", "WORN", "FaultParameter", "Hypothesis"]


@dataclass(frozen=True)
class FaultParameter:
    """A fault parameter: how it maps to the rig, its prior range and its unit.

    Attributes
    ----------
    name
        Identifier (``"cc"``).
    component
        Component it belongs to (``"cylinder"``).
    graph_param
        Rig graph parameter it sets.
    unit
        Unit of the reported value.
    low, high
        Prior range as multiples of the nominal value (``nominal_value``); for
        ``seat_leak``, in units of 1/R0.
    log
        Whether the prior is log-uniform.
    """

    name: str
    component: str
    graph_param: str
    unit: str
    low: float
    high: float
    log: bool
    description: str

    def nominal_value(self, rig: Rig) -> float:
        """The reported value of this parameter on the healthy rig [unit]."""
        if self.name == "pump_leak":
            return 1.0
        if self.name == "seat_leak":
            return 0.0
        return rig.base[self.graph_param]

    def bounds(self, rig: Rig) -> tuple[float, float]:
        """Prior range of the reported value [unit]."""
        if self.name == "seat_leak":
            return self.low, self.high
        nom = self.nominal_value(rig)
        return self.low * nom, self.high * nom

    def worn_bounds(self, rig: Rig) -> tuple[float, float]:
        """Prior range of the reported value when the component is *worn* [unit]: the
        part of :meth:`bounds` past the ``none`` severity of
        :func:`diagnostics.ranking.severity` (leakage × 1.33, i.e. clearance × 1.1; a
        setting 5 % down).  A two-fault hypothesis blames both components, so each of
        its parameters takes this range: the pair then no longer contains its single
        faults (both at nominal but one), and does not share their probability; a
        single-fault hypothesis likewise leaves the nominal end to ``healthy``."""
        lo, hi = self.bounds(rig)
        if self.name == "Pset":
            return lo, WORN["Pset"] * hi
        if self.name == "seat_leak":
            return WORN["seat_leak"], hi
        return WORN[self.name] * lo, hi

    def extended_bounds(self, rig: Rig) -> tuple[float, float]:
        """Range of the reported value in which the range test of
        :mod:`diagnostics.range_test` looks for a better fit beyond the prior [unit]
        (:data:`EXTENDED`, in the units of ``low``/``high``)."""
        lo, hi = EXTENDED[self.name]
        if self.name == "seat_leak":
            return lo, hi
        nom = self.nominal_value(rig)
        return lo * nom, hi * nom

    def to_z(self, value: float) -> float:
        """Reported value → fitting coordinate."""
        return math.log(value) if self.log else value

    def from_z(self, z: float) -> float:
        """Fitting coordinate → reported value."""
        return math.exp(z) if self.log else z

    def graph_value(self, rig: Rig, value: float) -> float:
        """Reported value → value of the graph parameter [SI]."""
        if self.name == "pump_leak":
            return rig.base["pump.Rlp"] / value
        if self.name == "seat_leak":
            return value / rig.base["pump.Rlp"]
        return value


#: start of the *worn* range, in the units of ``low``/``high`` (leakage multiple 1.33)
WORN: dict[str, float] = {"cc": 1.33 ** (1 / 3), "cv": 1.33 ** (1 / 3), "pump_leak": 1.33,
                          "seat_leak": 0.33, "Pset": 0.95}

#: range searched beyond each prior by the range test (:mod:`diagnostics.range_test`), in
#: the units of ``low``/``high`` [-]: on the severe side far past any rig that still works
#: (10 × the clearance is 1000 × its laminar leakage; a leakage 1000 × nominal; a relief set
#: at 2 % of nominal), on the healthy side past the rig document (half the clearance, a
#: tenth of the pump's leakage, no seat leak; a relief setting above nominal leaves every
#: reading healthy and is not searched).  Source: chosen, not tuned — the test only needs
#: the best fit beyond the bound, and a wider range can only find a better one.
EXTENDED: dict[str, tuple[float, float]] = {
    "cc": (0.5, 10.0), "cv": (0.5, 10.0), "pump_leak": (0.1, 1000.0), "Pset": (0.02, 0.95),
    "seat_leak": (1.0e-3, 1000.0)}

PARAMETERS: dict[str, FaultParameter] = {
    p.name: p for p in (
        FaultParameter("cc", "cylinder", "cylinder.cc", "m", 1.0, 4.0, True,
                       "radial clearance piston-bore"),
        FaultParameter("cv", "valve", "valve.cv", "m", 1.0, 4.0, True,
                       "radial clearance spool-body"),
        FaultParameter("pump_leak", "pump", "pump.Rlp", "1", 1.0, 20.0, True,
                       "internal leakage of the pump, multiple of nominal (its flow: "
                       "value × Δp / Rlp of the rig document)"),
        FaultParameter("Pset", "relief", "relief.Pset", "Pa", 0.3, 1.0, False,
                       "relief valve opening pressure"),
        FaultParameter("seat_leak", "relief", "relief.Gseat", "1", 0.01, 20.0, True,
                       "relief seat leakage, multiple of the nominal pump leakage (its "
                       "flow: value × Δp / Rlp of the rig document)"),
    )
}


@dataclass(frozen=True)
class Hypothesis:
    """A fault hypothesis: a name, the components blamed, the parameters freed."""

    name: str
    components: tuple[str, ...]
    parameters: tuple[str, ...]
    description: str


HYPOTHESES: tuple[Hypothesis, ...] = (
    Hypothesis("healthy", (), (), "every component as built"),
    Hypothesis("cylinder", ("cylinder",), ("cc",), "piston seal wear"),
    Hypothesis("valve", ("valve",), ("cv",), "directional valve spool wear"),
    Hypothesis("pump", ("pump",), ("pump_leak",), "pump wear: internal leakage up"),
    Hypothesis("relief_setting", ("relief",), ("Pset",), "relief valve setting drifted down"),
    Hypothesis("relief_seat", ("relief",), ("seat_leak",), "relief valve seat leaks"),
    Hypothesis("cylinder+valve", ("cylinder", "valve"), ("cc", "cv"), "seal and spool wear"),
    Hypothesis("cylinder+pump", ("cylinder", "pump"), ("cc", "pump_leak"), "seal and pump wear"),
    Hypothesis("valve+pump", ("valve", "pump"), ("cv", "pump_leak"), "spool and pump wear"),
)
