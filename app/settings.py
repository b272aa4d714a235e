"""Service settings, read from the environment (prefix ``HYDRODIAG_``).

Every setting has a safe default for a single engineer's machine: an SQLite file under
``./data``, every operation but ``/health``, ``/ready``, ``/metrics`` and the docs behind
an API key.  :class:`Settings` refuses configurations
that are obviously insecure or cannot work (a database password from a tutorial, an
in-memory SQLite database that would lose every write).
"""

from __future__ import annotations

import difflib
import ipaddress
import os
from collections.abc import Mapping
from functools import cached_property
from pathlib import Path
from typing import Literal

from pydantic import Field, SecretStr, field_validator, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict
from sqlalchemy.engine import URL, make_url
from sqlalchemy.exc import ArgumentError

from app.cgroup_limits import usable_cores
from app.db.engine import sqlite_path
from app.limits import BATCH_RECORDS_CEILING, DEFAULT_SWEEP_POINTS, SWEEP_POINTS_CEILING

__all__ = ["CONSOLE_SECRET_MIN", "DEFAULT_RETENTION_DAYS", "OTHER_VARIABLES", "WEAK_PASSWORDS",
           "Settings", "settings_line", "unknown_variables"]

#: Days a finished job's row is kept after it finished (:mod:`app.services.job_retention`)
#: [d].
DEFAULT_RETENTION_DAYS = 30.0

#: Passwords that appear in tutorials and default images; refused in a database URL.
WEAK_PASSWORDS = frozenset(
    {"", "admin", "changeme", "changethis", "hydrodiag", "password", "postgres", "secret", "root"}
)

#: Fewest characters of ``HYDRODIAG_CONSOLE_SECRET`` (the random default has 64 hex ones).
CONSOLE_SECRET_MIN = 32


