"""What an older release writes into a migrated store, made whole at each start.

An operator who upgrades one instance while an older one still serves the same store
(a rolling upgrade) has the store migrated under the older instance, which keeps
answering and writing rows in its own schema: its diagnoses were linked to no record
(``diagnosis_records``, revision 0008) and kept no 95 % interval in their estimates
(``diagnosis_estimates.low``/``high``, revision 0012), and no later start mended them (an
upgrade pass).  :func:`repair_store` runs after every migration check of a start: it
links each diagnosis that has no record to the one its result is kept with, as revision
0008 did, and fills the interval of each estimate that has none from its diagnosis's
stored result, as revision 0012 did.  Both are no-ops on a store only this release wrote
(one indexed query each).

Which records a joint diagnosis made by the older release also used was not kept by it:
that link cannot be made (as revision 0008 said).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import sqlalchemy as sa
from sqlalchemy import Engine

from app.db.models import Diagnosis, DiagnosisEstimate, DiagnosisRecord
from app.services.history import stated_bound

__all__ = ["Repaired", "repair_store"]

#: estimates filled per statement
BATCH = 1000


@dataclass(frozen=True)
class Repaired:
    """What :func:`repair_store` mended: diagnoses linked to their record, estimates given
    their interval."""

    links: int
    intervals: int

    def __bool__(self) -> bool:
        return bool(self.links or self.intervals)


def _bound(result: Any, component: str, bound: str) -> float | None:
    return stated_bound(result, component, bound) if isinstance(result, dict) else None


def repair_store(engine: Engine) -> Repaired:
    """Link unlinked diagnoses to their record and fill missing estimate intervals
    (module docstring); return what was mended."""
    links = cast(sa.Table, DiagnosisRecord.__table__)
    diagnoses = cast(sa.Table, Diagnosis.__table__)
    estimates = cast(sa.Table, DiagnosisEstimate.__table__)
    with engine.begin() as connection:
        unlinked = (sa.select(diagnoses.c.id, diagnoses.c.measurement_id)
                    .where(~sa.exists().where(links.c.diagnosis_id == diagnoses.c.id)))
        added = connection.execute(
            sa.insert(links).from_select(["diagnosis_id", "measurement_id"], unlinked))
        linked = max(added.rowcount or 0, 0)
        filled = 0
        last = 0
        update = (sa.update(estimates).where(estimates.c.id == sa.bindparam("row"))
                  .values(low=sa.bindparam("lo"), high=sa.bindparam("hi")))
        while True:
            rows = connection.execute(
                sa.select(estimates.c.id, estimates.c.component, diagnoses.c.result)
                .join(diagnoses, diagnoses.c.id == estimates.c.diagnosis_id)
                .where(estimates.c.id > last, estimates.c.low.is_(None),
                       estimates.c.high.is_(None))
                .order_by(estimates.c.id).limit(BATCH)).all()
            if not rows:
                break
            last = int(rows[-1][0])
            values = [{"row": int(i), "lo": _bound(result, component, "low"),
                       "hi": _bound(result, component, "high")} for i, component, result in rows]
            values = [v for v in values if v["lo"] is not None or v["hi"] is not None]
            if values:
                connection.execute(update, values)
                filled += len(values)
    return Repaired(linked, filled)
