"""What a job freed goes back to the system: :func:`app.services.heap.trim_heap`."""

from __future__ import annotations

import ctypes.util
import threading
from pathlib import Path

import pytest

from app.services.heap import trim_heap

#: blocks below glibc's mmap threshold (128 KiB), so from the thread's arena [byte]
BLOCK = 64 * 1024
BLOCKS = 2000  # 125 MiB


def _rss_mib() -> float:
    for line in Path("/proc/self/status").read_text(encoding="utf-8").splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise AssertionError("no VmRSS")


@pytest.mark.skipif(not Path("/proc/self/status").exists()
                    or ctypes.util.find_library("c") is None, reason="needs Linux and a libc")
def test_the_memory_a_job_thread_freed_is_returned() -> None:
    """A job thread, which lives on after its job (a pool's), freed 125 MiB of mid-sized
    blocks with a later block still held above them: glibc keeps them in the thread's
    arena (the process stayed 125 MiB larger) until :func:`trim_heap`."""
    held: list[object] = []
    freed, stop = threading.Event(), threading.Event()

    def job() -> None:
        blocks = [bytearray(BLOCK) for _ in range(BLOCKS)]
        for b in blocks:  # touch every page
            b[::4096] = b"\1" * len(b[::4096])
        held.append(bytearray(4096))  # above them in the arena, and kept
        del blocks
        freed.set()
        stop.wait(60.0)

    before = _rss_mib()
    thread = threading.Thread(target=job)
    thread.start()
    try:
        assert freed.wait(60.0)
        size, kept = BLOCK * BLOCKS / 2**20, _rss_mib() - before
        if kept < size / 2:
            pytest.skip(f"this allocator returned the blocks by itself ({kept:.0f} MiB kept)")
        assert trim_heap() is True
        assert _rss_mib() - before < size / 4, (before, kept, _rss_mib())
    finally:
        stop.set()
        thread.join()


def test_trim_heap_takes_a_done_callbacks_argument() -> None:
    assert trim_heap(object()) in (True, False)
