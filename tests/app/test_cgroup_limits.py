"""What a process's control group lets it use — the CPU quota and the memory limit — read as
the kernel lays them out (``/proc/self/mountinfo``, ``/proc/self/cgroup`` and the limits'
files), here built in a folder: a cgroup v2 container, a v2 host hierarchy whose parent
holds the limit, a v1 container, and the unlimited and unreadable cases."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from app.cgroup_limits import (
    DIAGNOSIS_MIB,
    SUPERVISOR_MIB,
    SWEEP_MIB,
    WORKER_MIB,
    cgroup_cpu_limit,
    cgroup_memory_limit,
    memory_warning,
    usable_cores,
)
from app.settings import Settings


def _proc(tmp_path: Path, mountinfo: str, cgroup: str) -> Path:
    proc = tmp_path / "proc"
    proc.mkdir()
    (proc / "mountinfo").write_text(mountinfo)
    (proc / "cgroup").write_text(cgroup)
    return proc


def _write(folder: Path, **files: str) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (folder / name.replace("_", ".", 1)).write_text(text + "\n")


def _v2(tmp_path: Path, group: str = "/") -> tuple[Path, Path]:
    mount = tmp_path / "cgroup"
    mount.mkdir()
    proc = _proc(tmp_path,
                 f"25 30 0:22 / /proc rw - proc proc rw\n"
                 f"31 23 0:28 / {mount} rw,nosuid - cgroup2 cgroup2 rw,nsdelegate\n",
                 f"0::{group}\n")
    return proc, mount


@pytest.mark.parametrize(("cpu_max", "limit", "cores"), [
    ("200000 100000", 2.0, 2), ("100000 100000", 1.0, 1), ("150000 100000", 1.5, 1),
    ("50000 100000", 0.5, 1), ("max 100000", None, None)])
def test_a_cgroup_v2_containers_quota(tmp_path: Path, cpu_max: str, limit: float | None,
                                      cores: int | None) -> None:
    proc, mount = _v2(tmp_path)
    _write(mount, cpu_max=cpu_max)
    assert cgroup_cpu_limit(proc) == limit
    affinity = len(os.sched_getaffinity(0))
    # the quota rounded down binds below the affinity; at least one core
    assert usable_cores(proc) == (affinity if cores is None else min(affinity, cores))


def test_a_limit_on_a_parent_group_binds_its_children(tmp_path: Path) -> None:
    """A Kubernetes pod's limit is set on the pod's group, the container's own says max."""
    proc, mount = _v2(tmp_path, "/kubepods/pod1/ctr")
    _write(mount / "kubepods", cpu_max="max 100000")
    _write(mount / "kubepods" / "pod1", cpu_max="150000 100000")
    _write(mount / "kubepods" / "pod1" / "ctr", cpu_max="max 100000")
    assert cgroup_cpu_limit(proc) == 1.5
    _write(mount / "kubepods" / "pod1" / "ctr", cpu_max="50000 100000")  # the smallest
    assert cgroup_cpu_limit(proc) == 0.5
    assert usable_cores(proc) == 1


def test_a_cgroup_v1_containers_limits(tmp_path: Path) -> None:
    """Docker on cgroup v1 without a group namespace: the container's group is the mount's
    root (``/docker/<id>``), mounted at the controller's folder."""
    mount, memory = tmp_path / "cpu,cpuacct", tmp_path / "memory"
    proc = _proc(tmp_path,
                 f"40 31 0:35 /docker/abc {mount} ro,nosuid - cgroup cgroup rw,cpu,cpuacct\n"
                 f"41 31 0:36 /docker/abc {memory} ro - cgroup cgroup rw,memory\n",
                 "5:memory:/docker/abc\n4:cpu,cpuacct:/docker/abc\n0::/\n")
    _write(mount, cpu_cfs_quota_us="300000", cpu_cfs_period_us="100000")
    _write(memory, memory_limit_in_bytes=str(2 * 2**30))
    assert cgroup_cpu_limit(proc) == 3.0 and cgroup_memory_limit(proc) == 2 * 2**30
    _write(mount, cpu_cfs_quota_us="-1")  # no quota; no memory limit: LONG_MAX in pages
    _write(memory, memory_limit_in_bytes="9223372036854771712")
    assert cgroup_cpu_limit(proc) is None and cgroup_memory_limit(proc) is None


def test_serve_warns_when_its_processes_outgrow_the_memory_limit(tmp_path: Path) -> None:
    """2 CPUs and 1 GiB, a common container size: 2 workers with their diagnosis processes
    take about 1 GiB once warm, more while they sweep, and an out-of-memory kill said
    nothing in the log."""
    proc, mount = _v2(tmp_path, "/kubepods/pod1")
    _write(mount / "kubepods", memory_max="max")
    _write(mount / "kubepods" / "pod1", memory_max=str(2**30))
    assert cgroup_memory_limit(proc) == 2**30
    said = memory_warning(2, 1, 2, proc)
    warm = SUPERVISOR_MIB + 2 * (WORKER_MIB + DIAGNOSIS_MIB)
    assert said is not None and "is 1024 MiB, and 2 server worker(s)" in said
    assert f"about {warm} MiB once warm, {warm + 4 * SWEEP_MIB} MiB while each runs a " \
        "sweep on its 2 process(es)" in said and "HYDRODIAG_WORKERS" in said
    assert memory_warning(1, 1, 2, proc) is None  # one worker: about 70 % of it
    _write(mount / "kubepods" / "pod1", memory_max=str(2 * 2**30))
    assert memory_warning(2, 1, 2, proc) is None  # 2 GiB: room for the sweeps too
    assert memory_warning(2, 1, 8, proc) is not None  # a sweep pool of 8 a worker: not
    _write(mount / "kubepods" / "pod1", memory_max="max")
    assert cgroup_memory_limit(proc) is None and memory_warning(64, 4, 64, proc) is None


def test_serve_and_the_sweep_pool_count_the_quota(monkeypatch: pytest.MonkeyPatch) -> None:
    """The defaults of ``HYDRODIAG_WORKERS`` and the sweep pool are this process's usable
    cores (on the test machine, whatever quota its group has)."""
    from app.services.executors import SweepExecutors

    monkeypatch.delenv("HYDRODIAG_WORKERS", raising=False)
    expected = min(usable_cores(), 64)
    assert Settings().workers == expected
    assert SweepExecutors().capacity() == usable_cores()  # before its pool starts
