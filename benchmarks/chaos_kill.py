"""Durability under kill -9 for ``make chaos``, on SQLite and on PostgreSQL.

``rounds`` rounds: three writer threads (``POST /diagnose`` with ``store``,
``POST /rigs/1/calibrations``, ``POST /pump-sets``) write as fast as the service answers;
after a random 1-3 s the server gets SIGKILL mid-load, is restarted on the same store,
and the store's integrity is checked: ``PRAGMA integrity_check`` on SQLite; on PostgreSQL
the ``amcheck`` extension's ``verify_heapam`` on every table and ``bt_index_check`` on
every B-tree index of the schema.  At the end every acknowledged write (a 2xx with its
id) is read back over HTTP; a write missing is a lost write.  The PostgreSQL rounds run
against a throw-away cluster started as the tests start theirs
(:mod:`tests.app.postgres`), where its server programs and psycopg are installed.
"""

from __future__ import annotations

import os
import random
import signal
import sqlite3
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx
import sqlalchemy as sa

from benchmarks.chaos_server import Server, start, stop, wait_ready

__all__ = ["RECORD", "TABLE", "kill_rounds", "postgres_integrity", "sqlite_integrity"]

TABLE = {"throttle": "I", "component": "valve", "back_pressure_pa": 1.0e6,
         "temperature_c": 40.0, "source": "chaos", "points": [
             {"opening_turns": 0.0, "bypass_flow_m3s": 1.0e-5, "clearance_m": 40e-6},
             {"opening_turns": 1.0, "bypass_flow_m3s": 3.0e-5, "clearance_m": 60e-6}]}
RECORD = {"rig_id": 1, "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
          "pump_pressure": 14.6e5, "p1": 11.9e5, "p2": 1.2e5, "flow_B": 4.44e-4,
          "flow_C": 3.97e-4, "speed_work": 0.180, "speed_return": 0.215}


@dataclass
class Acked:
    """Writes the service acknowledged (2xx with an id), by kind."""

    ids: dict[str, list[int]] = field(default_factory=lambda: {
        "diagnoses": [], "calibrations": [], "pump_sets": []})
    lock: threading.Lock = field(default_factory=threading.Lock)

    def add(self, kind: str, ident: int) -> None:
        with self.lock:
            self.ids[kind].append(ident)


def _writer(server: Server, kind: str, acked: Acked, stop_event: threading.Event,
            seq: list[int]) -> None:
    with httpx.Client(base_url=server.base_url, headers=server.auth, timeout=30) as client:
        while not stop_event.is_set():
            try:
                if kind == "diagnoses":
                    response = client.post("/diagnose", json={"record": RECORD})
                    ident = response.json()["diagnoses"][0]["id"] if response.is_success \
                        else None
                elif kind == "calibrations":  # one table per condition: vary it
                    response = client.post("/rigs/1/calibrations", json=TABLE | {
                        "back_pressure_pa": random.uniform(1e5, 5e6),
                        "temperature_c": random.uniform(10.0, 80.0)})
                    ident = response.json()["id"] if response.is_success else None
                else:
                    seq[0] += 1
                    response = client.post("/pump-sets", json={
                        "name": f"chaos-{os.getpid()}-{seq[0]}-{random.getrandbits(32)}",
                        "kind": "parameters", "pump": "gear",
                        "quantities": {"Cs": {"value": 2.1e-9, "unit": "1"}}})
                    ident = response.json()["id"] if response.is_success else None
            except (httpx.TransportError, ValueError):
                continue  # the server was killed: this write was never acknowledged
            if ident is not None:
                acked.add(kind, int(ident))


def _present(server: Server, kind: str, ident: int) -> bool:
    path = {"diagnoses": f"/diagnoses/{ident}", "calibrations": f"/rigs/1/calibrations/{ident}",
            "pump_sets": f"/pump-sets/{ident}"}[kind]
    return httpx.get(server.base_url + path, headers=server.auth, timeout=30).status_code == 200


def sqlite_integrity(data_dir: Path) -> str:
    """``PRAGMA integrity_check`` of the SQLite store in ``data_dir`` (``ok`` when sound)."""
    with sqlite3.connect(data_dir / "hydrodiag.db") as db:
        return str(db.execute("PRAGMA integrity_check").fetchone()[0])


