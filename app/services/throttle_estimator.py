"""The clearance estimator of the service: :mod:`diagnostics.throttle` on the rig's model.

A throttle equivalence row gives a bypass flow at a back-pressure and an oil temperature;
its equivalent clearance is the clearance whose leakage law (paper 002 eq. 36 for the
piston, eq. 23 for the spool) passes that flow at the rig's operating point of that
condition (:func:`diagnostics.throttle.clearances_from_law`):

* the operating point is the nominal rig's working phase on the steady fast path
  (:func:`sim.steady.steady_cycle`), the load being the back-pressure acting on the
  annulus, ``F = p_back · A2`` (paper 002 §3: 10 bar ≙ 2.1 kN; the rig file's convention);
* cylinder: ΔP = P1 − P2 and the piston speed of that point (Couette term), bore and seal
  length Lc of the rig;
* valve: ΔP = P_valve_P − PRvt (valve inlet to its T port), spool diameter Dv and sealing
  length Ls of the rig;
* viscosity from the rig's oil at the table's temperature.

On the reference rig this returns the nominal clearances for the nominal leakages (the
first rows of paper 002's Tables 2 and 3) and follows ``Q ∝ c³`` above them, as the paper
does.  Operating points are cached per (rig document, condition).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Mapping
from typing import Any

from app.services.rig_cache import DocumentRigs, document_digest
from diagnostics.throttle import CalibrationRow, CalibrationTable, clearances_from_law
from sim.errors import InputError, SimulationError
from sim.rigs import Condition
from sim.steady import steady_cycle

__all__ = ["ThrottleClearanceEstimator"]

_COMPONENTS = ("cylinder", "valve")


class ThrottleClearanceEstimator:
    """Computes the equivalent clearance of a throttle table row (module docstring).

    Implements :class:`app.services.clearance.ClearanceEstimator`; pass an instance to
    :func:`app.main.create_app` and :func:`app.services.bootstrap.ensure_reference_data`.

    Parameters
    ----------
    rigs
        Compiled rigs by document; a private cache when ``None``.
    """

    def __init__(self, rigs: DocumentRigs | None = None) -> None:
        self._rigs = rigs if rigs is not None else DocumentRigs()
        self._points: OrderedDict[tuple[str, str, float, float], dict[str, float]] = OrderedDict()
        self._lock = threading.Lock()

    def _law_inputs(self, document: Mapping[str, Any], component: str, back_pressure_pa: float,
                    temperature_c: float) -> dict[str, float]:
        key = (document_digest(document), component, back_pressure_pa, temperature_c)
        with self._lock:
            cached = self._points.get(key)
        if cached is not None:
            return cached
        rig = self._rigs.get(document)
        rig.require_cycle("the equivalent clearance of a throttle table (paper 002 §2.7)")
        values = rig.values()
        condition = Condition(load=back_pressure_pa * values["cylinder.A2"], back_pressure=0.0,
                              oil_temperature=temperature_c)
        try:
            working = steady_cycle(rig, None, condition).working
        except SimulationError as exc:
            raise InputError(f"no operating point of the rig at this condition: {exc.message}",
                             field="back_pressure_pa") from None
        mu = rig.fluid.dynamic_viscosity(temperature_c)
        if component == "cylinder":
            inputs = {"dp": working["P1"] - working["P2"], "mu": mu, "D": values["cylinder.bore"],
                      "L": values["cylinder.Lc"], "velocity": working["speed"]}
        else:
            inputs = {"dp": working["P_valve_P"] - values["valve.PRvt"], "mu": mu,
                      "D": values["valve.Dv"], "L": values["valve.Ls"], "velocity": 0.0}
        with self._lock:
            self._points[key] = inputs
            while len(self._points) > 64:
                self._points.popitem(last=False)
        return inputs

    def __call__(
        self,
        *,
        rig_document: Mapping[str, Any],
        component: str,
        bypass_flow_m3s: float,
        back_pressure_pa: float,
        temperature_c: float,
    ) -> float:
        """Equivalent clearance [m] of a row: bypass flow [m³/s] at back-pressure [Pa] and
        oil temperature [°C] (see the module docstring).

        Raises
        ------
        InputError
            A component other than ``cylinder`` or ``valve``, or no operating point.
        """
        if component not in _COMPONENTS:
            raise InputError(f"no leakage law for component {component!r} (known: "
                             f"{', '.join(_COMPONENTS)})", field="component")
        inputs = self._law_inputs(rig_document, component, back_pressure_pa, temperature_c)
        table = CalibrationTable(component,  # type: ignore[arg-type]
                                 (CalibrationRow("row", 0.0, bypass_flow_m3s),),
                                 back_pressure_pa, temperature_c)
        equivalence = clearances_from_law(table, **inputs)
        return float(equivalence.clearances[0])
