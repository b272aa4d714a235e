"""Is a bench table physically possible with its displacement?  Checked before any fit.

A positive-displacement pump cannot deliver more than it displaces, nor need less torque
than the ideal torque (paper 000 eqs. 1 and 13)::

    η_v = q / (D·ω) ≤ 1,        η_hm = Δp·D / T ≤ 1

with ``D`` the derived capacity [m³/rad].  Paper 000 §2 names a volumetric efficiency above
100 % as the symptom of a wrong capacity.  A fit that goes on regardless stores a turbulent
slip that *adds* flow (Cst < 0) or a friction that *drives* the shaft (Cf < 0), and the
free speed term of the loss model absorbs the rest, so the held-out check does not see it
(a user pass: a displacement typed in cm³/rev where m³/rad was asked was stored as
14.7 m³/rad, torque S 9e7 %; one 15 % small gave Cst < 0 everywhere, and halved torque
readings Cf = −0.48).  The tests use the *median* over the points, so single noisy
readings near η = 1 (low pressure, an instrument's 1 %) do not trip them:

* a given displacement is refused when the median η_v exceeds :data:`ETA_LIMIT`, or when
  even the best point delivers less than :data:`ETA_V_FLOOR` of it (a unit slip);
* torque readings are refused when the median η_hm over the points above a fifth of the
  highest pressure (where the ideal torque dominates) exceeds :data:`ETA_LIMIT`, or falls
  below :data:`ETA_HM_FLOOR`: no pump turns at 2-9 % hydro-mechanical efficiency, which is
  what l/min under a ``[cm^3/s]`` header (a displacement 16× small), the case-drain flow
  taken as the delivered one, or MPa under ``[bar]`` make of a sound file (a real-data
  analyst's pass: all three were stored).
"""

from __future__ import annotations

import numpy as np

from diagnostics.pump.capacity import derived_capacity_toet
from diagnostics.pump.data import BenchData
from sim.errors import InputError
from sim.units import from_si

__all__ = ["ETA_HM_FLOOR", "ETA_LIMIT", "ETA_V_FLOOR", "check_displacement", "check_torque"]

#: median efficiency above which the data contradict their displacement [-]: 1 + twice a
#: bench flowmeter's or torque meter's accuracy (ISO 4409 class B, ±1 %)
ETA_LIMIT = 1.02
#: best volumetric efficiency below which a given displacement is taken for a unit slip [-]
ETA_V_FLOOR = 0.5
#: median hydro-mechanical efficiency above a fifth of the highest pressure below which the
#: torque contradicts the displacement and pressures [-] (pumps: 0.8-0.95 there)
ETA_HM_FLOOR = 0.5


def _cm3(D: float) -> str:
    return f"{from_si(D, 'cm^3/rev', 'm^3/rad'):.4g} cm³/rev"


def _toet_hint(data: BenchData) -> str:
    try:
        toet = derived_capacity_toet(data)
    except InputError:
        return ""
    return f"; the data's own derived capacity (Toet) is {_cm3(toet.D)}: leave D out to use it"


def check_displacement(data: BenchData, D: float) -> None:
    """Refuse a *given* displacement the flows contradict (module docstring).

    Raises
    ------
    InputError
        ``field="D"``: the median η_v is above :data:`ETA_LIMIT` or the largest is below
        :data:`ETA_V_FLOOR`.
    """
    eta = data.q / (D * data.omega)
    median, best = float(np.median(eta)), float(np.max(eta))
    unit = " (D is per radian: 1 cm³/rev = 1.5915e-7 m³/rad)"
    if median > ETA_LIMIT:
        raise InputError(
            f"the given displacement D = {_cm3(D)} is smaller than the pump delivers: "
            f"q/(D·ω) is {median:.3g} at the median point (a pump cannot deliver more than "
            f"it displaces; paper 000 §2){_toet_hint(data)}{unit}", field="D")
    if best < ETA_V_FLOOR:
        raise InputError(
            f"the given displacement D = {_cm3(D)} is far larger than the pump delivers: "
            f"q/(D·ω) is at most {best:.3g}{_toet_hint(data)}{unit}", field="D")


def check_torque(data: BenchData, D: float, *, given: bool) -> None:
    """Refuse torque readings below the ideal torque Δp·D (module docstring); no torque,
    nothing to check.

    Raises
    ------
    InputError
        ``field="T"`` (the column the others contradict; the message names the
        slips that make it): the median η_hm above a fifth of the highest pressure exceeds
        :data:`ETA_LIMIT`, or is below :data:`ETA_HM_FLOOR`.
    """
    if data.torque is None:
        return
    dp = data.dp
    high = dp >= 0.2 * float(dp.max())
    if not np.any(high & (dp > 0)):
        return
    eta = dp[high] * D / data.torque[high]
    median = float(np.median(eta))
    if median > ETA_LIMIT:
        origin = "the given" if given else "the derived"
        raise InputError(
            f"the torque readings are below the ideal torque Δp·D ({origin} D = {_cm3(D)}): "
            f"Δp·D/T is {median:.3g} at the median point above {0.2 * float(dp.max()) / 1e5:.3g}"
            " bar (a pump needs more torque than Δp·D, paper 000 eq. 13; the friction "
            "coefficient would come out negative): check the torque column's unit and sign"
            + (", and the given displacement (too large for this torque)"
               + _toet_hint(data) if given else
               ", the speed column's unit (rev/s under an [rpm] header makes the derived D "
               "60× large) and the pressures' (bar under [MPa])"), field="T")
    if median < ETA_HM_FLOOR:
        origin = "the given" if given else "the derived"
        slips = ("the delivered flow's unit (l/min under a [cm^3/s] header makes D 16× "
                 "small) or column (the case drain is not the delivered flow), "
                 if not given else "")
        raise InputError(
            f"the torque readings are {1 / median:.3g} × the ideal torque Δp·D ({origin} "
            f"D = {_cm3(D)}) at the median point above {0.2 * float(dp.max()) / 1e5:.3g} bar: "
            f"a hydro-mechanical efficiency of {median:.3g}, where pumps reach 0.8-0.95 "
            f"(at least {ETA_HM_FLOOR:g} taken): check {slips}the pressures' unit (MPa "
            "under [bar]) and the torque's, or whether the table mixes displacement "
            "settings (one table per setting: hydrodiag calibrate pump-map)", field="T")
