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
from diagnostics.measurement import MIN_PRESSURE_READING
from diagnostics.throttle import CalibrationRow, CalibrationTable, clearances_from_law
from sim.errors import InputError, ParameterError, SimulationError
from sim.rigs import Condition
from sim.steady import steady_cycle

__all__ = ["ThrottleClearanceEstimator"]

_COMPONENTS = ("cylinder", "valve")
#: smallest back-pressure of a table other than 0 [Pa]: 0.1 bar, below what a load control
#: valve is set to; a smaller one is a unit slip (bar typed as Pa)
MIN_BACK_PRESSURE_PA = MIN_PRESSURE_READING


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
        self._points: OrderedDict[tuple[str, str, float, float],
                                  tuple[dict[str, float], float]] = OrderedDict()
        self._lock = threading.Lock()

    def _law_inputs(self, document: Mapping[str, Any], component: str, back_pressure_pa: float,
                    temperature_c: float) -> tuple[dict[str, float], float]:
        """The leakage law's inputs at the condition's operating point, and the pump's
        delivery ω·Vp [m³/s]."""
        key = (document_digest(document), component, back_pressure_pa, temperature_c)
        with self._lock:
            cached = self._points.get(key)
        if cached is not None:
            return cached
        if 0.0 < back_pressure_pa < MIN_BACK_PRESSURE_PA:
            # 10 "Pa" meant 10 bar: a closed row of 56.7 µm on a 34 µm spool was stored
            # (a check of the technician's fix); 0 stays: a table taken without a load
            raise InputError(
                f"a back-pressure of {back_pressure_pa:g} Pa ({back_pressure_pa / 1e5:g} bar) "
                "is no load a rig applies: it is in Pa (bar × 100,000); 0 for no load",
                field="back_pressure_pa")
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
        except ParameterError as exc:
            # the condition the table states, named as the table names it (a 180 °C
            # table's 422 named condition.oil_temperature, a field it does not have)
            field = {"condition.oil_temperature": "temperature_c",
                     "condition.force": "back_pressure_pa"}.get(exc.field or "", exc.field)
            raise InputError(exc.message, field=field) from None
        if not working["speed"] > 0.0:
            # a stalled piston (the relief valve open) stored clearances from a leak
            # law at an operating point the calibration cannot have had (a technician)
            raise InputError(
                f"at {back_pressure_pa / 1e5:g} bar (a load of "
                f"{condition.load / 1e3:.3g} kN on the annulus) the rig's piston does not "
                "move in the working phase (the relief valve opens first): a throttle table "
                "is taken with the piston moving (paper 002 §2.7)", field="back_pressure_pa")
        delivery = values["pump.speed"] * values["pump.Vp"]
        mu = rig.fluid.dynamic_viscosity(temperature_c)
        if component == "cylinder":
            inputs = {"dp": working["P1"] - working["P2"], "mu": mu, "D": values["cylinder.bore"],
                      "L": values["cylinder.Lc"], "velocity": working["speed"]}
        else:
            inputs = {"dp": working["P_valve_P"] - values["valve.PRvt"], "mu": mu,
                      "D": values["valve.Dv"], "L": values["valve.Ls"], "velocity": 0.0}
        with self._lock:
            self._points[key] = (inputs, delivery)
            while len(self._points) > 64:
                self._points.popitem(last=False)
        return inputs, delivery

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
            A component other than ``cylinder`` or ``valve``, no operating point, a piston
            that does not move at the condition, or a flow above the pump's delivery.
        """
        if component not in _COMPONENTS:
            raise InputError(f"no leakage law for component {component!r} (known: "
                             f"{', '.join(_COMPONENTS)})", field="component")
        inputs, delivery = self._law_inputs(rig_document, component, back_pressure_pa,
                                            temperature_c)
        if bypass_flow_m3s >= delivery:
            # flows typed in l/min or l/s were stored as 1.3-1.6 mm clearances (a technician)
            raise InputError(
                f"a bypass flow of {bypass_flow_m3s:g} m³/s ({bypass_flow_m3s * 6e4:.4g} l/min) "
                f"is more than the rig's pump delivers ({delivery:.3g} m³/s, "
                f"{delivery * 6e4:.3g} l/min): flows are in m³/s (l/min ÷ 60,000)",
                field="bypass_flow_m3s")
        table = CalibrationTable(component,  # type: ignore[arg-type]
                                 (CalibrationRow("row", 0.0, bypass_flow_m3s),),
                                 back_pressure_pa, temperature_c)
        equivalence = clearances_from_law(table, **inputs)
        return float(equivalence.clearances[0])
