"""Posterior probabilities of the fault hypotheses: evidences combined with a fleet prior.

:mod:`diagnostics.ranking` fits every hypothesis of :data:`diagnostics.hypotheses.HYPOTHESES`
and returns its log-evidence ln Z_h (the likelihood ``exp(−χ²/2)`` integrated over the
hypothesis's uniform prior in its fitting coordinates, MacKay 2003 ch. 28 eq. 28.8):

* healthy: no parameter, ln Z = −χ²/2;
* single faults: quadrature of the likelihood over the 241-point signature map of the
  worn range (exact to the grid, also where the likelihood is flat or sits on a bound);
* pairs: Laplace approximation at the Gauss-Newton optimum with the Gaussian mass
  truncated at the bounds, replaced by a profile integral (quadrature along the weak axis,
  Laplace across it) where the likelihood is a ridge, which the Laplace value misstates
  either way (it overstates a ridge along an axis and understates one across both axes,
  where JᵀJ is near singular, by orders of magnitude).

Singles and pairs integrate over *worn* ranges only (each parameter past the ``none``
severity, :meth:`diagnostics.hypotheses.FaultParameter.worn_bounds`): a pair does not
contain its single faults nor a single the healthy rig, so the hypotheses are exclusive
and the Occam factor of each is the share of its own prior volume the data allow.

This module turns those evidences into probabilities, once per diagnosis:

.. math:: P(h \\mid y) = \\frac{π_h Z_h}{\\sum_{g \\in O} π_g Z_g}, \\qquad h \\in O

over the set O of hypotheses observable with the present sensors at the present
conditions (an unobservable one has the healthy evidence and says nothing; it gets
probability 0 and is reported as not observable).  The prior π is the **fleet prior**
:data:`FLEET_PRIOR`: with no fleet statistics for this rig type, every hypothesis of the
library is equally likely before the readings (1/9 each: healthy, five single faults,
three pairs).  The accuracy study (``make accuracy``) draws its in-library cases from
this prior *and* the parameter priors of :mod:`diagnostics.hypotheses` (truths with these
frequencies, each fault parameter uniform in its fitting coordinate over its worn range),
so its reliability table tests the evidences, not a mismatch between the prior and the
draw.  A
user with fleet statistics passes their own prior to :func:`posterior`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from diagnostics.hypotheses import HYPOTHESES

if TYPE_CHECKING:
    from diagnostics.ranking import HypothesisFit, Ranker

__all__ = ["FLEET_PRIOR", "acting_relief_setting", "map_log_evidence", "map_support",
           "opening_pressure", "posterior", "whitening"]

#: prior probability of each hypothesis before the readings [-] (sums to 1); source: no
#: fleet statistics, every hypothesis of the library equally likely
FLEET_PRIOR: Mapping[str, float] = {h.name: 1.0 / len(HYPOTHESES) for h in HYPOTHESES}


def opening_pressure(ranker: Ranker) -> float:
    """Highest pump pressure of the healthy rig over the records' conditions [Pa]: a relief
    setting below it opens in some record, one above it in none (NaN if not predicted)."""
    from diagnostics.signatures import OBSERVABLES

    k = OBSERVABLES.index("pump_pressure")
    vals = [float(m.maps.nominal[k]) for m in ranker.models]
    return max(vals) if vals and all(math.isfinite(v) for v in vals) else math.nan


def acting_relief_setting(ranker: Ranker, fits: Sequence[HypothesisFit]) -> float | None:
    """Restrict ``relief_setting`` to the settings that act; returns the opening limit [Pa].

    A relief valve set above the pressure the rig reaches at a record's conditions never
    opens: every reading is the healthy rig's, exactly, so no reading can tell that drift
    from healthy nor blame it.  The hypothesis ``relief_setting`` is therefore *a setting
    that acts at these conditions*: its prior is uniform over the part of its worn range
    below the highest healthy pump pressure of the records, and its log-evidence is the
    quadrature of the likelihood over the signature-map points there (the same
    quadrature as every single fault, :mod:`diagnostics.ranking`).  A drift above that
    pressure is what the isolability statement reports as not observable here, with how to
    check it (:mod:`diagnostics.isolability`).  Without this, the inactive part of the
    range would share the healthy rig's evidence and take up to half of a healthy
    record's probability.

    Parameters
    ----------
    ranker
        The ranker of the records (its signature maps and likelihood).
    fits
        The fits; the ``relief_setting`` one has its ``log_evidence`` replaced.

    Returns
    -------
    float or None
        The highest healthy pump pressure of the records [Pa] (settings below it act), or
        ``None`` when there is no relief-setting fit or no setting of its range acts.
    """
    fit = next((f for f in fits if f.name == "relief_setting"), None)
    if fit is None or not math.isfinite(fit.log_evidence):
        return None
    p_open = opening_pressure(ranker)
    lowest = float(ranker.models[0].maps.maps["relief_setting"].axes[0][0])
    if not lowest < p_open:  # no setting of the range acts here (or no prediction)
        return None
    acting = map_support(ranker, "relief_setting")
    chi2 = np.zeros(acting.size)
    for m in ranker.models:
        chi2 += m.chi2_grid(m.maps.maps["relief_setting"].pred)
    fit.log_evidence = map_log_evidence(chi2, acting)
    return p_open


def map_support(ranker: Ranker, name: str) -> npt.NDArray[np.bool_]:
    """The points of single-fault hypothesis ``name``'s signature map its prior covers:
    all of them, but for ``relief_setting`` only the settings below the records' highest
    healthy pump pressure where any is (:func:`acting_relief_setting`)."""
    z = ranker.models[0].maps.maps[name].axes[0]
    if name != "relief_setting":
        return np.ones(z.size, dtype=bool)
    acting = z < opening_pressure(ranker)  # Pset is fitted linearly: z is the setting [Pa]
    return np.asarray(acting) if acting.any() else np.ones(z.size, dtype=bool)


def map_log_evidence(chi2: npt.NDArray[np.float64], support: npt.NDArray[np.bool_]
                     ) -> float:
    """ln Z of a single fault from its χ² on the signature map's points [-]: the mean of
    the likelihood ``exp(−χ²/2)`` over the points of ``support`` (the uniform prior in
    the fitting coordinate on the equally spaced fine grid); −∞ where none is finite."""
    logl = -0.5 * chi2[support]
    top = float(logl.max()) if logl.size else -math.inf
    return top + math.log(float(np.mean(np.exp(logl - top)))) if math.isfinite(top) \
        else -math.inf


def whitening(diag: npt.NDArray[np.float64], terms: Sequence[npt.NDArray[np.float64]]
              ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(marginal σ, whitening matrix W) of the covariance ``diag(d) + Σ_k t_k t_kᵀ``.

    The likelihood of a record is ``exp(−|W (y − ŷ)|²/2)`` with ``Wᵀ W = C⁻¹``, ``W =
    L⁻¹`` for the Cholesky factor ``C = L Lᵀ`` (GUM Supplement 2 §3.21: a common input,
    the oil temperature or the load of the record, correlates every reading it moves).
    A rank-one term ``t_k`` is the sensitivity of the readings to one condition times that
    condition's standard uncertainty [SI unit of each reading].  Where a term is too large
    to factor (a reading near a stall, whose sensitivity is capped at 1e100), its readings
    keep their marginal σ and no correlation (``W = diag(1/σ)``).

    Parameters
    ----------
    diag
        Independent variances of the readings (instrument and model) [SI²].
    terms
        Correlated terms, one vector per common input [SI].

    Returns
    -------
    sigma
        Marginal standard uncertainty of each reading [SI].
    white
        Whitening matrix W [1/SI].
    """
    cov = np.diag(diag)
    for t in terms:
        cov = cov + np.outer(t, t)
    sigma = np.sqrt(np.diag(cov))
    with np.errstate(divide="ignore"):
        fallback = np.diag(1.0 / sigma)
    if not np.isfinite(cov).all() or np.max(sigma) > 1e50 or not np.all(sigma > 0.0):
        # a reading with zero σ is refused by the caller (diagnostics.record_model)
        return sigma, fallback
    # factor the correlation matrix (scale-free: readings in Pa and m³/s side by side)
    corr = cov / np.outer(sigma, sigma)
    try:
        chol = np.linalg.cholesky(corr)
    except np.linalg.LinAlgError:
        return sigma, fallback
    white = np.linalg.solve(chol, np.diag(1.0 / sigma))
    if not np.isfinite(white).all():
        return sigma, fallback
    return sigma, np.asarray(white, dtype=np.float64)


def posterior(fits: Sequence[HypothesisFit], prior: Mapping[str, float] = FLEET_PRIOR
              ) -> None:
    """Set ``probability`` of every fit: π_h Z_h normalised over the observable ones.

    Parameters
    ----------
    fits
        Fitted hypotheses with their ``log_evidence`` [-] and ``observable`` flag.
    prior
        Prior probability of each hypothesis name [-]; a name it lacks has prior 0.

    Notes
    -----
    When no observable hypothesis has a finite evidence (no parameter value of any
    hypothesis gives these readings a prediction), every probability is 0: the goodness
    of fit of :mod:`diagnostics.goodness` then reports the readings as not explained.
    """
    obs = [f for f in fits if f.observable]
    for f in fits:
        f.probability = 0.0
    logp = np.array([f.log_evidence + (math.log(prior[f.name]) if prior.get(f.name, 0.0) > 0
                                       else -math.inf) for f in obs], dtype=np.float64)
    if logp.size == 0 or not np.isfinite(logp.max()):
        return
    w = np.exp(logp - logp.max())
    w /= w.sum()
    for f, p in zip(obs, w, strict=True):
        f.probability = float(p)
