"""Real measured data study (issue 12): pump leakage on the ZeMA rig, no label used in fitting.

ZeMA part in :mod:`benchmarks.real_zema`, map part in :mod:`benchmarks.real_pump_map`.

Reads ``data/real/uci-hydraulic-zema/`` of the shared data (``HYDRODIAG_SHARED``, else
``../shared``, else ``/work/shared``), imports every cycle through the import path
(:mod:`diagnostics.real.zema`), estimates the extra leakage conductance per cycle
(:mod:`diagnostics.real.leakage`) and scores it against the labels.  Also printed: the
viscosity-normalised baseline ``G·μ(θ)`` (what paper 000 eq. 6 with Cs = G·μ/D would track),
and change points of the estimate over the cycles against the leakage label's switches.

The V32HL56 piston-pump map (``data/real/pump-efficiency-V32HL56/``): per displacement
setting, the derived capacity (intercept, Toet, Vimax; one temperature, assumed), the
piston loss family (:mod:`diagnostics.pump.piston`) with one speed left out at a time next to
a plain quadratic in (Δp, n), with the flow loss fitted to Qth − QOut and to the measured
case-drain flow.  The discrepancy workflow on each setting as a bench table and on the ZeMA
plateaus as bench tables (:mod:`benchmarks.real_discrepancy`).

``HYDRODIAG_LIGHT=1``: every 4th cycle; the map in full (it is small).
Run: ``make real-data``.  Last line: JSON.
"""

from __future__ import annotations

import json
import os

from benchmarks import real_discrepancy, real_pump_map
from benchmarks.real_zema import zema


def pump_map() -> dict[str, object]:
    """The V32HL56 part (:mod:`benchmarks.real_pump_map`): print its tables, return figures."""
    return real_pump_map.pump_map()


def main() -> None:
    """Run the study and print the tables and the JSON line."""
    light = os.environ.get("HYDRODIAG_LIGHT") == "1"
    figures = zema(light)
    figures["pump_map"] = pump_map()
    figures["pump_discrepancy"] = real_discrepancy.pump_discrepancy()
    figures["zema_discrepancy"] = real_discrepancy.zema_discrepancy(light)
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