def postgres_integrity(url: str) -> str:
    """Check every table and B-tree index of the PostgreSQL store with ``amcheck``.

    Returns
    -------
    str
        ``ok``, or the problems found (heap corruption messages, index check errors).
    """
    engine = sa.create_engine(url)
    problems: list[str] = []
    try:
        with engine.connect() as connection:
            connection.execute(sa.text("CREATE EXTENSION IF NOT EXISTS amcheck"))
            connection.commit()
            tables = connection.execute(sa.text(
                "SELECT c.oid::regclass::text FROM pg_class c JOIN pg_namespace n "
                "ON n.oid = c.relnamespace WHERE n.nspname = 'public' AND c.relkind = 'r'"
            )).scalars().all()
            for table in tables:
                rows = connection.execute(sa.text(
                    "SELECT msg FROM verify_heapam(CAST(:t AS regclass))"), {"t": table}).all()
                problems += [f"{table}: {row[0]}" for row in rows]
            indexes = connection.execute(sa.text(
                "SELECT c.oid::regclass::text FROM pg_index i "
                "JOIN pg_class c ON c.oid = i.indexrelid "
                "JOIN pg_am a ON a.oid = c.relam JOIN pg_namespace n ON n.oid = c.relnamespace "
                "WHERE n.nspname = 'public' AND a.amname = 'btree'")).scalars().all()
            for index in indexes:
                try:
                    connection.execute(sa.text("SELECT bt_index_check(CAST(:i AS regclass), true)"),
                                       {"i": index})
                except sa.exc.DBAPIError as exc:
                    connection.rollback()
                    problems.append(f"{index}: {exc.orig}")
    finally:
        engine.dispose()
    return "ok" if not problems else "; ".join(problems)


def kill_rounds(work: Path, rounds: int, name: str = "kill",
                database_url: str | None = None) -> dict[str, Any]:
    """SIGKILL the server under concurrent writers; count lost acknowledged writes.

    Parameters
    ----------
    work
        Folder for the service's data folder (``work/name``).
    rounds
        Kill rounds [-].
    database_url
        The store; ``None``: SQLite in the data folder.
    """
    data_dir = work / name
    data_dir.mkdir()
    server = start(data_dir, database_url=database_url)
    wait_ready(server)
    key = server.key
    acked = Acked()
    per_round, integrity, restarts = [], [], []
    rng = random.Random(14)
    try:
        for _ in range(rounds):
            stop_event = threading.Event()
            seq = [0]
            threads = [threading.Thread(target=_writer, args=(server, kind, acked, stop_event,
                                                              seq))
                       for kind in ("diagnoses", "calibrations", "pump_sets")]
            before = {k: len(v) for k, v in acked.ids.items()}
            for thread in threads:
                thread.start()
            time.sleep(rng.uniform(1.0, 3.0))
            os.kill(server.process.pid, signal.SIGKILL)
            server.process.wait(timeout=30)
            stop_event.set()
            for thread in threads:
                thread.join(timeout=60)
            started = time.perf_counter()
            server = start(data_dir, key, database_url=database_url)
            restarts.append(time.perf_counter() - started)
            integrity.append(sqlite_integrity(data_dir) if database_url is None
                             else postgres_integrity(database_url))
            per_round.append({k: len(v) - before[k] for k, v in acked.ids.items()})
            wait_ready(server)  # the next round writes to a warmed service
        lost = {kind: sum(not _present(server, kind, i) for i in ids)
                for kind, ids in acked.ids.items()}
    finally:
        stop(server)
    return {
        "store": "sqlite" if database_url is None else "postgresql",
        "rounds": rounds,
        "acknowledged": {k: len(v) for k, v in acked.ids.items()},
        "acknowledged_total": sum(len(v) for v in acked.ids.values()),
        "lost": lost,
        "lost_total": sum(lost.values()),
        "integrity_ok": sum(i == "ok" for i in integrity),
        "integrity_problems": [i for i in integrity if i != "ok"][:3],
        "restart_s_max": round(max(restarts), 2),
        "per_round": per_round,
    }
