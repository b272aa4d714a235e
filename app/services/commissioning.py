"""Commission a stored rig from healthy records and store the fit as a new version.

Used by ``POST /rigs/{rig_id}/commission`` and ``hydrodiag commission``.  The fit is
:func:`diagnostics.commissioning.commission` on the rig's latest version; the parameters
the records pin down are written into a copy of that version's document (each in the unit
the document wrote it in, with a source naming the fit and its interval), stored through
:func:`app.services.rigs.update_rig`.  The guard against wear absorbed by the fit measures
each parameter's move from the value its author wrote (the newest version whose source is
not a commissioning's), not from the last fit.  Nothing is stored when any record is
invalid, the fit fails, or the fitted rig does not explain the records (χ² test at 1 %: a
record of a worn rig among them); nor when every pinned-down parameter's 95 % interval
holds the document's value (the records confirm it).
"""

from __future__ import annotations

import copy
import math
from dataclasses import asdict
from typing import Any

from sqlalchemy.orm import Session

from app.db.base import utcnow
from app.schemas.commission import CommissionRequest, CommissionResponse
from app.services import rigs as rig_service
from app.services.diagnosis import DIAGNOSIS_LOCK
from app.services.measurements import to_record
from app.services.rig_cache import RigCache
from diagnostics.commissioning import COMMISSIONED, Commissioning, commission
from sim.errors import InputError, MeasurementError
from sim.rigs import validate_rig_document
from sim.units import from_si, spelled

__all__ = ["commission_rig", "commissioned_document"]


#: what a value stored beyond the document's uncertainty on request says in its source: the
#: operator has declared the author's value wrong, so it is the origin of later guards
BEYOND_MARK = "stored beyond the document's uncertainty on request"


def commissioned_document(document: dict[str, Any], fit: Commissioning, units: dict[str, str]
                          ) -> dict[str, Any]:
    """A copy of ``document`` with the pinned-down parameters of ``fit``, each in the unit
    the document wrote it in (``units``: their SI units), its source saying what it was and
    keeping the old source: a commissioned version rewrote an author's 10 mm as
    0.01035064160016852 m and dropped "seal land" (a rig author's pass)."""
    out = copy.deepcopy(document)
    for p in fit.parameters:
        if not p.identifiable:
            continue
        role, name = p.name.split(".")
        old = out["components"][role]["parameters"][name]
        written = spelled(str(old.get("unit", units[p.name])))

        def shown(x: float, unit: str = written, canonical: str = units[p.name]) -> float:
            return from_si(x, unit, canonical)

        said = f" ({old['source']})" if old.get("source") else ""
        if p.name in fit.beyond_prior:
            said += f"; {BEYOND_MARK}"
        out["components"][role]["parameters"][name] = {
            "value": shown(p.value), "unit": written,
            "source": f"{rig_service.COMMISSIONED_SOURCE} {fit.n_records} healthy records: "
                      f"{shown(p.value):.6g} {written} (95 % interval {shown(p.low):.6g} … "
                      f"{shown(p.high):.6g}); was {shown(p.before):.6g} {written}{said}"}
    return out


def _authored(session: Session, rig_id: int, latest: dict[str, float]) -> dict[str, float]:
    """Each commissionable parameter's value [SI] in the newest version whose source for
    it is not a commissioning's (the value its author wrote, or measured and stored since)
    or is one stored beyond the guard on request (:data:`BEYOND_MARK`: the author's value
    declared wrong): the guard of a later commissioning measures from it."""
    versions, _ = rig_service.list_versions(session, rig_id, limit=10_000, offset=0)
    values: dict[int, dict[str, float]] = {}    # each version validated once, if at all
    out: dict[str, float] = {}
    for name in COMMISSIONED:
        role, key = name.split(".")
        for version in versions:           # newest first
            entry = (version.document.get("components", {}).get(role, {})
                     .get("parameters", {}).get(key))
            source = str(entry.get("source", "")) if isinstance(entry, dict) else ""
            # a value stored beyond the guard on request is the origin from then on: every
            # honest re-commissioning after it was refused (a verification pass)
            if not source.startswith(rig_service.COMMISSIONED_SOURCE) or source.endswith(
                    BEYOND_MARK):
                if version is not versions[0]:
                    if version.version not in values:
                        values[version.version] = validate_rig_document(
                            version.document).values()
                    out[name] = values[version.version].get(name, latest.get(name, math.nan))
                break
    return {k: v for k, v in out.items() if math.isfinite(v) and v > 0}


