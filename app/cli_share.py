"""The commands' ``--calibration-share`` option: records read by the same instruments
(:mod:`diagnostics.shared_errors`), for ``diagnose --joint`` and ``commission``."""

from __future__ import annotations

from typing import Annotated, Any

import typer

__all__ = ["CalibrationShareOption", "state_share"]

#: the option, 0-1 [-]; typer refuses a value outside (exit 2, naming the option)
CalibrationShareOption = Annotated[float | None, typer.Option(
    min=0.0, max=1.0,
    help="Share of each stated variance that is the instrument's calibration error, the "
    "same in every record of the visit (1: the records were read by the same instruments; "
    "0: independent errors) \\[-], for every record that states none.")]


def state_share(records: Any, share: float | None) -> None:
    """Set ``calibration_share`` to ``share`` on every record (a dict, or a list of them)
    of ``records`` that states none; nothing where ``share`` is None.  What is not a
    record is left for the request's validation to name."""
    if share is None:
        return
    for item in records if isinstance(records, list) else [records]:
        if isinstance(item, dict):
            item.setdefault("calibration_share", share)
