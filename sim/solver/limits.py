"""Bounds on the work of one integration (issue 16 item 3, issue 17)."""

from __future__ import annotations

import time
from dataclasses import dataclass

__all__ = ["SolverLimits"]


@dataclass(frozen=True)
class SolverLimits:
    """What one integration may spend before it stops with :class:`~sim.errors.SolverLimitError`.

    Attributes
    ----------
    max_steps
        Most solver steps (accepted + rejected) of one integration call [-].  Enforced
        inside the compiled step loop.
    max_sim_time
        Longest simulated time span of one integration [s].
    wall_clock
        Wall-clock budget [s]; ``None``: unbounded.  Checked between chunks of
        :attr:`chunk_steps` compiled steps (the compiled loop cannot read a clock), so a run
        overshoots the budget by at most one chunk (a few ms on the rigs).
    chunk_steps
        Steps per compiled call between two wall-clock checks [-].
    """

    max_steps: int = 2_000_000
    max_sim_time: float = 600.0
    wall_clock: float | None = None
    chunk_steps: int = 5_000

    def deadline(self) -> float | None:
        """``time.perf_counter()`` value at which the budget is spent, from now [s]."""
        return None if self.wall_clock is None else time.perf_counter() + self.wall_clock
