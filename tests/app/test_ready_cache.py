"""``/ready`` leaves the engine's statement cache alone: Alembic builds a new
``alembic_version`` table at each revision read, and each probe compiled into a new cache
entry (up to the cache's 500), pushing the service's own statements out."""

from __future__ import annotations

from pathlib import Path

from sqlalchemy.engine import make_url

from app.db import migrate
from app.db.engine import make_engine
from tests.app.live import LiveServer


def test_probes_add_no_statement_cache_entries(server: LiveServer) -> None:
    engine = server.app.state.engine
    assert server.anon.get("/ready").status_code == 200
    before = len(engine._compiled_cache)  # SQLAlchemy's LRU of compiled statements
    for _ in range(50):
        assert server.anon.get("/ready").status_code == 200
    assert len(engine._compiled_cache) == before


def test_reading_the_revision_caches_nothing(tmp_path: Path) -> None:
    engine = make_engine(make_url(f"sqlite:///{tmp_path / 'store.db'}"))
    migrate.upgrade(engine)
    before = len(engine._compiled_cache)
    for _ in range(20):
        assert migrate.current_revision(engine) == migrate.head_revision()
    assert len(engine._compiled_cache) == before
    engine.dispose()
