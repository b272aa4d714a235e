"""Wear first, then the effect: a rig in service that has worn *and* lacks some physics.

The workflow confirms each balance's chosen effect by re-simulating the *stored* rig with
it (:mod:`~diagnostics.discrepancy.confirm`).  On a rig whose clearances have also opened,
the held-out gap is dominated by the wear and the effect is rejected; the base re-fit
(:mod:`~diagnostics.discrepancy.drift`) cannot close the gap either, since the missing law
pushes a friction parameter to its bound.  Measured on the HTTP test's hidden effect
(pressure-dependent seal friction, k_p = 1.5e-5 m²) with a worn piston (cc 120 µm, the
``worn_piston`` scenario): the selection chose the right entry, its confirmation was
rejected, the base re-fit ended with Kf on its bound, and the answer was "unexplained".

So when nothing was confirmed, a balance had proposed an effect and no drift closes the
gap, the wear re-fitted alone (:attr:`~diagnostics.discrepancy.drift.Drift.wear`, the
friction kept as stored) is written into the rig document (:func:`worn_document`) and the
workflow runs again from that worn rig.  An effect confirmed there is named
(:func:`named_after_wear`); on the case above: cc +45.0 % (truth +44.6 %), then
seal_friction_pressure with k_p 1.46e-5 m² (interval 1.44-1.49e-5).

What is stored is the stored rig with the effect: the wear is reported, not stored — a
clearance that opened is what ``POST /diagnose`` sizes against the healthy rig, and writing
it into the rig would hide it.  The gap before is the one against the stored rig; the gap
after is that of the rig with the wear and the effect, the model that explains the data.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from diagnostics.discrepancy.drift import Drift
from diagnostics.discrepancy.refit import with_effects

if TYPE_CHECKING:
    from diagnostics.discrepancy.workflow import Discovery

__all__ = ["WORN_SOURCE", "named_after_wear", "worn_document"]

#: source written beside each re-fitted wear parameter of the worn document
WORN_SOURCE = "re-fitted wear (discrepancy workflow; reported, not stored)"


def worn_document(doc: Mapping[str, Any], wear: Drift) -> dict[str, Any]:
    """A copy of the rig document ``doc`` with the re-fitted wear parameters of ``wear``
    (``role.name`` → value in its SI unit) written into its components, each with that
    unit (the document may state it in another, e.g. µm)."""
    out = copy.deepcopy(dict(doc))
    for p in wear.parameters:
        role, _, name = p.parameter.partition(".")
        out["components"][role]["parameters"][name] = {"value": p.value, "unit": p.unit,
                                                       "source": WORN_SOURCE}
    return out


def named_after_wear(first: Discovery, again: Discovery, doc: Mapping[str, Any],
                     wear: Drift) -> Discovery:
    """The answer when ``again`` (the workflow run from :func:`worn_document`) named an
    effect that ``first`` (the run from the stored rig ``doc``) could not confirm: the
    names and the gap after from ``again``, the gap before and the held-out comparison
    against the stored rig from ``first``, the stored rig with the effects as the new
    document, and the wear reported as the base re-fit."""
    values = {f"{n.name}.{n.parameter}": n.value for n in again.named}
    why = first.base_drift.reason if first.base_drift is not None else ""
    message = (f"{again.message}; named on the rig with its wear re-fitted first, alone "
               f"({wear.statement()}): on the stored rig the effect was not confirmed and "
               f"no drift closed the gap ({why}). The wear is reported, not stored (POST "
               "/diagnose sizes it against the stored rig); the new version is the stored "
               "rig with the effect")
    reported = dataclasses.replace(
        wear, reason="re-fitted first, alone; the effect was named on the rig with this "
        "wear (reported, not stored)")
    traces = dict(again.traces)
    for key in ("before", "before_all"):
        if key in first.traces:
            traces[key] = first.traces[key]
    return dataclasses.replace(
        again, message=message, gap_before=first.gap_before,
        whiteness_before=first.whiteness_before, rig_document=with_effects(doc, values),
        traces=traces, base_drift=reported)
