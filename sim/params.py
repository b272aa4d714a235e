"""Parameter declarations: every physical parameter has a name, unit, default and source."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

__all__ = ["Param", "Relation", "at_least", "at_most", "broken_relation", "param_table"]


@dataclass(frozen=True, slots=True)
class Param:
    """Declaration of one physical parameter of a component.

    Attributes
    ----------
    name
        Identifier used in rig files and overrides (``"cc"``, ``"Dv"``).
    unit
        Canonical SI unit (a key of :data:`sim.units.UNITS`).
    default
        Default value [unit].
    source
        Where the default comes from (paper and equation/table, or "chosen: why").
    description
        One line for humans.
    lower, upper
        Physical bounds [unit]; a value outside raises :class:`~sim.errors.ParameterError`.
    lower_inclusive
        Whether ``lower`` itself is allowed (a clearance of 0 is not, a leakage of 0 is).
    """

    name: str
    unit: str
    default: float
    source: str
    description: str
    lower: float | None = 0.0
    upper: float | None = None
    lower_inclusive: bool = False


def param_table(params: Iterable[Param]) -> dict[str, Param]:
    """Index declarations by name, refusing duplicates."""
    out: dict[str, Param] = {}
    for p in params:
        if p.name in out:
            raise ValueError(f"duplicate parameter {p.name!r}")
        out[p.name] = p
    return out


@dataclass(frozen=True, slots=True)
class Relation:
    """A bound of one parameter by others of the same component (its geometry).

    Attributes
    ----------
    name
        The parameter bounded (named in the error).
    text
        The bound in words, for the error (``"the rod must be thinner than the bore"``).
    holds
        Whether the component's values [SI, by parameter name] keep it.
    bound
        A plausibility bound of the parameter alone (:func:`at_most`, :func:`at_least`),
        checked before the relations between parameters.
    """

    name: str
    text: str
    holds: Callable[[Mapping[str, float]], bool]
    bound: bool = False


def at_most(name: str, limit: float, unit: str, what: str) -> Relation:
    """The plausibility bound ``name ≤ limit`` [``unit``]: ``what`` says past which built
    thing it lies.  Checked when a document is stored and on overrides, like a geometric
    relation, not on stored documents read back (one stored before the bound still
    loads).  A value past it is a unit slip: a bore of 63 "m" was stored and made
    ``/simulate`` fail with a 500 (an engineer's pass)."""
    return Relation(name, f"{name} must be at most {limit:g} {unit} ({what}; a larger value "
                    f"is likely a unit slip, e.g. {_LARGER_SLIPS.get(unit, f'a smaller unit as {unit}')})",
                    lambda p: p[name] <= limit, bound=True)


#: the likely slip behind a value too large for its SI unit (a speed in rpm was said to be
#: "mm written as m": a CLI pass)
_LARGER_SLIPS = {"m": "mm written as m", "rad/s": "rpm written as rad/s",
                 "m^3/rad": "cm³/rev or L/rev written as m³/rad"}


def at_least(name: str, limit: float, unit: str, what: str) -> Relation:
    """The plausibility bound ``name ≥ limit`` [``unit``], checked like :func:`at_most`:
    ``what`` says why a smaller value is not the built thing.  A relief set at 0.5 bar
    (below the supply line's drop) was stored and its rig could not extend (an engineer's
    pass)."""
    return Relation(name, f"{name} must be at least {limit:g} {unit} ({what}; a smaller "
                    "value is likely a unit slip, e.g. kPa or bar written as Pa)",
                    lambda p: p[name] >= limit, bound=True)


def broken_relation(relations: Iterable[Relation], values: Mapping[str, float]
                    ) -> Relation | None:
    """The first of ``relations`` that ``values`` [SI, by parameter name] break, or None:
    the plausibility bounds first, so that a unit slip is named as one (a clearance of 30
    "m" read "must be less than the bore's radius", not "likely a unit slip": a rig
    author's pass)."""
    ordered = sorted(relations, key=lambda r: not r.bound)
    return next((r for r in ordered if not r.holds(values)), None)
