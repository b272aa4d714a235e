"""The discrepancy workflow (issue 8): :func:`discover` and its report.

See :mod:`diagnostics.discrepancy.workflow` for the steps, :mod:`.balances` for the
equation-error residuals, :mod:`.selection` for the statistics and
:mod:`sim.components.effects` for the library of named effects.
"""

from diagnostics.discrepancy.workflow import Discovery, NamedEffect, discover

__all__ = ["Discovery", "NamedEffect", "discover"]
