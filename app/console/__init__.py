"""The web console: server-rendered pages under ``/console`` on the service's own store.

Pages are Jinja2 templates (``templates/``) with one stylesheet (``static/``) and no
script; plots are inline SVG from :mod:`diagnostics.plots`.  See :mod:`app.console.web`
for the login and the security headers.
"""

from __future__ import annotations

from fastapi import APIRouter

from app.console import pages_diagnose, pages_pumps, pages_rigs, pages_series, pages_simulate

__all__ = ["router"]

router = APIRouter()
router.include_router(pages_rigs.router)
router.include_router(pages_diagnose.router)
router.include_router(pages_simulate.router)
router.include_router(pages_series.router)
router.include_router(pages_pumps.router)
router.include_router(pages_rigs.unknown)   # last: any other /console path
