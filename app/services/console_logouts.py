"""Console sessions ended on the server (revision 0015).

The console's login cookie is signed and stateless (:mod:`app.console.web`): deleting it
in the browser did not end a copy of it.  A logout keeps the SHA-256 of the cookie until
the cookie would have expired; a cookie found here is refused.
"""

from __future__ import annotations

import hashlib
from datetime import datetime

from sqlalchemy import delete, select
from sqlalchemy.dialects.postgresql import insert as pg_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.orm import Session

from app.db.base import utcnow
from app.db.models import ConsoleLogout
from app.services.common import commit

__all__ = ["digest", "end_session", "is_ended"]


def digest(cookie: str) -> str:
    """The SHA-256 (hex) of a cookie's value: what is kept of it (never the cookie)."""
    return hashlib.sha256(cookie.encode()).hexdigest()


def end_session(session: Session, cookie: str, expires_at: datetime) -> None:
    """Refuse ``cookie`` from now until ``expires_at`` [UTC], and remove the rows of
    sessions that have expired since.  Ending a session twice is no error."""
    values = {"digest": digest(cookie), "expires_at": expires_at}
    insert = (pg_insert if session.get_bind().dialect.name == "postgresql"
              else sqlite_insert)(ConsoleLogout).values(**values)
    session.execute(insert.on_conflict_do_nothing(index_elements=["digest"]))
    session.execute(delete(ConsoleLogout).where(ConsoleLogout.expires_at < utcnow()))
    commit(session, conflict="the console session changed concurrently")


def is_ended(session: Session, cookie: str) -> bool:
    """Whether a logout ended the session ``cookie`` carries."""
    return session.scalar(select(ConsoleLogout.id).where(
        ConsoleLogout.digest == digest(cookie))) is not None
