"""What ``hydrodiag serve`` becomes once the store is ready: uvicorn, alone.

``serve`` readies the store (migrations, the reference rig, the first key) with what that
needs imported, then replaces itself with this module (:func:`exec_supervisor`:
``os.execv``, the same process id, so the workers' lifeline and a process manager's signals
reach it as before), which runs uvicorn on ``app.main:create_service_app``: with several
workers as their supervisor (the workers are spawned and import the application
themselves; the parent only starts, watches and stops them), with one in this process.
Kept as it was, a multi-worker parent held everything ``serve`` had imported and loaded:
450 MB of a 2-worker service's 2.2-2.6 GB (``make soak``), against ~35 MB for uvicorn and
the three small modules imported here (:mod:`app.logs`, :mod:`app.metrics`,
:mod:`app.nodelay`); and every process spawned below it (workers, diagnosis processes,
sweep pools) imports its parent's main module first: the whole command line, where this
module is light (a sweep process 149 → 115 MiB).  A single worker now also starts with
``MALLOC_ARENA_MAX`` set (:func:`app.services.heap.limit_arenas`, before the ``exec``).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from collections.abc import Sequence
from typing import Literal, cast

__all__ = ["CONNECTIONS_GRACE_S", "exec_supervisor", "main", "supervisor_argv"]

#: how long a stopping ``serve`` waits for open requests before it cuts them off [s]: a
#: client uploading a body at 1 byte/s kept a SIGTERMed service running past 45 s, its
#: /health unanswered, until the client went away (an SRE pass); running jobs then get
#: their own 5 s (:data:`app.services.jobs.SHUTDOWN_GRACE_S`), within docker stop's 10 s
CONNECTIONS_GRACE_S = 3


def supervisor_argv(*, host: str, port: int, workers: int, log_level: str,
                    log_format: str, keep_alive_s: int, forwarded_allow_ips: str) -> list[str]:
    """The command line that runs this module with ``serve``'s settings (``-P``: the
    working folder is not put first on the module path, so that an ``app`` package of the
    folder ``serve`` was started in — a common name — is not the one imported)."""
    return [sys.executable, "-P", "-m", "app.supervisor", "--host", host, "--port", str(port),
            "--workers", str(workers), "--log-level", log_level, "--log-format", log_format,
            "--keep-alive", str(keep_alive_s), "--forwarded-allow-ips", forwarded_allow_ips]


def exec_supervisor(argv: Sequence[str]) -> None:
    """Replace this process with the supervisor (:func:`supervisor_argv`); never returns.
    What was printed is flushed first: ``execv`` drops the buffers of this process."""
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(argv[0], list(argv))


def main(argv: Sequence[str] | None = None) -> None:
    """Run uvicorn's supervisor with ``--workers`` workers of the service on ``--host`` and
    ``--port`` until it is stopped."""
    parser = argparse.ArgumentParser(prog="python -m app.supervisor",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--host", required=True)
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--workers", type=int, required=True)
    parser.add_argument("--log-level", default="info",
                        choices=("debug", "info", "warning", "error"))
    parser.add_argument("--log-format", default="json", choices=("json", "text"))
    parser.add_argument("--keep-alive", type=int, default=5)
    parser.add_argument("--forwarded-allow-ips", default="127.0.0.1,::1")
    args = parser.parse_args(argv)

    import uvicorn

    from app.logs import configure_logging
    from app.metrics import shared_metrics
    from app.nodelay import NoDelayHttpToolsProtocol

    configure_logging(cast(Literal["json", "text"], args.log_format), args.log_level)
    with shared_metrics() if args.workers > 1 else contextlib.nullcontext():
        # several workers: /metrics sums every worker's counters
        uvicorn.run("app.main:create_service_app", factory=True, workers=args.workers,
                    host=args.host, port=args.port, log_level=args.log_level,
                    http=NoDelayHttpToolsProtocol,  # no Nagle delay on kept-alive
                    timeout_keep_alive=args.keep_alive,
                    forwarded_allow_ips=args.forwarded_allow_ips,
                    timeout_graceful_shutdown=CONNECTIONS_GRACE_S,
                    access_log=False)  # the service logs each request itself


if __name__ == "__main__":
    main()
