"""What ``make soak`` reads of a running ``hydrodiag serve`` between requests: each server
process's resident memory, open descriptors and threads, the SQLite store and its WAL, the
rows of every table, the files in the metrics folder, the temporary directory and the
compile cache, and the log's size (:mod:`benchmarks.soak`)."""

from __future__ import annotations

import os
import sqlite3
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["Sample", "parent_of", "process_tree", "role", "sample"]

#: the tables whose rows are read at each sample
TABLES = ("measurements", "diagnoses", "measured_series", "jobs", "api_keys",
          "console_logouts", "idempotent_requests", "throttle_calibrations", "pump_sets")


@dataclass
class Sample:
    """One reading of the service's resources at ``t`` [s] after ``requests`` requests."""

    t: float
    requests: int
    #: per process (by role and pid): resident memory [MiB], descriptors [-], threads [-]
    rss_mb: dict[str, float] = field(default_factory=dict)
    fds: dict[str, int] = field(default_factory=dict)
    threads: dict[str, int] = field(default_factory=dict)
    db_mb: float = 0.0
    wal_mb: float = 0.0
    rows: dict[str, int] = field(default_factory=dict)
    #: files in the metrics folder, the others in the service's temporary directory, files
    #: in the compile cache
    metrics_files: int = 0
    tmp_entries: int = 0
    cache_files: int = 0
    log_mb: float = 0.0
    #: descriptors of every process by what they open: socket, pipe, store (the SQLite
    #: files), anon (eventfd, epoll, ...), file (any other path)
    fd_kinds: dict[str, int] = field(default_factory=dict)


def process_tree(root: int) -> list[int]:
    """``root`` and every process below it (the children of each of its threads: a sweep
    pool's processes are started by a job thread, not the main one)."""
    found = [root]
    try:
        tasks = os.listdir(f"/proc/{root}/task")
    except OSError:
        return found
    for task in tasks:
        try:
            children = Path(f"/proc/{root}/task/{task}/children").read_text(
                encoding="utf-8").split()
        except OSError:
            continue
        for child in children:
            found += process_tree(int(child))
    return found


def parent_of(pid: int) -> int:
    """The parent process id of ``pid`` (``OSError`` for one gone)."""
    return int(Path(f"/proc/{pid}/stat").read_text(encoding="utf-8")
               .rsplit(")", 1)[1].split()[1])


def role(pid: int, root: int) -> str:
    """``serve`` for the supervisor, ``worker`` for a server worker, ``tracker`` for spawn's
    resource tracker, ``child`` for a worker's own processes (its diagnosis processes and
    its sweep pool's), ``other`` otherwise."""
    if pid == root:
        return "serve"
    try:
        cmdline = Path(f"/proc/{pid}/cmdline").read_bytes()
        parent = parent_of(pid)
    except (OSError, ValueError):
        return "other"
    if b"resource_tracker" in cmdline:
        return "tracker"
    if parent == root:
        return "worker"
    return "child" if b"spawn_main" in cmdline else "other"


def _status(pid: int) -> tuple[float, int]:
    rss, threads = float("nan"), 0
    for line in Path(f"/proc/{pid}/status").read_text(encoding="utf-8").splitlines():
        if line.startswith("VmRSS:"):
            rss = int(line.split()[1]) / 1024
        elif line.startswith("Threads:"):
            threads = int(line.split()[1])
    return rss, threads


def _fd_kind(pid: int, fd: str) -> str:
    try:
        target = os.readlink(f"/proc/{pid}/fd/{fd}")
    except OSError:
        return "gone"
    if target.startswith(("socket:", "pipe:")):
        return target.split(":", 1)[0]
    if target.startswith("anon_inode:"):
        return "anon"
    return "store" if "hydrodiag.db" in target else "file"


def _size_mb(path: Path) -> float:
    try:
        return path.stat().st_size / 2**20
    except OSError:
        return 0.0


def _files(folder: Path | None) -> int:
    if folder is None or not folder.is_dir():
        return 0
    return sum(len(files) for _, _, files in os.walk(folder))


def sample(t: float, requests: int, root: int, data_dir: Path, metrics_dir: Path | None,
           tmp_dir: Path, cache_dir: Path | None, log: Path) -> Sample:
    """Read every figure of :class:`Sample` now; a process gone meanwhile is left out."""
    s = Sample(t, requests)
    for pid in process_tree(root):
        try:
            rss, threads = _status(pid)
            fds = os.listdir(f"/proc/{pid}/fd")
        except OSError:
            continue
        for fd in fds:
            kind = _fd_kind(pid, fd)
            s.fd_kinds[kind] = s.fd_kinds.get(kind, 0) + 1
        name = f"{role(pid, root)}:{pid}"
        s.rss_mb[name], s.threads[name], s.fds[name] = rss, threads, len(fds)
    store = data_dir / "hydrodiag.db"
    s.db_mb, s.wal_mb = _size_mb(store), _size_mb(Path(f"{store}-wal"))
    with sqlite3.connect(f"file:{store}?mode=ro", uri=True, timeout=30) as connection:
        for table in TABLES:
            s.rows[table] = int(connection.execute(f"SELECT count(*) FROM {table}").fetchone()[0])
    connection.close()
    s.metrics_files = _files(metrics_dir)
    s.tmp_entries = _files(tmp_dir) - s.metrics_files
    s.cache_files = _files(cache_dir)
    s.log_mb = _size_mb(log)
    return s
