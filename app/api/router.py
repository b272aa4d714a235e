"""All routes of the API, assembled: one module per resource in ``app/api/routes``.

* ``ops`` — ``/health``, ``/ready``, ``/metrics``;
* ``rigs``, ``calibrations`` — rig documents and their throttle equivalence tables;
* ``commission`` — ``POST /rigs/{rig_id}/commission``: fit a rig to healthy records;
* ``rediagnose`` — ``POST /rigs/{rig_id}/rediagnose``: stored records diagnosed again
  against the latest version, as a job (:mod:`app.services.rediagnosis`);
* ``pumps`` — pump parameter sets, loss maps and parameterisation from a bench CSV;
* ``diagnose`` — ``POST /diagnose`` over :mod:`app.services.diagnosis`;
* ``simulate`` — ``POST /simulate`` over :mod:`app.services.simulation`;
* ``scenarios`` — ``POST /scenarios``: sweeps as jobs (:mod:`app.services.sweeps`);
* ``series`` — measured time series of a rig (:mod:`app.services.series`);
* ``trends`` — ``GET /rigs/{rig_id}/trends`` over :mod:`app.services.trends`;
* ``discrepancy`` — ``POST /discrepancy``: the discrepancy workflow as a job;
* ``jobs`` — status, progress and results of long work;
* ``history`` — stored measurements and diagnoses read back.

Every operation but those of ``ops`` refuses a query parameter it does not read
(:mod:`app.api.query_check`).
"""

from __future__ import annotations

from fastapi import APIRouter, Depends

from app.api.query_check import known_query
from app.api.routes import (
    calibrations,
    commission,
    diagnose,
    discrepancy,
    history,
    jobs,
    ops,
    pumps,
    rediagnose,
    rigs,
    scenarios,
    series,
    simulate,
    trends,
)

__all__ = ["api_router"]

api_router = APIRouter()
api_router.include_router(ops.router)  # no parameters, and /health must cost nothing
# POST /diagnose, the hot path, next: FastAPI matches a request against the routes in this
# order (twice a request), and behind the ~30 routes of the resources its match cost 83-157
# µs, 19-20 µs first (~0.13-0.27 ms of the server process's CPU a diagnosis; issue 9); the
# API document lists it there too
for _module in (diagnose, rigs, commission, rediagnose, calibrations, trends, pumps, series,
                simulate, scenarios, discrepancy, jobs, history):
    api_router.include_router(_module.router, dependencies=[Depends(known_query)])
