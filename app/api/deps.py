"""Dependencies of the routes, as ``Annotated`` aliases.

``SessionDep`` gives a session per request (closed, and rolled back if uncommitted, when
the request ends); ``WriteKeyDep`` demands a valid API key of scope ``write`` or
``admin``, ``AdminKeyDep`` one of scope ``admin``; ``ReadAccess`` demands a key of any
scope unless the service runs with open reads (``HYDRODIAG_OPEN_READS=true``, default
false): then the reads, ``/simulate`` and ``/diagnose`` without ``store`` answer without a
key.  A valid key without the scope an operation needs is answered 403 (``ScopeError``).
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Annotated, Any

from fastapi import Depends, Query, Request, Security
from fastapi.security import APIKeyHeader
from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from app.db.models import ApiKey
from app.errors import RateLimitError, ScopeError
from app.ratelimit import KeyRateLimiter, client_address
from app.schemas.common import MAX_OFFSET
from app.security import Scope
from app.services.clearance import ClearanceEstimator
from app.services.executors import SweepExecutors
from app.services.keys import API_KEY_HEADER, authenticate, authenticate_on_loop
from app.services.rig_cache import RigCache
from app.settings import Settings
from sim.errors import AuthError

__all__ = [
    "OPEN_READ_ACCESS",
    "SCOPE_OF",
    "AdminKeyDep",
    "EstimatorDep",
    "ExecutorsDep",
    "KeyHeaderDep",
    "PageDep",
    "PageParams",
    "ReadAccess",
    "RigsDep",
    "SessionDep",
    "SettingsDep",
    "WriteKeyDep",
    "count_rate",
    "get_db",
    "read_access",
    "read_access_on_loop",
    "require_admin_key",
    "require_key",
    "require_key_on_loop",
    "require_scope",
    "require_write_key",
    "wrong_key_guard",
    "wrong_keys_counted",
]


async def get_settings(request: Request) -> Settings:
    """Return the settings the application was created with.

    ``async`` like the other accessors here: FastAPI runs a plain function dependency in
    its thread pool, a thread hand-off per request for a read of an attribute.
    """
    settings: Settings = request.app.state.settings
    return settings


async def get_db(request: Request) -> AsyncIterator[Session]:
    """Yield a session of the application's store for one request.

    On the event loop, not in a thread: making a session does no I/O (it connects on first
    use, in the thread that uses it), and a session that holds no connection at the end (an
    async route that closed it in its thread call, or never used it) is closed on the loop
    too.  Only a session still holding a connection is closed in a thread, where returning
    the connection to the pool may wait for the database.  A sync generator here cost two
    thread hand-offs per request, and on a busy server each hand-off costs the event loop
    its interpreter lock (profile of ``POST /diagnose``, issue 9).
    """
    session: Session = request.app.state.sessions()
    try:
        yield session
    finally:
        if session.in_transaction():
            await run_in_threadpool(session.close)
        else:
            session.close()


async def get_estimator(request: Request) -> ClearanceEstimator | None:
    """Return the clearance estimator the application was given, if any."""
    estimator: ClearanceEstimator | None = request.app.state.clearance_estimator
    return estimator


async def get_rigs(request: Request) -> RigCache:
    """Return the application's cache of compiled rigs."""
    rigs: RigCache = request.app.state.rigs
    return rigs


async def get_executors(request: Request) -> SweepExecutors:
    """Return the executors the application's sweeps run on."""
    executors: SweepExecutors = request.app.state.sweep_executors
    return executors


SettingsDep = Annotated[Settings, Depends(get_settings)]
RigsDep = Annotated[RigCache, Depends(get_rigs)]
ExecutorsDep = Annotated[SweepExecutors, Depends(get_executors)]
SessionDep = Annotated[Session, Depends(get_db)]
EstimatorDep = Annotated[ClearanceEstimator | None, Depends(get_estimator)]

_api_key_header = APIKeyHeader(
    name=API_KEY_HEADER,
    auto_error=False,
    description="API key made by `hydrodiag keys create` (or printed at first start)",
)


def require_key(
    request: Request,
    session: SessionDep,
    key: Annotated[str | None, Security(_api_key_header)],
) -> ApiKey:
    """Authenticate the request's API key and count it against the key's rate (once per
    request)."""
    cached: ApiKey | None = getattr(request.state, "api_key", None)
    if cached is None:
        with wrong_keys_counted(request, key):
            cached = authenticate(session, key, before_check=wrong_key_guard(request))
        count_rate(request, cached.prefix)
        request.state.api_key = cached
    return cached


def wrong_key_guard(request: Request) -> Callable[[], None]:
    """What runs before a key is derived (scrypt): 429 when the client's address has sent
    more wrong keys than :data:`~app.ratelimit.FAILED_KEYS_PER_MINUTE` allows."""
    def check() -> None:
        limiter: KeyRateLimiter = request.app.state.failed_keys
        wait = limiter.wait_for(client_address(request))
        if wait > 0:
            raise RateLimitError(
                f"more than {int(limiter.capacity)} wrong API keys a minute came from this "
                f"address; a key not checked before is checked again in "
                f"{limiter.retry_after(wait)} s", retry_after=limiter.retry_after(wait),
                field=API_KEY_HEADER)
    return check


