"""What a process's control group lets it use: CPU (its affinity and the group's CPU quota)
and memory (the group's limit).

A container limited with ``docker run --cpus=2`` or a Kubernetes CPU limit may run on every
core of its host (its affinity is the host's) but gets only 2 cores' worth of CPU time a
period: the kernel's CFS quota, ``cpu.max`` (cgroup v2: ``"200000 100000"``, quota and
period in µs, or ``"max …"``) or ``cpu.cfs_quota_us`` / ``cpu.cfs_period_us`` (cgroup v1,
quota −1 for none).  Counting the affinity alone, ``hydrodiag serve`` in a 2-CPU container
on a 64-core host started 64 server workers, each with its diagnosis process (0.2-0.3 GiB
each), and each worker's first sweep a pool of 64 processes more, all sharing two cores'
worth of time (a deployment pass).  :func:`usable_cores` counts both: the
affinity, and the quota rounded down (a worker more than the quota pays for is throttled
by the kernel for the rest of each 100 ms period, a latency spike no load test on a
quiet machine shows), at least 1.

The memory limit (``memory.max``; v1 ``memory.limit_in_bytes``) is not divided among
workers here: :func:`memory_warning` says, when ``serve`` starts, that the processes it
starts (and its sweeps start) need about as much as the limit or more — an out-of-memory
kill of a worker said nothing in the service's log.

Limits are read along the process's own control group and each of its parents, the
smallest counting (a limit set on a parent — a Kubernetes pod's — binds its children); the
group is found from ``/proc/self/cgroup`` and where its hierarchy is mounted from
``/proc/self/mountinfo``.  Anything unreadable counts as no limit.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path

__all__ = ["DIAGNOSIS_MIB", "SUPERVISOR_MIB", "SWEEP_MIB", "WORKER_MIB", "cgroup_cpu_limit",
           "cgroup_memory_limit", "memory_warning", "usable_cores"]

PROC = Path("/proc/self")
#: memory of ``serve``'s processes, their proportional set size (shared pages split among
#: the processes that share them) in a ready 2-worker service on the reference rig,
#: measured 2026-12-01: the supervisor, a server worker, a diagnosis process, and a process
#: of a worker's sweep pool after a transient sweep [MiB] (``make serve-memory`` prints
#: them beside what it measures)
SUPERVISOR_MIB = 23
WORKER_MIB = 257
DIAGNOSIS_MIB = 234
SWEEP_MIB = 115
#: a v1 memory limit this large or larger is none (the kernel writes LONG_MAX rounded to a
#: page) [byte]
_NO_V1_LIMIT = 2**62


def _mounts(mountinfo: str) -> list[tuple[str, str, str, set[str]]]:
    """(root, mount point, file system type, super options) of each cgroup mount."""
    out = []
    for line in mountinfo.splitlines():
        fields, sep, rest = line.partition(" - ")
        parts, tail = fields.split(), rest.split()
        if not sep or len(parts) < 5 or len(tail) < 3 or not tail[0].startswith("cgroup"):
            continue
        out.append((parts[3], parts[4], tail[0], set(tail[2].split(","))))
    return out


def _groups(cgroup: str) -> list[tuple[set[str], str]]:
    """(controllers, path) of each line of ``/proc/self/cgroup`` (v2: no controllers)."""
    out = []
    for line in cgroup.splitlines():
        parts = line.split(":", 2)
        if len(parts) == 3:
            out.append((set(filter(None, parts[1].split(","))), parts[2]))
    return out


def _levels(mount_point: str, root: str, path: str) -> list[Path]:
    """The group's folder under its mount and each parent up to the mount point."""
    if root != "/" and (path == root or path.startswith(root.rstrip("/") + "/")):
        path = path[len(root):]
    elif root != "/":
        path = ""  # a group outside the mounted root (a container's namespace): its root
    here = Path(mount_point, path.lstrip("/"))
    top = Path(mount_point)
    levels = [here]
    while here != top and top in here.parents:
        here = here.parent
        levels.append(here)
    return levels


def _number(path: Path) -> int | None:
    try:
        return int(path.read_text())
    except (OSError, ValueError):
        return None


