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
"""

from __future__ import annotations

import ctypes
import ctypes.util
from functools import cache
from typing import Any

__all__ = ["trim_heap"]


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
