"""Start-up warming: compile the stored rigs before the service reports ready.

A fresh process compiles (or loads from the code cache) each rig's model on its first
request.  :class:`Warmup` does that once at start-up for the rigs the service serves — the
latest version of each stored rig, newest first, as many as the rig cache holds — and runs
one steady operating point and a millisecond of each transient solver (RODAS4, ROS2) on
each, so that every compiled function has been called once (loaded from the code cache,
or compiled on a machine's first start).  A rig without a working/return cycle (the ZeMA
rig's circuit) is loaded only: nothing a diagnosis or a cycle would run exists for it.
``/ready`` answers 503 until it has finished, so a load balancer sends no traffic to a
worker that is still loading.
"""

from __future__ import annotations

import gc
import logging
import threading
import time
from collections.abc import Callable, Sequence

from sqlalchemy import select

from app.db.engine import SessionFactory
from app.db.models import Rig as RigRow
from app.services.rig_cache import ResolvedRig, RigCache
from sim.cycle import phase_params
from sim.errors import HydrodiagError
from sim.rigs import Rig
from sim.steady import steady_cycle

__all__ = ["Warmup"]


def _touch_transient_solvers(rig: Rig) -> None:
    """Call each compiled transient solver once on ``rig`` (a millisecond from rest)."""
    p = phase_params(rig, "working", None, rig.default_condition())
    y0 = rig.model.initial_state(p)
    for method in ("rodas4", "ros2"):
        rig.model.integrate(y0, p, 1e-3, method=method)

logger = logging.getLogger("hydrodiag.app")


class Warmup:
    """Loads the stored rigs in a background thread; ``done`` once all are loaded.

    Parameters
    ----------
    sessions
        Session factory of the store.
    rigs
        The application's cache of compiled rigs, filled here.
    limit
        Largest number of rigs loaded [-] (the cache's size: more would be evicted).
    then
        Called with the loaded rigs before ``done`` is set (the diagnosis workers warm
        them: :meth:`app.services.diagnosis_pool.DiagnosisPool.warm`).
    """

    def __init__(self, sessions: SessionFactory, rigs: RigCache, limit: int,
                 then: Callable[[Sequence[ResolvedRig]], None] | None = None) -> None:
        self._sessions = sessions
        self._rigs = rigs
        self._limit = limit
        self._then = then
        self._done = threading.Event()
        self.loaded: list[int] = []
        self.failed: dict[int, str] = {}
        self.seconds = 0.0
        self._thread = threading.Thread(target=self._run, name="hydrodiag-warmup",
                                        daemon=True)

    @property
    def done(self) -> bool:
        """Whether every rig has been loaded (or has failed to load, logged)."""
        return self._done.is_set()

    def start(self) -> None:
        """Start loading in the background."""
        self._thread.start()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until loading has finished or ``timeout`` [s] passed; return ``done``."""
        return self._done.wait(timeout)

    def _run(self) -> None:
        started = time.perf_counter()
        try:
            with self._sessions() as session:
                ids = list(session.scalars(
                    select(RigRow.id).order_by(RigRow.updated_at.desc(), RigRow.id.desc())
                    .limit(self._limit)))
                warmed: list[ResolvedRig] = []
                for rig_id in ids:
                    try:
                        resolved = self._rigs.get(session, rig_id)
                        if not resolved.rig.circuit.cycle:  # nothing a diagnosis would run
                            self.loaded.append(rig_id)
                            continue
                        steady_cycle(resolved.rig)
                        _touch_transient_solvers(resolved.rig)
                    except HydrodiagError as exc:  # a rig that cannot run still serves 422s
                        self.failed[rig_id] = str(exc)
                        logger.warning("rig %d not warmed: %s", rig_id, exc)
                    else:
                        self.loaded.append(rig_id)
                        warmed.append(resolved)
            if self._then is not None:
                self._then(warmed)
        except Exception:  # never leave the service unready for ever
            logger.exception("warming the rigs failed")
        finally:
            self.seconds = time.perf_counter() - started
            logger.info("rigs loaded: %d in %.1f s", len(self.loaded), self.seconds)
            settle_heap()
            self._done.set()


def settle_heap() -> None:
    """Move what start-up made (modules, compiled rigs, the app) out of the garbage
    collector's sight (``gc.freeze``): a full collection traversed all of it, holding the
    interpreter for ~170 ms while a trends request allocated its rows, and ``/health`` p99
    rose to ~200 ms under two readers of trends (30 ms with the collector off; an operator
    pass).  Objects made later are collected as before."""
    gc.collect()
    gc.freeze()