def _cpus_v2(folder: Path) -> float | None:
    try:  # "quota period", the quota "max" for none
        quota, period = (folder / "cpu.max").read_text().split()[:2]
        q = None if quota == "max" else int(quota)
        p = int(period)
    except (OSError, ValueError):
        return None
    return q / p if q is not None and q > 0 and p > 0 else None


def _cpus_v1(folder: Path) -> float | None:
    q, p = _number(folder / "cpu.cfs_quota_us"), _number(folder / "cpu.cfs_period_us")
    return q / p if q is not None and p is not None and q > 0 and p > 0 else None


def _bytes_v2(folder: Path) -> float | None:
    limit = _number(folder / "memory.max")  # "max": no limit, not a number
    return float(limit) if limit is not None and limit > 0 else None


def _bytes_v1(folder: Path) -> float | None:
    limit = _number(folder / "memory.limit_in_bytes")
    return float(limit) if limit is not None and 0 < limit < _NO_V1_LIMIT else None


def _smallest(proc: Path, controller: str, read_v2: Callable[[Path], float | None],
              read_v1: Callable[[Path], float | None]) -> float | None:
    """The smallest limit along this process's group and its parents, of cgroup v2 and of
    the v1 hierarchy of ``controller`` (module docstring); None without one."""
    try:
        mounts = _mounts((proc / "mountinfo").read_text())
        groups = _groups((proc / "cgroup").read_text())
    except OSError:
        return None
    limits = []
    for root, point, fstype, options in mounts:
        for controllers, path in groups:
            if fstype == "cgroup2" and not controllers:
                read = read_v2
            elif fstype == "cgroup" and controller in options and controller in controllers:
                read = read_v1
            else:
                continue
            limits += [x for x in map(read, _levels(point, root, path)) if x is not None]
    return min(limits) if limits else None


def cgroup_cpu_limit(proc: Path = PROC) -> float | None:
    """The CPU quota of this process's control group [CPUs]: quota / period, the smallest
    along the group and its parents; None without one (or where it cannot be read).

    ``proc``: the folder holding ``mountinfo`` and ``cgroup`` (``/proc/self``).
    """
    return _smallest(proc, "cpu", _cpus_v2, _cpus_v1)


def cgroup_memory_limit(proc: Path = PROC) -> int | None:
    """The memory limit of this process's control group [byte], the smallest along the
    group and its parents; None without one (or where it cannot be read)."""
    limit = _smallest(proc, "memory", _bytes_v2, _bytes_v1)
    return None if limit is None else int(limit)


def memory_warning(workers: int, diagnosis_processes: int, sweep_processes: int,
                   proc: Path = PROC) -> str | None:
    """What ``serve`` logs when ``workers`` server workers, each with
    ``diagnosis_processes`` diagnosis processes and, while it runs a sweep, its pool of
    ``sweep_processes`` processes, need about 90 % of the group's memory limit or more
    (:data:`SUPERVISOR_MIB`, :data:`WORKER_MIB`, :data:`DIAGNOSIS_MIB`,
    :data:`SWEEP_MIB`); None otherwise, and without a limit."""
    limit = cgroup_memory_limit(proc)
    if limit is None:
        return None
    warm = (SUPERVISOR_MIB if workers > 1 else 0) + workers * (
        WORKER_MIB + diagnosis_processes * DIAGNOSIS_MIB)
    sweeping = warm + workers * sweep_processes * SWEEP_MIB
    have = limit / 2**20
    if sweeping < 0.9 * have:
        return None
    return (f"the memory limit of this service's control group (a container's) is "
            f"{have:.0f} MiB, and {workers} server worker(s) with {diagnosis_processes} "
            f"diagnosis process(es) each take about {warm} MiB once warm, {sweeping} MiB "
            f"while each runs a sweep on its {sweep_processes} process(es): the kernel will "
            "kill processes of the service when they outgrow it; set HYDRODIAG_WORKERS (or "
            "HYDRODIAG_DIAGNOSIS_PROCESSES, HYDRODIAG_SWEEP_WORKERS) lower or raise the "
            "limit")


def usable_cores(proc: Path = PROC) -> int:
    """Cores' worth of CPU this process may use [-] (module docstring): its affinity, and
    its control group's quota rounded down, at least 1."""
    cores = (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
             else os.cpu_count() or 1)
    limit = cgroup_cpu_limit(proc)
    if limit is not None:
        cores = min(cores, math.floor(limit))
    return max(1, cores)
