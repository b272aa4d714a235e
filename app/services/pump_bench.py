"""Pump parameterisation from a bench CSV, stored as a pump parameter set.

Used by ``POST /pump-sets/bench`` and ``hydrodiag calibrate pump``.  The CSV is read by
:func:`diagnostics.pump.read_bench_csv` (units in the column names; see its module) and
parameterised by :func:`diagnostics.pump.parameterise` (paper 000 eqs. 7-9 and 17-19: the
derived capacity D, the loss coefficients Cs, Cst and, with torque, Cv and Cf as
polynomial surfaces in pressure and speed).  The set keeps every number needed to use or
judge the result: D and its standard error, each surface's coefficient matrix, its
covariance, R², reduced χ² and residuals, the reference scales and the range of the data.
Data from the virtual bench say so in the set's ``source``.  The set also keeps the
sign-checked loss model of :mod:`diagnostics.pump.piston` with the test points it was checked
on and its error with one speed left out (:mod:`app.services.pump_check`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from sqlalchemy.orm import Session

from app.db.models import PumpSet
from app.limits import check_file
from app.schemas.pumps import PumpBenchForm, PumpSetCreate
from app.services.common import prefixed
from app.services.pump_check import check_quantities
from app.services.pumps import create_pump_set
from app.services.rigs import get_rig
from diagnostics.pump import BenchData, PumpParameterisation, parameterise, read_bench_csv
from diagnostics.pump.capacity import THETA_GAP
from diagnostics.pump.levels import cluster_levels
from sim.errors import InputError
from sim.fluid import Fluid

__all__ = ["MAX_CSV_BYTES", "bench_oil", "bench_pump_set", "parameterise_csv",
           "read_bench_bytes", "store_bench_parameters"]

#: Largest bench CSV accepted [byte].
MAX_CSV_BYTES = 5 * 1024 * 1024

_SIMULATED = "SIMULATED virtual-bench data, not measured"


def read_bench_bytes(content: bytes, *, field: str = "file") -> BenchData:
    """Read a bench CSV given as bytes (errors name ``field`` and the column)."""
    check_file(content, MAX_CSV_BYTES, field=field)
    try:
        return read_bench_csv(content, field=field)
    except InputError as exc:
        name = None if exc.field == field else exc.field
        raise type(exc)(exc.message, field=prefixed(field, name)) from None


def bench_oil(form: PumpBenchForm) -> Fluid | None:
    """The oil the form states (its data-sheet viscosities at 40 and 100 °C, its density at
    15 °C; what it leaves out, the default's), or ``None`` for the default ISO VG 46 HM oil
    of :class:`sim.fluid.Fluid`."""
    if form.oil_nu40_m2_s is None and form.oil_rho15_kg_m3 is None:
        return None
    default = Fluid()
    return Fluid(nu1=form.oil_nu40_m2_s or default.nu1, T1=40.0,
                 nu2=form.oil_nu100_m2_s or default.nu2, T2=100.0,
                 rho15=form.oil_rho15_kg_m3 or default.rho15, alpha=default.alpha,
                 beta=default.beta)


def parameterise_csv(content: bytes, *, displacement: float | None = None,
                     displacement_std: float = 0.0, oil: Fluid | None = None
                     ) -> tuple[BenchData, PumpParameterisation]:
    """Read and parameterise a bench CSV.

    Parameters
    ----------
    content
        The CSV file.
    displacement
        Derived capacity D [m³/rad] when known; from the data (Toet) when ``None``.
    displacement_std
        Standard error of a given D [m³/rad].
    oil
        The bench's oil (:func:`bench_oil`); ``None``: the default oil, and the density
        of eq. 9 at its 865 kg/m³ (:data:`sim.components.gear_pump.PARAMETERS`); a stated
        oil's density is taken at 40 °C.
    """
    data = read_bench_bytes(content)
    extra: dict[str, Any] = {} if oil is None else {"fluid": oil, "rho": oil.density(40.0)}
    try:
        result = parameterise(data, D=displacement, D_std=displacement_std, **extra)
    except InputError as exc:
        if exc.field == "D" and displacement is not None:  # the form's field, not the file's
            raise type(exc)(exc.message, field="displacement_m3_rad") from None
        raise type(exc)(exc.message, field=prefixed("file", exc.field)) from None
    return data, result


def _quantity(value: Any, unit: str, description: str) -> dict[str, Any] | None:
    array = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(array)):
        return None
    return {"value": array.tolist() if array.ndim else float(array), "unit": unit,
            "description": description}


def _nu_at(fluid: Fluid, theta: float) -> float:
    """The oil's kinematic viscosity at ``theta`` [°C] [m²/s]: a reference point as given
    (the law's round trip stored 46 cSt as 4.6000000000000054e-05: a verification pass),
    else the Walther law's."""
    for t, nu in ((fluid.T1, fluid.nu1), (fluid.T2, fluid.nu2)):
        if t == theta:
            return nu
    return fluid.kinematic_viscosity(theta)


def _quantities(data: BenchData, result: PumpParameterisation) -> dict[str, dict[str, Any]]:
    origin = ("derived capacity, Toet method at the coldest oil" if result.capacity is not None
              else "derived capacity, given")
    entries: dict[str, dict[str, Any] | None] = {
        "D": _quantity(result.D, "m^3/rad", origin),
        "D_std": _quantity(result.D_std, "m^3/rad", "standard error of D"),
        "D_per_rev": _quantity(result.D * 2.0 * math.pi, "m^3/rev", "derived capacity"),
        "rho": _quantity(result.rho, "kg/m^3", "oil density assumed in eq. 9"),
        "oil_nu40": _quantity(_nu_at(result.fluid, 40.0), "m^2/s",
                              "oil's kinematic viscosity at 40 °C in μ(θ)"),
        "oil_nu100": _quantity(_nu_at(result.fluid, 100.0), "m^2/s",
                               "oil's kinematic viscosity at 100 °C in μ(θ)"),
        "beta_ef": _quantity(result.beta_ef, "Pa", "effective bulk modulus assumed in eq. 8"),
        "n_points": _quantity(len(data), "1", "test points read"),
        "dp_range": _quantity([float(data.dp.min()), float(data.dp.max())], "Pa",
                              "pressure rise covered by the data"),
        "omega_range": _quantity([float(data.omega.min()), float(data.omega.max())], "rad/s",
                                 "shaft speed covered by the data"),
    }
    for name, fit in result.fits.items():
        surface = fit.surface
        basis = f"{name}(Δp, ω) = Σ c[i][j]·(Δp/p_ref)^i·(ω/ω_ref)^j, paper 000"
        entries[f"{name}_coef"] = _quantity(surface.coef, "1", basis)
        entries[f"{name}_cov"] = _quantity(fit.cov, "1", f"covariance of {name}_coef, row-major")
        entries[f"{name}_p_ref"] = _quantity(surface.p_ref, "Pa", f"pressure scale of {name}")
        entries[f"{name}_omega_ref"] = _quantity(surface.omega_ref, "rad/s",
                                                 f"speed scale of {name}")
        entries[f"{name}_r2"] = _quantity(fit.r2, "1", f"weighted R² of the {name} surface")
        entries[f"{name}_chi2_red"] = _quantity(fit.chi2_red, "1",
                                                f"reduced χ² of the {name} surface")
        entries[f"{name}_residual_rms"] = _quantity(fit.residual_rms, "1",
                                                    f"RMS residual of {name}")
        entries[f"{name}_constant"] = _quantity(
            fit.constant, "1", f"{name} as one number: the weighted mean of its point "
            "estimates over the tested pressures and speeds")
        entries[f"{name}_constant_std"] = _quantity(fit.constant_std, "1",
                                                    f"standard error of {name}_constant")
        entries[f"{name}_varies_p"] = _quantity(
            fit.varies_p, "1", f"p-value of the F-test of the {name} surface against "
            f"{name}_constant: small where {name} changes with pressure and speed beyond "
            "the noise")
    return {k: v for k, v in entries.items() if v is not None}


def store_bench_parameters(session: Session, form: PumpBenchForm, content: bytes) -> PumpSet:
    """Parameterise a bench CSV and store the result as a pump set of kind ``parameters``.

    Raises
    ------
    NotFoundError
        ``rig_id`` names no rig.
    InputError
        The file cannot be read or parameterised (``field`` starts with ``file``).
    ConflictError
        The name is taken.
    """
    if form.rig_id is not None:
        get_rig(session, form.rig_id, field="rig_id")
    return create_pump_set(session, bench_pump_set(form, content))


def _oil_note(data: BenchData, result: PumpParameterisation) -> str | None:
    """How the two-temperature coefficients were made: which runs, which oil's μ(θ)
    (a user pass: neither was said, and Cs, Cv scale with the viscosity assumed)."""
    if not result.fits:
        return None
    _, levels = cluster_levels(data.theta, rel_gap=0.0, abs_gap=THETA_GAP, field="theta")
    fl = result.fluid
    which = ("the default oil (ISO VG 46 HM: " if fl == Fluid() else "the oil stated (") \
        + f"{fl.nu1 * 1e6:g} cSt at {fl.T1:g} °C, {fl.nu2 * 1e6:g} cSt at {fl.T2:g} °C, " \
        f"Walther; ρ {result.rho:.4g} kg/m³ in eq. 9)"
    text = (f"Cs, Cst, Cv, Cf from the runs at {float(levels[0]):.1f} and "
            f"{float(levels[-1]):.1f} °C with μ(θ) of {which}; D per radian")
    if fl == Fluid():
        text += (" — another oil (an HV grade's 8 cSt at 100 °C) needs its data-sheet "
                 "viscosities (oil_nu40_m2_s, oil_nu100_m2_s): Cs and Cv scale with μ")
    if levels.size > 2:
        middle = ", ".join(f"{float(t):.1f}" for t in levels[1:-1])
        text += f"; the runs at {middle} °C are not used by them (eqs. 7 and 17 take two)"
    return text


#: below this p-value a surface's change over pressure and speed is beyond the noise
VARIES_P = 0.05


def _surface_note(result: PumpParameterisation) -> str | None:
    """What the coefficient surfaces say beyond their numbers: which do not change with
    pressure and speed beyond the noise (read them as one number), and any that go below
    zero at a set point (a pump maker's pass: a 16-term surface through the noise of a
    constant Cs swung ±100 % and went negative, without a word)."""
    flat = [f"{k} {f.constant:.3g} ± {f.constant_std:.2g} (p = {f.varies_p:.2f})"
            for k, f in result.fits.items()
            if not f.varies_p < VARIES_P and math.isfinite(f.constant)]
    notes = [f"surfaces that do not change with pressure and speed beyond the noise "
             f"(F-test against a constant): read as one number: {', '.join(flat)}"] \
        if flat else []
    notes += [n for f in result.fits.values() if (n := f.negative()) is not None]
    return "; ".join(notes) or None


def _duplicate_note(data: BenchData) -> str | None:
    """Rows that repeat another row in every reading (a copy-paste, as a rule: two real
    readings agree to the last digit in every column only by mistake), or ``None``; they
    were taken as repeated measurements without a word (a pump maker's pass)."""
    cols = [data.p_in, data.p_out, data.omega, data.theta, data.q, data.replicate]
    if data.torque is not None:
        cols.append(data.torque)
    rows = np.column_stack(cols)
    _, first = np.unique(rows, axis=0, return_index=True)
    repeats = len(data) - first.size
    if not repeats:
        return None
    dup = sorted(set(range(len(data))) - {int(i) for i in first})
    return (f"{repeats} data row{'s' if repeats > 1 else ''} (from row {dup[0] + 1}) repeat "
            "another row in every reading: taken as repeated measurements, weighing their "
            "set points twice; if they were copied by mistake, remove them")


def bench_pump_set(form: PumpBenchForm, content: bytes) -> PumpSetCreate:
    """The pump set of a bench CSV, validated and not stored (:func:`store_bench_parameters`
    less the rig check and the store: several sets checked before any is stored).

    Raises
    ------
    InputError
        The file cannot be read or parameterised (``field`` starts with ``file``).
    """
    oil = bench_oil(form)
    data, result = parameterise_csv(content, displacement=form.displacement_m3_rad,
                                    displacement_std=form.displacement_std_m3_rad, oil=oil)
    checked, check_note = check_quantities(data, result.D)
    notes = [n for n in (_SIMULATED if data.simulated else None, form.source,
                         data.provenance or None, result.not_identifiable or None,
                         _duplicate_note(data), _oil_note(data, result),
                         _surface_note(result), check_note) if n]
    return PumpSetCreate.model_validate({
        "name": form.name, "kind": "parameters", "rig_id": form.rig_id, "pump": form.pump,
        "source": "; ".join(notes)[:2000] or None,
        "quantities": _quantities(data, result) | checked,
    })
