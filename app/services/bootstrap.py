"""What ``hydrodiag serve`` does before it listens: migrate, preload, first key."""

from __future__ import annotations

import errno
import logging
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from sqlalchemy import Engine, select, text
from sqlalchemy.exc import DatabaseError
from sqlalchemy.orm import Session

from app.db import migrate
from app.db.engine import lift_timeouts, sqlite_path
from app.db.models import ThrottleCalibration
from app.reference_data import REFERENCE_CALIBRATIONS, REFERENCE_RIG_NAME
from app.schemas.calibrations import CalibrationCreate, CalibrationPointIn
from app.services.calibrations import create_calibration
from app.services.clearance import ClearanceEstimator
from app.services.keys import count_active_keys, create_api_key, list_api_keys
from app.services.rigs import create_rig, find_rig
from app.services.store_repair import repair_store
from sim.errors import InputError
from sim.rigs import reference_rig_document

__all__ = ["LOCAL_KEY_NAME", "Preloaded", "bootstrap_lock", "ensure_first_key",
           "ensure_reference_data", "require_known_revision", "store_problem",
           "upgrade_database", "warn_open_file"]

logger = logging.getLogger("hydrodiag.app")

#: Name of the key created on first start.
LOCAL_KEY_NAME = "local"


@dataclass(frozen=True, slots=True)
class Preloaded:
    """What :func:`ensure_reference_data` added (zero on every start after the first)."""

    rig_created: bool
    calibrations_created: int


#: PostgreSQL advisory-lock key of the bootstrap (any constant; "hydrodiag" in ASCII, cut)
_LOCK_KEY = 0x687964726F646961


