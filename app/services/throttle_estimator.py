"""The clearance estimator of the service: :mod:`diagnostics.throttle` on the rig's model.

A throttle equivalence row gives a bypass flow at a back-pressure and an oil temperature;
its equivalent clearance is the clearance whose leakage law (paper 002 eq. 36 for the
piston, eq. 23 for the spool) passes that flow at the rig's operating point of that
condition (:func:`diagnostics.throttle.clearances_from_law` with the inputs of
:func:`diagnostics.throttle.law_inputs`, which says how the operating point is found).

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
from diagnostics.throttle import (
    CalibrationRow,
    CalibrationTable,
    clearances_from_law,
    law_inputs,
)
from sim.errors import InputError

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
        self._points: OrderedDict[tuple[str, str, float, float],
                                  tuple[dict[str, float], float]] = OrderedDict()
        self._lock = threading.Lock()

    def _law_inputs(self, document: Mapping[str, Any], component: str, back_pressure_pa: float,
                    temperature_c: float) -> tuple[dict[str, float], float]:
        """:func:`diagnostics.throttle.law_inputs` of the document's compiled rig, cached
        per (document, component, condition)."""
        key = (document_digest(document), component, back_pressure_pa, temperature_c)
        with self._lock:
            cached = self._points.get(key)
        if cached is not None:
            return cached
        found = law_inputs(self._rigs.get(document), component,  # type: ignore[arg-type]
                           back_pressure_pa, temperature_c)
        with self._lock:
            self._points[key] = found
            while len(self._points) > 64:
                self._points.popitem(last=False)
        return found

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
