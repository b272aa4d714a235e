"""The CPUs a process may use: its CPU affinity, and the CPU quota of its control group.

A container limited with ``docker run --cpus=2`` or a Kubernetes CPU limit may run on every
core of its host (its affinity is the host's) but gets only 2 cores' worth of CPU time a
period: the kernel's CFS quota, ``cpu.max`` (cgroup v2: ``"200000 100000"``, quota and
period in µs, or ``"max …"``) or ``cpu.cfs_quota_us`` / ``cpu.cfs_period_us`` (cgroup v1,
quota −1 for none).  Counting the affinity alone, ``hydrodiag serve`` in a 2-CPU container
on a 64-core host started 64 server workers, each with its diagnosis process and its
sweep pool of one process per core — some 200 processes of 0.4-0.5 GB each sharing two
cores' worth of time (an operator's pass).  :func:`usable_cores` counts both: the
affinity, and the quota rounded down (a worker more than the quota pays for is throttled
by the kernel for the rest of each 100 ms period, a latency spike no load test on a
quiet machine shows), at least 1.

The quota is read along the process's own control group and each of its parents, the
smallest counting (a limit set on a parent — a Kubernetes pod's — binds its children); the
group is found from ``/proc/self/cgroup`` and where its hierarchy is mounted from
``/proc/self/mountinfo``.  Anything unreadable counts as no quota.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

__all__ = ["cgroup_cpu_limit", "usable_cores"]

PROC = Path("/proc/self")


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


def _v2_limit(folder: Path) -> float | None:
    try:
        quota, period = (folder / "cpu.max").read_text().split()[:2]
    except (OSError, ValueError):
        return None
    if quota == "max":
        return None
    try:
        q, p = int(quota), int(period)
    except ValueError:
        return None
    return q / p if q > 0 and p > 0 else None


def _v1_limit(folder: Path) -> float | None:
    try:
        q = int((folder / "cpu.cfs_quota_us").read_text())
        p = int((folder / "cpu.cfs_period_us").read_text())
    except (OSError, ValueError):
        return None
    return q / p if q > 0 and p > 0 else None


def cgroup_cpu_limit(proc: Path = PROC) -> float | None:
    """The CPU quota of this process's control group [CPUs]: quota / period, the smallest
    along the group and its parents; None without one (or where it cannot be read).

    ``proc``: the folder holding ``mountinfo`` and ``cgroup`` (``/proc/self``).
    """
    try:
        mounts = _mounts((proc / "mountinfo").read_text())
        groups = _groups((proc / "cgroup").read_text())
    except OSError:
        return None
    limits = []
    for root, point, fstype, options in mounts:
        for controllers, path in groups:
            if fstype == "cgroup2" and not controllers:
                read = _v2_limit
            elif fstype == "cgroup" and "cpu" in options and "cpu" in controllers:
                read = _v1_limit
            else:
                continue
            limits += [x for x in map(read, _levels(point, root, path)) if x is not None]
    return min(limits) if limits else None


def usable_cores(proc: Path = PROC) -> int:
    """Cores' worth of CPU this process may use [-] (module docstring): its affinity, and
    its control group's quota rounded down, at least 1."""
    cores = (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
             else os.cpu_count() or 1)
    limit = cgroup_cpu_limit(proc)
    if limit is not None:
        cores = min(cores, math.floor(limit))
    return max(1, cores)