@contextmanager
def wrong_keys_counted(request: Request, key: str | None) -> Iterator[None]:
    """Count a wrong key (one sent, not a missing one) against its client's address."""
    try:
        yield
    except AuthError:
        if key:
            request.app.state.failed_keys.acquire(client_address(request))
        raise


def count_rate(request: Request, prefix: str) -> None:
    """Count the request against its key's rate (429 when spent)."""
    limiter: KeyRateLimiter | None = request.app.state.rate_limiter
    if limiter is not None:
        wait = limiter.acquire(prefix)
        if wait > 0:
            raise RateLimitError(
                f"this API key is over its {int(limiter.capacity)} requests per minute; "
                f"retry in {limiter.retry_after(wait)} s", retry_after=limiter.retry_after(wait),
                field=API_KEY_HEADER)


async def require_key_on_loop(request: Request, key: str | None, needed: Scope) -> Any:
    """:func:`require_scope` for ``async`` routes: the key checked on the event loop
    (:func:`app.services.keys.authenticate_on_loop`), counted against its rate once per
    request; returns the key's row (``id``, ``name``, ``prefix``, ``scope``).

    Raises
    ------
    AuthError, ScopeError, RateLimitError
        As :func:`require_scope` (401, 403, 429).
    """
    row: Any = getattr(request.state, "api_key", None)
    if row is None:
        with wrong_keys_counted(request, key):
            row = await authenticate_on_loop(request.app.state.engine, key,
                                             before_check=wrong_key_guard(request))
        count_rate(request, row.prefix)
        request.state.api_key = row
    if not Scope(row.scope).allows(needed):
        raise ScopeError(f"this operation needs a key of scope {needed.value!r} or above; "
                         f"key {row.id} ({row.name}) has scope {row.scope!r}",
                         field=API_KEY_HEADER)
    return row


async def read_access_on_loop(
    request: Request,
    settings: SettingsDep,
    key: Annotated[str | None, Security(_api_key_header)],
) -> None:
    """:func:`read_access` for ``async`` routes: no session, no thread hand-off."""
    if not settings.open_reads:
        await require_key_on_loop(request, key, Scope.READ)


def require_scope(request: Request, session: Session, key: str | None, needed: Scope) -> ApiKey:
    """Authenticate the request's key and demand that its scope allows ``needed``.

    Raises
    ------
    AuthError
        No valid key (401).
    ScopeError
        A valid key whose scope is below ``needed`` (403).
    """
    row = require_key(request, session, key)
    if not Scope(row.scope).allows(needed):
        raise ScopeError(f"this operation needs a key of scope {needed.value!r} or above; "
                         f"key {row.id} ({row.name}) has scope {row.scope!r}",
                         field=API_KEY_HEADER)
    return row


def require_write_key(
    request: Request,
    session: SessionDep,
    key: Annotated[str | None, Security(_api_key_header)],
) -> ApiKey:
    """Demand a valid key of scope ``write`` or ``admin``."""
    return require_scope(request, session, key, Scope.WRITE)


def require_admin_key(
    request: Request,
    session: SessionDep,
    key: Annotated[str | None, Security(_api_key_header)],
) -> ApiKey:
    """Demand a valid key of scope ``admin``."""
    return require_scope(request, session, key, Scope.ADMIN)


def read_access(
    request: Request,
    settings: SettingsDep,
    session: SessionDep,
    key: Annotated[str | None, Security(_api_key_header)],
) -> None:
    """Let the request through when reads are open, else demand a valid key (any scope)."""
    if not settings.open_reads:
        require_key(request, session, key)


#: The scope each access dependency demands (read for the keyed reads); the OpenAPI
#: document states it on each operation as ``x-hydrodiag-scope``.
SCOPE_OF: dict[object, Scope] = {
    read_access: Scope.READ,
    read_access_on_loop: Scope.READ,
    require_key: Scope.READ,
    require_write_key: Scope.WRITE,
    require_admin_key: Scope.ADMIN,
}

#: The access dependencies that let reads through without a key under open reads.
OPEN_READ_ACCESS = frozenset({read_access, read_access_on_loop})

WriteKeyDep = Annotated[ApiKey, Depends(require_write_key)]
AdminKeyDep = Annotated[ApiKey, Depends(require_admin_key)]
#: The API key header as sent (``None`` when absent), for routes that write only on request.
KeyHeaderDep = Annotated[str | None, Security(_api_key_header)]
ReadAccess = Depends(read_access)


@dataclass(frozen=True, slots=True)
class PageParams:
    """Which page of a list to return."""

    limit: int
    offset: int


def page_params(
    limit: Annotated[
        int, Query(ge=1, le=500, description="Largest number of items to return [-]",
                   examples=[50])
    ] = 50,
    offset: Annotated[
        int, Query(ge=0, le=MAX_OFFSET, description="Number of items to skip [-]",
                   examples=[0])
    ] = 0,
) -> PageParams:
    """Read ``limit`` and ``offset`` from the query string."""
    return PageParams(limit=limit, offset=offset)


PageDep = Annotated[PageParams, Depends(page_params)]