class Settings(BaseSettings):
    """Configuration of the hydrodiag service.

    Every attribute can be set by an environment variable named ``HYDRODIAG_`` plus the
    attribute name in capitals, e.g. ``HYDRODIAG_DATABASE_URL``.

    Attributes
    ----------
    data_dir
        Folder for the embedded SQLite database and other local state.
    database_url
        SQLAlchemy URL of the store; default ``sqlite:///<data_dir>/hydrodiag.db``.
        A PostgreSQL URL (``postgresql+psycopg://user:pw@host/db``) selects PostgreSQL.
    open_reads
        Whether the reads (GET), ``/simulate`` and ``/diagnose`` with ``"store": false``
        answer without an API key (default false: every operation but ``/health``,
        ``/ready``, ``/metrics`` and the docs needs one).
    max_body_bytes
        Largest request body accepted [byte] (default 8 MiB); a larger one is answered 413
        before it is read in full.  File uploads (``multipart/form-data``) have their own
        limit, ``max_upload_bytes``.
    max_upload_bytes
        Largest ``multipart/form-data`` body accepted [byte] (default 64 MiB): a measured
        series (file up to 20 MiB), a discrepancy data file (up to 50 MiB) or a bench CSV
        with its form fields.  Each upload route also caps its file (422 naming ``file``).
    rate_limit_per_minute
        Requests each API key may send per minute (and in a burst), per server process;
        over it, 429 with ``Retry-After``.  0 (default) sets no limit.
    host, port
        Where ``hydrodiag serve`` listens.
    forwarded_allow_ips
        Addresses whose ``X-Forwarded-For`` / ``X-Forwarded-Proto`` headers ``serve``
        believes (uvicorn's ``forwarded_allow_ips``): comma-separated addresses or networks,
        or ``*``; default ``127.0.0.1,::1``.  Behind a proxy that terminates TLS on another
        host or container, name its address: otherwise the service takes every request
        for plain HTTP from the proxy, and the console's login cookie is then sent without
        ``Secure``.
    keep_alive_s
        How long ``serve`` keeps an idle kept-alive connection open [s] (uvicorn's
        ``timeout_keep_alive``; default 5, uvicorn's).  Behind a proxy that keeps its
        connections to the service alive, set it above the proxy's idle timeout (nginx's
        upstream ``keepalive_timeout`` and an AWS load balancer's idle timeout are 60 s):
        a request the proxy sends on a connection the service is closing fails, and nginx
        does not send a POST again (a 502 to the client).
    job_workers
        Threads that run long jobs (sweeps, maps) in the service process.
    max_queued_jobs
        Jobs (sweeps, re-diagnoses, discrepancy checks) a server process keeps
        waiting beside its ``job_workers`` running ones [-]; default 16.  One more is
        answered 503 with ``Retry-After``, nothing stored: 100 sweeps of 200 transient
        points were all accepted at once, ~5 MiB of server memory each (an SRE pass).
    sweep_workers
        Processes of the local pool that sweeps fan out to; when unset, one per core this
        process may use (:func:`app.cgroup_limits.usable_cores`).
    dask_scheduler
        Address of a Dask scheduler (``tcp://host:8786``); when set and
        ``dask.distributed`` is installed, sweeps run there instead of the local pool.
    rig_cache_size
        Compiled rigs (rig, version) kept in memory.
    access_log
        Whether the service logs one line per request (logger ``hydrodiag.access``:
        method, route template, status, duration, request id, key id; see
        :mod:`app.logs`).  ``serve`` turns uvicorn's own access log off.
    log_format
        ``json`` (default): one JSON object per log line; ``text``: plain lines.
    workers
        Server processes of ``serve`` (uvicorn workers); each has its own caches.  Default:
        one per core this process may use: its CPU affinity and its control group's CPU
        quota, a container's ``--cpus`` (:func:`app.cgroup_limits.usable_cores`).
    diagnosis_processes
        Worker processes of each server process that compute ``/diagnose``
        (:mod:`app.services.diagnosis_pool`), so that diagnoses never hold the server's
        interpreter lock and ``/health`` answers under load; 0 computes in the server's
        threads.  Default 1.
    diagnosis_queue
        Most ``/diagnose`` requests a server process takes at once (running or waiting);
        one more is answered 503 with ``Retry-After`` at once.  Default 32.
    diagnosis_wait_ms
        Longest expected wait of a ``/diagnose`` request for a diagnosis process [ms]: the
        tasks ahead, divided among the processes, times the measured time of one; past it
        a request is answered 503 with ``Retry-After`` before any work, so that an
        overloaded service refuses what it cannot do in time.  Default 100.
    log_level
        Level of the service's log.
    max_batch_records
        Most records one ``/diagnose`` may carry [-]; default 100, at most 10,000.  More is
        a 422 on ``records`` naming this setting.
    max_sweep_points_steady, max_sweep_points_transient
        Most scenarios one ``/scenarios`` sweep may run [-], steady (default 5,000, at most
        100,000) and transient (default 200, at most 10,000).  More is a 422 on ``design``
        naming the setting.
    sim_max_steps
        Most solver steps of one integration of ``/simulate`` (one phase of one run;
        enforced inside the compiled step loop); default 2,000,000 (RODAS4 needs ~1,000 a
        phase for a noise-accurate cycle of the reference rig, ~7,500 at rtol 1e-8).
    sim_max_time
        Longest simulated span of one ``/simulate`` phase or sampling grid [s]; default 600.
    sim_wall_clock
        Wall-clock budget of one ``/simulate`` run, companion runs included [s]; default
        10.  Checked between chunks of 5,000 compiled steps, so a run overshoots it by at
        most one chunk (a few tens of ms).
    sim_max_rows
        Most rows of one ``/simulate`` time series on a sampling grid (a CSV or Parquet
        export, or the grid its summary is read from) [-]; default 1,000,000 (1,000 s at
        1 kHz).  A JSON time series holds at most 100,000.  Past it a 422 on
        ``sample_rate`` says how many rows the run would have.
    console_secret
        Secret that signs the console's login cookies, at least
        :data:`CONSOLE_SECRET_MIN` characters and no well-known default; set the same on
        every host that serves one console (a login then holds across them).  Default: a
        random one, kept in ``<data_dir>/console-secret``.
    """

    model_config = SettingsConfigDict(env_prefix="HYDRODIAG_", extra="ignore")

    data_dir: Path = Field(default=Path("data"), description="Folder for local state.")
    database_url: str | None = Field(default=None, description="SQLAlchemy database URL.")
    open_reads: bool = Field(default=False, description="Reads, /simulate and unstored "
                             "/diagnose need no API key when true.")
    max_body_bytes: int = Field(default=8 * 1024 * 1024, ge=1024, le=1024**3,
                                description="Largest request body [byte].")
    max_upload_bytes: int = Field(default=64 * 1024 * 1024, ge=1024, le=1024**3,
                                  description="Largest file-upload (multipart) body [byte].")
    rate_limit_per_minute: int = Field(default=0, ge=0, le=10**6,
                                       description="Requests per API key and minute; 0: none.")
    host: str = Field(default="127.0.0.1", description="Interface `serve` binds.")
    port: int = Field(default=8000, ge=1, le=65535, description="TCP port `serve` binds.")
    forwarded_allow_ips: str = Field(
        default="127.0.0.1,::1", description="Proxies whose X-Forwarded-* headers `serve` "
        "believes: addresses or networks, comma-separated, or *.")
    keep_alive_s: int = Field(default=5, ge=1, le=3600,
                              description="Seconds `serve` keeps an idle connection open.")
    job_workers: int = Field(default=2, ge=1, le=64, description="Job worker threads.")
    max_queued_jobs: int = Field(default=16, ge=0, le=10_000,
                                 description="Jobs a server process keeps waiting [-].")
    job_retention_days: float = Field(
        default=DEFAULT_RETENTION_DAYS, ge=0, le=36_500,
        description="Days a finished job is kept after it finished; 0: every job kept [d].")
    sweep_workers: int | None = Field(default=None, ge=1, le=256,
                                      description="Sweep worker processes.")
    dask_scheduler: str | None = Field(default=None, description="Dask scheduler address.")
    rig_cache_size: int = Field(default=16, ge=1, le=1024, description="Compiled rigs kept.")
    access_log: bool = Field(default=True, description="Log every request.")
    workers: int = Field(default_factory=lambda: min(usable_cores(), 64), ge=1, le=64,
                         description="Server processes (default: one per core).")
    diagnosis_processes: int = Field(default=1, ge=0, le=64,
                                     description="Diagnosis worker processes per server "
                                     "process; 0: in its threads.")
    diagnosis_queue: int = Field(default=32, ge=1, le=100_000,
                                 description="Most /diagnose requests taken at once per "
                                 "server process.")
    diagnosis_wait_ms: float = Field(default=100.0, gt=0, le=600_000,
                                     description="Longest expected wait for a diagnosis "
                                     "process before /diagnose answers 503 [ms].")
    log_level: Literal["debug", "info", "warning", "error"] = Field(default="info")
    log_format: Literal["json", "text"] = Field(default="json",
                                                description="Log lines as JSON or text.")
    max_batch_records: int = Field(default=100, ge=1, le=BATCH_RECORDS_CEILING,
                                   description="Most records of one /diagnose.")
    max_sweep_points_steady: int = Field(
        default=DEFAULT_SWEEP_POINTS["steady"], ge=1, le=SWEEP_POINTS_CEILING["steady"],
        description="Most points of one steady sweep.")
    max_sweep_points_transient: int = Field(
        default=DEFAULT_SWEEP_POINTS["transient"], ge=1,
        le=SWEEP_POINTS_CEILING["transient"],
        description="Most points of one transient sweep.")
    db_lock_timeout: float = Field(
        default=10.0, gt=0, le=3600,
        description="How long a request waits for a PostgreSQL lock another session holds "
        "before its 503 [s]; statements are cut at 60 s or this, the larger.")
    sim_max_steps: int = Field(default=2_000_000, ge=100, le=100_000_000,
                               description="Most solver steps of one /simulate integration.")
    sim_max_time: float = Field(default=600.0, gt=0, le=1e6,
                                description="Longest simulated span of /simulate [s].")
    sim_wall_clock: float = Field(default=10.0, gt=0, le=3600,
                                  description="Wall-clock budget of one /simulate run [s].")
    sim_max_rows: int = Field(default=1_000_000, ge=1_000, le=100_000_000,
                              description="Most rows of one /simulate time series [-].")
    console_secret: SecretStr | None = Field(
        default=None, description="Signing secret of the console's login cookies (≥ 32 "
        "characters); default a random one in <data_dir>/console-secret.")

    @field_validator("console_secret", mode="before")
    @classmethod
    def _check_console_secret(cls, value: object) -> object:
        # it was read beside the settings and any value taken: "secret" signed logins that
        # anyone who guessed it could forge (a design pass)
        text = value.get_secret_value() if isinstance(value, SecretStr) else value
        if text is None or (isinstance(text, str) and not text.strip()):
            return None
        if not isinstance(text, str):
            return value
        if text.strip().lower() in WEAK_PASSWORDS or len(text.strip()) < CONSOLE_SECRET_MIN:
            raise ValueError(
                f"the console secret must be at least {CONSOLE_SECRET_MIN} characters and not "
                "a well-known default (make one: python3 -c 'import secrets; "
                "print(secrets.token_hex(32))')")
        return text.strip()

    @field_validator("forwarded_allow_ips")
    @classmethod
    def _check_proxies(cls, value: str) -> str:
        items = [v.strip() for v in value.split(",")]
        for item in items:
            if item == "*":
                continue
            try:
                ipaddress.ip_network(item, strict=False)
            except ValueError:
                raise ValueError(f"{item!r} is not an address or a network (give addresses "
                                 "like 10.0.0.5 or 10.0.0.0/8, comma-separated, or *)"
                                 ) from None
        return ",".join(items)

    @field_validator("database_url")
    @classmethod
    def _check_url(cls, value: str | None) -> str | None:
        if value is None or value.strip() == "":
            return None
        try:
            url = make_url(value)
        except ArgumentError as exc:
            # not SQLAlchemy's text: before 2.0.41 it quoted the whole URL, password included
            raise ValueError("not a database URL: SQLAlchemy could not parse it") from exc
        backend = url.get_backend_name()
        if backend == "postgres":  # libpq's and Heroku's spelling
            raise ValueError("write the scheme as postgresql+psycopg:// (SQLAlchemy does not "
                             "take postgres://)")
        if backend not in {"sqlite", "postgresql"}:
            raise ValueError(f"unsupported database {backend!r}; use sqlite or postgresql")
        if backend == "sqlite" and sqlite_path(url) is None:   # file::memory: as well
            raise ValueError("an in-memory SQLite database would lose every write; give a file")
        if url.password is not None and url.password.lower() in WEAK_PASSWORDS:
            raise ValueError("the database password is a well-known default; set a real one")
        return value

    @model_validator(mode="after")
    def _check_paths(self) -> Settings:
        if self.data_dir.exists() and not self.data_dir.is_dir():
            raise ValueError(f"data_dir {self.data_dir} exists and is not a folder")
        return self

    @property
    def sweep_points(self) -> dict[str, int]:
        """Most points of one sweep, by method [-]."""
        return {"steady": self.max_sweep_points_steady,
                "transient": self.max_sweep_points_transient}

    @cached_property
    def url(self) -> URL:
        """The effective database URL (the SQLite default filled in)."""
        if self.database_url is not None:
            return make_url(self.database_url)
        path = (self.data_dir / "hydrodiag.db").resolve()
        return URL.create("sqlite", database=str(path))

    @property
    def is_sqlite(self) -> bool:
        """Whether the store is an SQLite file."""
        return self.url.get_backend_name() == "sqlite"


