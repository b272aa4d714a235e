"""All routes of the API, assembled: one module per resource in ``app/api/routes``.

* ``ops`` — ``/health``, ``/ready``, ``/metrics``;
* ``rigs``, ``calibrations`` — rig documents and their throttle equivalence tables;
* ``pumps`` — pump parameter sets, loss maps and parameterisation from a bench CSV;
* ``diagnose`` — ``POST /diagnose`` over :mod:`app.services.diagnosis`;
* ``simulate`` — ``POST /simulate`` over :mod:`app.services.simulation`;
* ``scenarios`` — ``POST /scenarios``: sweeps as jobs (:mod:`app.services.sweeps`);
* ``trends`` — ``GET /rigs/{rig_id}/trends`` over :mod:`app.services.trends`;
* ``discrepancy`` — ``POST /discrepancy``: the discrepancy workflow as a job;
* ``jobs`` — status, progress and results of long work.
"""

from __future__ import annotations

from fastapi import APIRouter

from app.api.routes import (
    calibrations,
    diagnose,
    discrepancy,
    jobs,
    ops,
    pumps,
    rigs,
    scenarios,
    simulate,
    trends,
)

__all__ = ["api_router"]

api_router = APIRouter()
for _module in (ops, rigs, calibrations, trends, pumps, diagnose, simulate, scenarios,
                discrepancy, jobs):
    api_router.include_router(_module.router)