@contextmanager
def bootstrap_lock(engine: Engine) -> Iterator[None]:
    """Hold the store's bootstrap lock for the block: one process at a time migrates,
    preloads and makes the first key.

    Two replicas started together on an empty PostgreSQL database both preloaded the
    reference rig, and the slower one exited with "ConflictError: throttle: a table for
    this throttle and condition exists" (an operator pass).  On PostgreSQL this is a
    session advisory lock on its own connection; on an SQLite file an exclusive
    ``flock`` of ``<database>.bootstrap-lock`` beside it; an in-memory store has nothing
    to share.
    """
    url = engine.url
    if url.get_backend_name() == "postgresql":
        with engine.connect() as connection:
            # the lock is the session's; the transaction it opens stays open to the end,
            # and the service's lock timeout would cut the wait for a replica's migration
            lift_timeouts(connection)
            connection.execute(text("SELECT pg_advisory_lock(:k)"), {"k": _LOCK_KEY})
            try:
                yield
            finally:
                connection.execute(text("SELECT pg_advisory_unlock(:k)"), {"k": _LOCK_KEY})
                connection.commit()
        return
    database = sqlite_path(url)
    if database is None:
        yield
        return
    import fcntl

    lock_path = database.with_name(database.name + ".bootstrap-lock")
    lock_path.parent.mkdir(parents=True, exist_ok=True)
    with lock_path.open("a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def upgrade_database(engine: Engine) -> str:
    """Migrate the store to the newest revision; return that revision.

    Raises
    ------
    InputError
        The store is at a revision this release does not know (a newer release migrated
        it), or it cannot be written (read-only file or folder), naming the store.
    """
    before = require_known_revision(engine)
    began = time.monotonic()
    migrate.upgrade(engine)
    _check_writable(engine)
    head = migrate.head_revision()
    if before is not None and before != head:
        # an operator could not tell afterwards when, or from what, the store was
        # migrated (an upgrade pass)
        logger.info("migrated the store %s from revision %s to %s in %.1f s",
                    _where(engine), before, head, time.monotonic() - began)
    repaired = repair_store(engine)   # the first process to start mends; the rest find none
    if repaired:
        logger.warning(
            "the store %s held rows an older release wrote after its migration (an older "
            "instance still serving it?): linked %d diagnoses to their record, gave %d "
            "estimates their interval; stop every older instance before upgrading",
            _where(engine), repaired.links, repaired.intervals)
    return head


def warn_open_file(engine: Engine) -> None:
    """A warning when an SQLite store can be read by others (a group its operator chose is
    theirs to choose, as a backup agent's: the store keeps the mode it was given): stores made
    before this release made them 0600 stayed 0644 through the upgrade (every record and
    the keys' hashes; an upgrade pass).  Called once per start by ``serve`` (not by each
    worker: it was logged three times, a verification pass) and by the CLI's commands."""
    database = sqlite_path(engine.url)
    if database is None:
        return
    try:
        mode = database.stat().st_mode & 0o777
    except OSError:
        return
    if mode & 0o007:
        logger.warning("the store %s can be read by others (mode %o): chmod 600 it, and its "
                       "backups; rotate any API key an older release printed into a log",
                       database, mode)


def require_known_revision(engine: Engine) -> str | None:
    """The store's revision (None: an empty store), refused where this release does not
    know it: a newer release migrated it.  ``db upgrade`` and ``db downgrade`` printed a
    270-line traceback for it where ``serve`` said this line (an operator's pass).

    Raises
    ------
    InputError
        An unknown revision, naming the store, its revision and this release's newest.
    """
    current = migrate.current_revision(engine)
    if current is not None and current not in migrate.known_revisions():
        raise InputError(
            f"the store {_where(engine)} is at revision {current}, which this release does "
            f"not know (its newest is {migrate.head_revision()}): a newer hydrodiag migrated "
            "it; run that release, or a backup made before", field="HYDRODIAG_DATABASE_URL")
    return current


def _where(engine: Engine) -> str:
    """The store's URL without its password."""
    return engine.url.render_as_string(hide_password=True)


def _check_writable(engine: Engine) -> None:
    """A write that changes nothing, rolled back: a read-only store answered "store ready"
    and then a 70-line traceback from the first write of the service (an operator pass)."""
    try:
        with engine.connect() as connection:
            connection.execute(text("UPDATE alembic_version SET version_num = version_num"))
            connection.rollback()
    except DatabaseError as exc:
        said = str(exc).lower()
        if not any(w in said for w in ("readonly", "read-only", "permission denied")):
            raise
        raise InputError(f"the store {_where(engine)} is read-only: the service writes its "
                         "history there (file and folder permissions, or the database "
                         "user's rights)", field="HYDRODIAG_DATABASE_URL") from None


def store_problem(engine: Engine, exc: BaseException) -> InputError | None:
    """What an operator reads, in one line, for an error of the store at start-up: a data
    folder that cannot be written, a damaged file; ``None`` for another error.  These gave
    49- to 461-line tracebacks without the file's name (an operator pass)."""
    where = _where(engine)
    if isinstance(exc, PermissionError | IsADirectoryError) or (
            isinstance(exc, OSError) and exc.errno in (errno.EROFS, errno.EACCES)):
        # a read-only file system too: its lock file gave a 50-line traceback (an
        # operator's pass)
        return InputError(f"cannot write {exc.filename or where} ({exc.strerror}): the service "
                          "keeps its store and a lock file beside it there (HYDRODIAG_DATA_DIR, "
                          "HYDRODIAG_DATABASE_URL)", field="HYDRODIAG_DATA_DIR")
    text_of = (str(getattr(exc, "orig", None) or exc).strip().splitlines() or [""])[0]
    if isinstance(exc, DatabaseError) and any(
            w in text_of.lower() for w in ("malformed", "not a database", "file is encrypted")):
        return InputError(f"the store {where} is damaged ({text_of}): restore it from a backup "
                          "(hydrodiag db backup FILE makes one)",
                          field="HYDRODIAG_DATABASE_URL")
    if isinstance(exc, DatabaseError) and "permission denied" in text_of.lower():
        # PostgreSQL 15: a role that does not own the database cannot create in "public"
        # (341-line tracebacks from db upgrade and serve; an operator pass)
        return InputError(f"the database role may not change {where} ({text_of}): make the "
                          "role the database's owner, or GRANT CREATE ON SCHEMA public to it",
                          field="HYDRODIAG_DATABASE_URL")
    return None


def ensure_reference_data(
    session: Session, *, estimator: ClearanceEstimator | None = None
) -> Preloaded:
    """Add the paper-002 reference rig and its throttle tables where they are missing.

    Existing rows are left as they are: a lab that edited the reference tables keeps its
    edits.  Missing clearances are computed by ``estimator`` when given; if the computed
    values contradict the published rows, the table is stored as published.
    """
    rig = find_rig(session, REFERENCE_RIG_NAME)
    rig_created = rig is None
    if rig is None:
        rig, _ = create_rig(session, reference_rig_document(),
                            comment="reference rig of paper 002, preloaded")
    created = 0
    for table in REFERENCE_CALIBRATIONS:
        exists = session.scalar(
            select(ThrottleCalibration.id).where(
                ThrottleCalibration.rig_id == rig.id,
                ThrottleCalibration.throttle == table.throttle,
                ThrottleCalibration.back_pressure_pa == table.back_pressure_pa,
                ThrottleCalibration.temperature_c == table.temperature_c,
            )
        )
        if exists is not None:
            continue
        data = CalibrationCreate(
            throttle=table.throttle,
            component=table.component,
            back_pressure_pa=table.back_pressure_pa,
            temperature_c=table.temperature_c,
            source=table.source,
            points=[
                CalibrationPointIn(opening_turns=x, bypass_flow_m3s=q, clearance_m=c)
                for x, q, c in zip(table.openings_turns, table.bypass_flows_m3s,
                                   table.clearances_m, strict=True)
            ],
        )
        try:
            create_calibration(session, rig.id, data, estimator=estimator)
        except InputError as exc:
            # the estimator contradicts the published rows: keep the table as published
            session.rollback()
            logger.warning("reference table %s: computed clearances not used (%s)",
                           table.throttle, exc)
            create_calibration(session, rig.id, data, estimator=None)
        created += 1
    return Preloaded(rig_created=rig_created, calibrations_created=created)


def ensure_first_key(session: Session) -> str | None:
    """Create the ``local`` key when the store has no active key.

    Returns
    -------
    str or None
        The new key (to be shown once), or ``None`` when keys exist already.
    """
    if count_active_keys(session):
        return None
    taken = {row.name for row in list_api_keys(session)}  # revoked keys keep their names
    name, suffix = LOCAL_KEY_NAME, 1
    while name in taken:
        suffix += 1
        name = f"{LOCAL_KEY_NAME}-{suffix}"
    _, plaintext = create_api_key(session, name)
    return plaintext