#: ``HYDRODIAG_`` variables read elsewhere than :class:`Settings` (the compiled models'
#: cache, the README's key for curl, the tests' and studies' knobs)
OTHER_VARIABLES = frozenset(f"HYDRODIAG_{name}" for name in (
    "CACHE_DIR", "KEY", "CHROMIUM", "SHARED", "TEST_POSTGRES_URL",
    "FUZZ_EXAMPLES", "SCREENSHOTS", "ACCURACY_SEED", "ACCURACY_DUMP", "LIGHT", "SEEDS",
    "KINDS", "NOISE", "EFFECTS", "SIZES", "DWELL", "SLOW"))


def unknown_variables(environ: Mapping[str, str] | None = None) -> list[str]:
    """``HYDRODIAG_`` variables of ``environ`` (default the process's) that nothing reads,
    each with the setting it may have meant: a misspelt ``HYDRODIAG_OPENREADS=true`` left
    open reads off without a word (an operator's pass)."""
    env = os.environ if environ is None else environ
    known = {f"HYDRODIAG_{name.upper()}" for name in Settings.model_fields} | OTHER_VARIABLES
    out = []
    prefix = len("HYDRODIAG_")  # compared without it: every name shares it
    for name in sorted(k for k in env if k.startswith("HYDRODIAG_") and k not in known):
        close = difflib.get_close_matches(name[prefix:], sorted(k[prefix:] for k in known),
                                          n=1, cutoff=0.6)
        out.append(f"{name} (did you mean HYDRODIAG_{close[0]}?)" if close else name)
    return out


def settings_line(settings: Settings) -> str:
    """The settings in effect that decide how the service answers, in one line for the
    start-up log (the log said none of them: an operator's pass); the database URL
    without its password."""
    return (f"settings: store {settings.url.render_as_string(hide_password=True)}, host "
            f"{settings.host}, port {settings.port}, workers {settings.workers}, open reads "
            f"{'on' if settings.open_reads else 'off'}, rate limit "
            f"{settings.rate_limit_per_minute or 'none'}"
            f"{' per key and minute' if settings.rate_limit_per_minute else ''}, "
            f"largest body {settings.max_body_bytes} B, largest upload "
            f"{settings.max_upload_bytes} B, log {settings.log_format} at "
            f"{settings.log_level}")
