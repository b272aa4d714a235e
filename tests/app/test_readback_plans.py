"""How SQLite reads a page of a long history (``app/services/readback.py``, the console's
history and the trends): through the records' (rig, time) index, in order, the page's rows
read whole by id — not every stored diagnosis sorted to return fifty (a store-scale pass:
1.1 s for the first page of 100,000, ``make history-bench``).

The plans are those of a freshly migrated store without statistics, as every store is
(nothing runs ``ANALYZE``); they depend on the schema and the statements, not on the rows.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest
from sqlalchemy import Engine, event
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session

from app.console.views import history_page
from app.db import migrate
from app.db.engine import make_engine, make_session_factory
from app.services import readback


@pytest.fixture(scope="module")
def engine(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Engine]:
    folder = tmp_path_factory.mktemp("plans")
    engine = make_engine(make_url(f"sqlite:///{folder / 'plans.db'}"))
    migrate.upgrade(engine)
    yield engine
    engine.dispose()


def _plans(engine: Engine, read: Callable[[Session], Any]) -> list[tuple[str, list[str]]]:
    """Each SELECT that ``read`` ran, with SQLite's query plan for it."""
    seen: list[tuple[str, Any]] = []

    def capture(_conn: Any, _cursor: Any, statement: str, parameters: Any, _context: Any,
                _many: bool) -> None:
        if statement.lstrip().upper().startswith("SELECT"):
            seen.append((statement, parameters))

    event.listen(engine, "before_cursor_execute", capture)
    try:
        with make_session_factory(engine)() as session:
            read(session)
    finally:
        event.remove(engine, "before_cursor_execute", capture)
    with engine.connect() as connection:
        return [(sql, [row[3] for row in connection.exec_driver_sql(
            "EXPLAIN QUERY PLAN " + sql, parameters)]) for sql, parameters in seen]


def _paged(plans: list[tuple[str, list[str]]]) -> list[tuple[str, list[str]]]:
    paged = [(sql, plan) for sql, plan in plans if "LIMIT" in sql]
    assert paged, plans
    return paged


@pytest.mark.parametrize("filters", [{"rig_id": 1}, {"rig_id": 1, "component": "valve"}])
def test_a_rigs_page_of_diagnoses_walks_the_records_time_index(
        engine: Engine, filters: dict[str, Any]) -> None:
    plans = _plans(engine, lambda s: readback.list_diagnoses(s, limit=50, offset=0, **filters))
    for sql, plan in _paged(plans):
        assert any("ix_measurements_rig_id" in step for step in plan), (sql, plan)
        # at most the diagnoses of one record are sorted (a re-diagnosed record has two)
        assert "USE TEMP B-TREE FOR ORDER BY" not in plan, (sql, plan)
        assert "result" not in sql.split("FROM")[0], sql  # the ids alone


def test_a_page_reads_its_rows_whole_by_id_only(engine: Engine) -> None:
    plans = _plans(engine, lambda s: readback.list_diagnoses(s, limit=50, offset=0))
    # an empty store: the ids and the count, and no read of whole rows
    assert all("diagnoses.result" not in sql for sql, _ in plans), plans
    assert len(_paged(plans)) == 1


def test_a_rigs_page_of_records_and_the_consoles_history_walk_the_index(
        engine: Engine) -> None:
    for read in (lambda s: readback.list_measurements(s, limit=50, offset=0, rig_id=1),
                 lambda s: history_page(s, rig_id=1)):
        for sql, plan in _paged(_plans(engine, read)):
            assert any("ix_measurements_rig_id" in step for step in plan), (sql, plan)
            assert "USE TEMP B-TREE FOR ORDER BY" not in plan, (sql, plan)


def test_a_listing_of_series_leaves_their_samples_unread(engine: Engine) -> None:
    """A rig's series are listed without their samples (the listing shows none: the 2,215
    ZeMA cycles took 249 ms to list with them, 28 ms without)."""
    from sqlalchemy import inspect

    from app.db.models import MeasuredSeries, Rig
    from app.services.series import list_series

    with make_session_factory(engine)() as session:
        rig = Rig(name="plans", title="plans", latest_version=1)
        session.add(rig)
        session.flush()
        session.add(MeasuredSeries(
            rig_id=rig.id, name="log", record="cycle-1", sample_rate=1.0, n_samples=2,
            measured=True, units={"p_pump": "Pa"}, condition={}, measured_at=None,
            data={"t": [0.0, 1.0], "channels": {"p_pump": [1e7, 1.1e7]}}))
        session.commit()
        rig_id = rig.id
    with make_session_factory(engine)() as session:
        rows, total = list_series(session, rig_id, limit=10, offset=0)
        assert total == 1 and rows[0].n_samples == 2
        assert "data" in inspect(rows[0]).unloaded
