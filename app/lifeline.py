"""Processes that leave with their parent: server workers and diagnosis workers.

``hydrodiag serve`` with several workers is a supervisor process and its uvicorn workers;
each worker has diagnosis processes of its own.  Killed with SIGKILL, the supervisor
cannot stop its children, which would go on serving (and holding memory) as orphans.
:func:`exit_with_parent` makes a child end itself once its parent is gone.
"""

from __future__ import annotations

import os
import threading
import time

__all__ = ["PARENT_CHECK_S", "exit_with_parent"]

#: How often a child checks that its parent is still there [s].
PARENT_CHECK_S = 0.5


def _watch(parent: int, interval: float) -> None:
    while os.getppid() == parent:
        time.sleep(interval)
    os._exit(1)  # the parent is gone (kill -9 included): nothing left to serve


def exit_with_parent(parent: int | None = None, interval: float = PARENT_CHECK_S) -> None:
    """End this process (exit status 1) within ``interval`` [s] of its parent's end.

    Parameters
    ----------
    parent
        Process id of the parent to watch; the current parent when ``None``.
    interval
        Time between two checks [s].
    """
    watched = os.getppid() if parent is None else parent
    threading.Thread(target=_watch, args=(watched, interval), daemon=True,
                     name="hydrodiag-lifeline").start()