def commission_rig(session: Session, rigs: RigCache, rig_id: int, request: CommissionRequest
                   ) -> CommissionResponse:
    """Fit rig ``rig_id``'s uncertain parameters to ``request.records``; store a version.

    Raises
    ------
    NotFoundError
        No such rig.
    InputError
        A record names another rig, or is invalid (``field`` is its path).
    MeasurementError
        The fit does not explain the records (its χ² test fails): not the records of one
        healthy rig of this document (``field`` names the record that disagrees most);
        nothing is stored.
    """
    resolved = rigs.get(session, rig_id)
    now = utcnow()
    records = []
    for i, data in enumerate(request.records):
        if data.rig_id != rig_id:
            raise InputError(f"the record names rig {data.rig_id}, not {rig_id}",
                             field=f"records[{i}].rig_id")
        if data.rig_version is not None and data.rig_version != resolved.version:
            raise InputError(f"commissioning fits rig {rig_id}'s latest version "
                             f"({resolved.version}); the record states version "
                             f"{data.rig_version}", field=f"records[{i}].rig_version")
        records.append(to_record(data, path=f"records[{i}]", rig_name=resolved.name,
                                 measured_at=data.measured_at or now))
    origin = _authored(session, rig_id, resolved.rig.base)
    try:
        with DIAGNOSIS_LOCK:
            fit = commission(resolved.rig, records, request.parameters, origin=origin)
    except InputError as exc:
        raise type(exc)(exc.message, field=exc.field) from None
    if not fit.consistent:  # a version fitted to a record that is not healthy: not stored
        worst = fit.disagreements[0][0] if fit.disagreements else None
        raise MeasurementError(fit.statements[0] + "; nothing stored",
                               field="records" if worst is None else f"records[{worst}]")
    if fit.beyond_prior and not request.beyond_prior:
        far = [s for s in fit.statements if s.startswith(tuple(f"{n} (" for n in
                                                              fit.beyond_prior))]
        raise MeasurementError("; ".join(far) + "; nothing stored (send beyond_prior: true "
                               "to store it anyway)", field="beyond_prior")
    circuit = resolved.rig.circuit
    units = {}
    for p in fit.parameters:
        role, name = p.name.split(".")
        decl = circuit.parameter(role, name)
        units[p.name] = decl.unit if decl is not None else ""
    statements = list(fit.statements)
    pinned = [p for p in fit.parameters if p.identifiable]
    if all(p.low <= p.before <= p.high for p in pinned):
        # nothing the records can tell apart from the document: a version of it would only
        # split the rig's history (the /docs example, one record, stored Lc +0.36 % inside
        # a ±28 % interval, and both trends lost their 9 points; a first-day user pass)
        held = ", ".join(p.name for p in pinned) or "no parameter pinned down"
        statements.insert(0, f"the records confirm the document: each pinned-down "
                             f"parameter's 95 % interval holds its value ({held}); nothing "
                             f"stored, version {resolved.version} kept")
        version_number, stored = resolved.version, False
    else:
        document = commissioned_document(dict(resolved.document), fit, units)
        comment = request.comment or (f"commissioned from {fit.n_records} healthy records "
                                      f"(version {resolved.version})")
        _, version = rig_service.update_rig(session, rig_id, document, comment=comment)
        version_number, stored = version.version, True
    return CommissionResponse.model_validate({
        "rig_id": rig_id, "from_version": resolved.version, "version": version_number,
        "stored": stored,
        "parameters": [asdict(p) | {"unit": units[p.name]} for p in fit.parameters],
        "chi2": fit.chi2, "dof": fit.dof,
        "chi2_limit": fit.limit if math.isfinite(fit.limit) else None,
        "n_observations": fit.n_observations, "n_records": fit.n_records,
        "statements": statements})
