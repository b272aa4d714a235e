"""Give the memory a finished job freed back to the system.

A job (a sweep, a discrepancy check) runs in a thread of the server process and allocates
its tables and arrays there — tens of MB in many blocks below glibc's ``mmap`` threshold,
so from that thread's malloc arena.  Freed, they stay in the arena: the process's resident
memory keeps the high-water mark of every job that ran, and one arena per job thread
keeps its own.  In a 10-minute soak run (``make soak``, 2,409 requests, 18 jobs) the
server worker that served them grew from 396 to 614 MiB, 50 MiB per 1,000 requests over
the run, while Python's own heap (``tracemalloc``, the same workload in one process) grew
by at most 1.4 MiB per 1,000 requests (the traced total, its own snapshots included).
:func:`trim_heap` asks glibc to return the free memory at the top of each arena and the
whole free pages inside it (``malloc_trim(0)``), which the job runner does after each
job (:meth:`app.services.jobs.JobRunner.submit`).  Elsewhere than glibc it does nothing.

The trim returns what a job freed, not what the request threads' arenas keep (glibc makes
up to eight arenas per core, one per thread that meets a locked one): with it, the worker
that served a 10-minute soak still grew +10.5 MiB per 1,000 requests over the second half
of the run.  ``hydrodiag serve`` therefore starts its processes with at most
:data:`MALLOC_ARENAS` arenas (``MALLOC_ARENA_MAX``, unless the environment sets it;
:func:`limit_arenas`): the same soak, late slope −3.8 MiB per 1,000 requests, the busy
worker 396 → 472 MiB where it grew 395 → 570 (one 10-minute run each, the machine at load
5-8).  The diagnosis itself runs in processes of its own, one thread each, and the server's
threads hold the GIL while they allocate Python objects, so fewer arenas cost no
contention worth measuring.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
from functools import cache
from typing import Any

__all__ = ["MALLOC_ARENAS", "limit_arenas", "trim_heap"]

#: glibc malloc arenas of each process ``serve`` starts (``MALLOC_ARENA_MAX``) [-]
MALLOC_ARENAS = 2


@cache
def _libc() -> Any:
    name = ctypes.util.find_library("c")
    if name is None:
        return None
    try:
        libc = ctypes.CDLL(name)
        trim = libc.malloc_trim
    except (OSError, AttributeError):  # not glibc (musl, macOS): nothing to trim
        return None
    trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return trim


def trim_heap(_: object = None) -> bool:
    """Return the heap's free memory to the system (glibc's ``malloc_trim(0)``); whether
    any was returned.  Takes and ignores one argument, so it can be a future's done
    callback."""
    trim = _libc()
    return bool(trim(0)) if trim is not None else False


def limit_arenas() -> str:
    """Set ``MALLOC_ARENA_MAX`` to :data:`MALLOC_ARENAS` for the processes started from now
    on (server workers, diagnosis processes, the sweep pool: glibc reads it when a process
    starts), unless the environment sets it; return the value in effect.  The process that
    calls it has its arenas already; ``serve`` calls it before it replaces itself with
    :mod:`app.supervisor`, which starts afresh with it, one worker or several (the
    Dockerfile sets the variable for the whole container)."""
    return os.environ.setdefault("MALLOC_ARENA_MAX", str(MALLOC_ARENAS))
