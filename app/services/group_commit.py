"""Group commit: the stored diagnoses of concurrent requests committed in one transaction.

A stored ``POST /diagnose`` used to open a session, insert its rows and commit, in a thread
of its own: one transaction and one thread hop per request, and on a busy server several
threads contending for SQLite's single writer lock and for the interpreter lock that the
event loop needs.  :class:`GroupCommitter` keeps one writer thread per server process.  A
request hands it a *write* (a function that adds rows to a session and flushes them, no
commit) and awaits it; the thread takes the first write queued, then every other write
queued meanwhile (at most ``max_batch``: "commit what is queued", no waiting window, so a
lone request is not delayed), runs them in one session and commits once.

Durability promise: a request is answered only after the transaction holding its rows
has committed (its future is resolved after ``commit`` returns), so an acknowledged
diagnosis survives a ``kill -9`` of the server (SQLite in WAL mode, PostgreSQL).  A write
that fails (a rig deleted meanwhile, a constraint) must not fail its neighbours: when a
batch fails, it is rolled back and each write is run again alone in its own transaction,
so that only the failing request gets its error and nothing of it is stored.  A write is
therefore run at most twice and must be repeatable (it builds new rows from plain data).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import queue
import threading
from collections.abc import Callable
from dataclasses import dataclass

from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from app.db.engine import SessionFactory
from app.services.common import commit
from sim.errors import ConflictError

__all__ = ["GroupCommitter", "Write"]

logger = logging.getLogger("hydrodiag.app")

#: Adds rows to a session and flushes them (no commit); may be run twice (see above).
Write = Callable[[Session], None]


@dataclass(slots=True)
class _Pending:
    write: Write
    conflict: str
    loop: asyncio.AbstractEventLoop
    future: asyncio.Future[None]


def _settle(future: asyncio.Future[None], error: BaseException | None) -> None:
    """Resolve ``future`` (on its event loop); a request that has gone is not told."""
    if future.done():
        return
    if error is None:
        future.set_result(None)
    else:
        future.set_exception(error)


def _settle_all(futures: list[asyncio.Future[None]]) -> None:
    for future in futures:
        _settle(future, None)


def _answer(pending: _Pending, error: BaseException | None) -> None:
    """Tell the request (on its event loop thread) how its write went."""
    with contextlib.suppress(RuntimeError):  # a closed loop: nobody waits for the answer
        pending.loop.call_soon_threadsafe(_settle, pending.future, error)


class GroupCommitter:
    """One writer thread that commits the writes queued at once in a single transaction.

    Parameters
    ----------
    sessions
        Session factory of the store.
    max_batch
        Most writes committed in one transaction [-].
    """

    def __init__(self, sessions: SessionFactory, max_batch: int = 64) -> None:
        if max_batch < 1:
            raise ValueError("max_batch must be 1 or more")
        self.max_batch = max_batch
        #: Transactions committed, and writes committed in them [-] (for tests and metrics).
        self.transactions = 0
        self.committed = 0
        self._sessions = sessions
        self._queue: queue.SimpleQueue[_Pending | None] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self._closed = False

    async def write(self, write: Write, *, conflict: str) -> None:
        """Run ``write`` in the next group transaction; return once it has committed.

        Raises
        ------
        ConflictError
            A constraint refused the rows (``conflict`` is the message); nothing of this
            write is stored.
        HydrodiagError
            Whatever ``write`` raised; nothing of it is stored.
        """
        loop = asyncio.get_running_loop()
        future: asyncio.Future[None] = loop.create_future()
        self._start()
        self._queue.put(_Pending(write, conflict, loop, future))
        await future

    def _start(self) -> None:
        with self._lock:
            if self._closed:
                raise RuntimeError("the group committer is shut down")
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="hydrodiag-group-commit",
                                                daemon=True)
                self._thread.start()

    def _run(self) -> None:
        while True:
            first = self._queue.get()
            if first is None:
                return
            batch = [first]
            stop = False
            while len(batch) < self.max_batch:
                try:
                    item = self._queue.get_nowait()
                except queue.Empty:
                    break
                if item is None:
                    stop = True
                    break
                batch.append(item)
            self._commit(batch)
            if stop:
                return

    def _commit(self, batch: list[_Pending]) -> None:
        """Commit ``batch`` in one transaction, or each write alone when that fails."""
        if len(batch) == 1:
            self._commit_alone(batch[0])
            return
        try:
            with self._sessions() as session:
                for pending in batch:
                    pending.write(session)
                session.commit()
        except Exception:  # one write failed: find which, commit the others
            logger.debug("a group of %d writes failed; committing each alone", len(batch))
            for pending in batch:
                self._commit_alone(pending)
            return
        self.transactions += 1
        self.committed += len(batch)
        by_loop: dict[asyncio.AbstractEventLoop, list[asyncio.Future[None]]] = {}
        for pending in batch:
            by_loop.setdefault(pending.loop, []).append(pending.future)
        for loop, futures in by_loop.items():  # one wake-up of each loop per transaction
            with contextlib.suppress(RuntimeError):  # a closed loop: nobody waits
                loop.call_soon_threadsafe(_settle_all, futures)

    def _commit_alone(self, pending: _Pending) -> None:
        error: BaseException | None = None
        try:
            with self._sessions() as session:
                pending.write(session)
                commit(session, conflict=pending.conflict)
        except IntegrityError:  # raised by a flush inside the write
            error = ConflictError(pending.conflict)
        except Exception as exc:  # handed to the request, which maps it to its answer
            error = exc
        else:
            self.transactions += 1
            self.committed += 1
        _answer(pending, error)

    def shutdown(self) -> None:
        """Commit what is queued, then stop the thread (blocks until it has)."""
        with self._lock:
            self._closed = True
            thread, self._thread = self._thread, None
        if thread is not None:
            self._queue.put(None)
            thread.join()
