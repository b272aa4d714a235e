"""The one exception tree of hydrodiag.

Every error that the library raises on purpose derives from :class:`HydrodiagError`.
``sim`` defines the root and the model/parameter branches; ``diagnostics`` and ``app``
add subclasses of these branches, never new roots.  The service maps the tree to HTTP
status codes in a single place (``app.errors``):

=============================  =======  =============================================
class                          HTTP     meaning
=============================  =======  =============================================
``InputError``                 422      a value given by the caller is invalid
``ParameterError``             422      a rig / component parameter is invalid
``RigFileError``               422      a rig description file is invalid
``SolverLimitError``           422      the run needs more than the solver limits allow
``MeasurementError``           422      a measurement record is invalid or contradictory
``ModelStructureError``        422      a bond graph cannot be turned into equations
``CausalityError``             422      causality conflict (names the elements)
``DerivativeCausalityError``   422      a storage element ended in derivative causality
``AlgebraicLoopError``         422      an algebraic loop (names the elements)
``NotFoundError``              404      an id that does not exist
``ConflictError``              409      a write that contradicts stored state
``AuthError``                  401      missing or wrong API key
``SimulationError``            500      the solver failed (step size underflow, ...)
=============================  =======  =============================================
"""

from __future__ import annotations

__all__ = [
    "AlgebraicLoopError",
    "AuthError",
    "CausalityError",
    "CircuitError",
    "ConflictError",
    "DerivativeCausalityError",
    "HydrodiagError",
    "InputError",
    "MeasurementError",
    "ModelStructureError",
    "NotFoundError",
    "ParameterError",
    "RigFileError",
    "SimulationError",
    "SolverLimitError",
]


class HydrodiagError(Exception):
    """Root of every error raised on purpose by hydrodiag.

    Parameters
    ----------
    message
        Human-readable explanation.
    field
        Dotted path of the offending input field, when there is one
        (``"components.cylinder.cc"``, ``"records[2].flow_B"``).
    """

    #: every problem when the error stands for several (a batch's refused records), each
    #: ``{"field": ..., "message": ...}``, the first of them the error's own; None for one
    details: list[dict[str, str | None]] | None = None

    def __init__(self, message: str, *, field: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.field = field

    def __str__(self) -> str:
        return f"{self.field}: {self.message}" if self.field else self.message


class InputError(HydrodiagError):
    """A value supplied by the caller is invalid."""


class SolverLimitError(InputError):
    """The solver stopped at a limit before the run was done.

    An input error because the caller asked for more than the limits allow: a tolerance
    or accuracy so tight, or a simulated time so long, that the run needs more steps, more
    simulated time or more wall-clock time than the configured maximum (or a step size
    below round-off).  The message names the limit, its value, the tolerance and the
    simulated time reached; a looser tolerance or a shorter run is the remedy.
    """


class ParameterError(InputError):
    """A rig or component parameter is missing, has the wrong unit or an impossible value."""


class RigFileError(ParameterError):
    """A rig description file (YAML/JSON) does not validate."""


class CircuitError(InputError):
    """The rig's circuit has not the part an operation needs (a cylinder's working/return
    cycle for a cycle simulation or a diagnosis); the message names the circuit."""


class MeasurementError(InputError):
    """A measurement record is invalid, impossible or self-contradictory."""


class ModelStructureError(InputError):
    """A bond graph cannot be turned into state equations.

    Parameters
    ----------
    message
        Explanation.
    elements
        Names of the elements involved, so the engineer can find them on the drawing.
    """

    def __init__(self, message: str, *, elements: tuple[str, ...] = (), field: str | None = None):
        super().__init__(message, field=field)
        self.elements = elements


class CausalityError(ModelStructureError):
    """Causality cannot be assigned without conflict (e.g. two effort sources on a 0-junction)."""


class DerivativeCausalityError(CausalityError):
    """A storage element (C or I) would have to be in derivative causality."""


class AlgebraicLoopError(ModelStructureError):
    """The causal equations contain an algebraic loop."""


class NotFoundError(HydrodiagError):
    """An identifier that does not exist in the store."""


class ConflictError(HydrodiagError):
    """A write that contradicts what is stored (duplicate name, version clash)."""


class AuthError(HydrodiagError):
    """Missing or wrong API key."""


class SimulationError(HydrodiagError):
    """The numerical solution failed (step-size underflow, no steady state found)."""
