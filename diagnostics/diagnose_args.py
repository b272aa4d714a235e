"""The arguments of :func:`diagnostics.diagnose.diagnose`, checked before any work.

A wrong type raised a bare Python error outside the exception tree (``None`` for the rig,
a dict for a record, ``method="fastest"``: a library user's pass); each is now the tree's
error naming the argument.
"""

from __future__ import annotations

from collections.abc import Sequence

from diagnostics.measurement import MeasurementRecord
from diagnostics.ranking import Method, check_method
from sim.errors import MeasurementError, ParameterError
from sim.numbers import field_number
from sim.rigs.assembly import require_rig

__all__ = ["check_arguments"]


def check_arguments(rig: object, records: object, model_rel: object, method: object) -> Method:
    """Refuse arguments :func:`~diagnostics.diagnose.diagnose` cannot use; the ranking
    method to use.

    Parameters
    ----------
    rig
        Must be a compiled :class:`~sim.rigs.Rig`.
    records
        Must be a non-empty sequence of :class:`~diagnostics.measurement.MeasurementRecord`.
    model_rel
        The model's relative error [-], in [0, 1).
    method
        ``"fast"``, ``"direct"`` or None (the default).

    Raises
    ------
    InputError
        No compiled rig (``field="rig"``), an unknown method (``field="method"``).
    MeasurementError
        ``records`` a single record, empty or not a sequence (``field="records"``), an
        item that is no record (``field="records[i]"``).
    ParameterError
        ``model_rel`` outside [0, 1) (``field="model_rel"``).
    """
    require_rig(rig)
    chosen = check_method(method)
    if isinstance(records, MeasurementRecord):
        # "'MeasurementRecord' object is not iterable" (a library user's pass)
        raise MeasurementError("records is a list of records: diagnose(rig, [record])",
                               field="records")
    if not isinstance(records, Sequence) or isinstance(records, str):
        raise MeasurementError(f"records is a list of MeasurementRecord objects, not a "
                               f"{type(records).__name__}", field="records")
    if not records:
        raise MeasurementError("at least one record is needed", field="records")
    for i, rec in enumerate(records):
        if not isinstance(rec, MeasurementRecord):
            # a dict raised "'dict' object has no attribute 'condition'"
            raise MeasurementError(
                f"records are MeasurementRecord objects (MeasurementRecord.from_readings("
                f"rig_id, condition, readings)), not a {type(rec).__name__}",
                field=f"records[{i}]")
    # the numbers every other argument takes (a numpy float; not a bool: a verification
    # pass found np.float32(0.02) refused and False taken)
    rel = field_number(model_rel, "model_rel", error=ParameterError,
                       expected="the model's relative error, in [0, 1),")
    if not 0.0 <= rel < 1.0:
        # unchecked, −1, inf or 5 turned a worn spool into "healthy" (a library user's pass)
        raise ParameterError(f"model_rel is the model's relative error, in [0, 1), not "
                             f"{model_rel!r}", field="model_rel")
    return chosen
