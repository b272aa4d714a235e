"""Library of physically meaningful loss terms (paper 001 Table 1) for a fixed-displacement pump.

Each term is a regressor built from the test conditions: pressure rise Δp [Pa], speed ω
[rad/s], viscosity μ [Pa·s] (from the oil temperature), density ρ [kg/m³], effective bulk
modulus β [Pa] and the derived capacity Vi [m³/rad].  The physical factors (Vi, ρ, β) are
kept in the columns, so that a fitted coefficient is comparable with paper 000's
coefficients: in the flow model the coefficient of ``lam_wilson`` is −Cs, that of
``turb_schlosser`` is −Cst, that of ``comp_zarotti`` is −1 for a correct β; in the torque
model ``coul_wilson``'s is 1 + Cf and ``visc_wilson``'s is Cv.

For a fixed displacement (ε = 1, Vi constant) several Table 1 entries give the same column;
each column appears once, naming every source that produces it.  Dorey's
Vi·Δp/(2πμ)·(A + B·ω/ω_max)·(Δp/p_case) with a constant case pressure splits into Δp²/μ
and Vi·Δp²·ω/μ.  Entries whose form is not legible in the copy of paper 001 (Jeong's ω³
turbulent flow term, Manring's turbulent Δp/(μω)) or that carry their own nonlinear
parameters (Hibi and Ichikawa's 1 + (ω/ω₀)^α, Michael et al.'s A + μω/Δp) are not in the
library.

Flow model (response: delivered flow Q [m³/s]); always in the model: a constant (β₀) and
the displacement term ``disp`` = ω·Vi.  Torque model (response: shaft torque T [N·m]);
always in: a constant (shaft seal torque Te, paper 000 eq. 10) and ``coul_wilson`` =
Vi·Δp (ideal torque plus the Coulomb friction proportional to it).  Paper 001 applies the
torque-loss terms to a motor; here they describe the torque loss of the pump.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from diagnostics.pump.data import BenchData
from sim.components.gear_pump import dynamic_viscosity
from sim.errors import InputError
from sim.fluid import Fluid

__all__ = [
    "FLOW_TERMS",
    "TORQUE_TERMS",
    "Term",
    "TermContext",
    "context_from_bench",
    "design_columns",
    "expected_signs",
]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class TermContext:
    """Test conditions from which the regressors are built (all arrays of one length).

    Attributes
    ----------
    dp
        Pressure rise [Pa].
    omega
        Speed [rad/s].
    mu
        Dynamic viscosity [Pa·s].
    rho
        Density [kg/m³].
    beta
        Effective bulk modulus [Pa].
    Vi
        Derived capacity [m³/rad].
    """

    dp: FloatArray
    omega: FloatArray
    mu: FloatArray
    rho: float
    beta: float
    Vi: float


@dataclass(frozen=True, slots=True)
class Term:
    """One candidate regressor.

    Attributes
    ----------
    name
        Identifier.
    formula
        The column, as written in Table 1 for ε = 1.
    physics
        Which loss it describes.
    sources
        Table 1 references that give this column.
    response
        ``"flow"`` [m³/s] or ``"torque"`` [N·m].
    sign
        Physically expected sign of the coefficient: −1 for a flow loss, +1 for a torque
        loss or the displacement, 0 for a correction term that may take either sign (a gap
        that closes with pressure makes Δp²/μ positive; a Coulomb coefficient that falls
        with pressure makes Δp² negative).
    column
        Function of a :class:`TermContext` giving the column [unit of the response per unit
        coefficient].
    """

    name: str
    formula: str
    physics: str
    sources: str
    response: str
    sign: int
    column: Callable[[TermContext], FloatArray]


def _t(name: str, formula: str, physics: str, sources: str, response: str, sign: int,
       fn: Callable[[TermContext], FloatArray]) -> Term:
    return Term(name, formula, physics, sources, response, sign, fn)


def expected_signs(terms: Sequence[Term]) -> dict[str, int]:
    """``{name: sign}`` of the terms with a definite expected sign (for
    :func:`diagnostics.pump.selection.best_subset`)."""
    return {t.name: t.sign for t in terms if t.sign != 0}


FLOW_TERMS: tuple[Term, ...] = (
    _t("disp", "ω·Vi", "theoretical displacement", "paper 001 eqs. 2-5 (β₁)", "flow", 1,
       lambda c: c.omega * c.Vi),
    _t("lam_wilson", "Vi·Δp/μ", "laminar (Poiseuille) slip",
       "Wilson 1950; Bavendiek 1987; Jeong 2007; Johnson 2018b", "flow", -1,
       lambda c: c.Vi * c.dp / c.mu),
    _t("lam_manring05", "Δp/(μ·ω)", "laminar slip, speed-weighted", "Manring 2005a", "flow", -1,
       lambda c: c.dp / (c.mu * c.omega)),
    _t("lam_manring16", "Δp²/μ", "laminar slip through a pressure-dependent gap",
       "Manring 2016; Dorey 1988 (A-part)", "flow", 0, lambda c: c.dp**2 / c.mu),
    _t("lam_dorey", "Vi·Δp²·ω/μ", "laminar slip growing with speed (Δp/p_case, p_case "
       "constant)", "Dorey 1988 (B-part)", "flow", 0, lambda c: c.Vi * c.dp**2 * c.omega / c.mu),
    _t("turb_schlosser", "Vi^(2/3)·√(2Δp/ρ)", "turbulent (orifice) slip",
       "Schlösser 1961; Jeong 2007", "flow", -1,
       lambda c: c.Vi ** (2.0 / 3.0) * np.sqrt(2.0 * c.dp / c.rho)),
    _t("turb_manring16", "Δp²", "turbulent slip, quadratic in pressure", "Manring 2016",
       "flow", -1, lambda c: c.dp**2),
    _t("comp_zarotti", "Vi·Δp·ω/β", "compressibility of the displaced oil",
       "Zarotti and Nevegna 1981; Dorey 1988; Jeong 2007; Manring 2016", "flow", -1,
       lambda c: c.Vi * c.dp * c.omega / c.beta),
    _t("comp_olsson", "Vi·Δp/β", "compressibility of the dead volume", "Olsson 1973",
       "flow", -1, lambda c: c.Vi * c.dp / c.beta),
)

TORQUE_TERMS: tuple[Term, ...] = (
    _t("coul_wilson", "Vi·Δp", "ideal torque and Coulomb friction ∝ Δp",
       "Wilson 1950; paper 000 eqs. 13, 15", "torque", 1, lambda c: c.Vi * c.dp),
    _t("visc_wilson", "Vi·μ·ω", "viscous (Couette) friction", "Wilson 1950; Jeong 2007",
       "torque", 1, lambda c: c.Vi * c.mu * c.omega),
    _t("visc_manring05", "μ·ω/Δp", "viscous friction relative to load", "Manring 2005a",
       "torque", 1, lambda c: c.mu * c.omega / c.dp),
    _t("turb_schlosser", "ρ·Vi^(5/3)·ω²", "turbulent drag",
       "Schlösser 1961; Thoma 1969; Jeong 2007", "torque", 1,
       lambda c: c.rho * c.Vi ** (5.0 / 3.0) * c.omega**2),
    _t("turb_ivantysyn", "μ·ω²", "drag growing with speed squared",
       "Ivantysyn and Ivantysynova 2003", "torque", 1, lambda c: c.mu * c.omega**2),
    _t("coul_jeong", "Δp²", "load-dependent friction, quadratic in pressure", "Jeong 2007",
       "torque", 0, lambda c: c.dp**2),
)


def design_columns(terms: Sequence[Term], ctx: TermContext) -> dict[str, FloatArray]:
    """Columns of the named terms, checked for finiteness.

    Raises
    ------
    InputError
        A column is not finite (e.g. Δp = 0 in a 1/Δp term); ``field`` names the term.
    """
    out: dict[str, FloatArray] = {}
    for t in terms:
        col = np.asarray(t.column(ctx), dtype=np.float64)
        if not np.all(np.isfinite(col)):
            raise InputError(f"term {t.formula} is not finite on these data (Δp = 0?)",
                             field=t.name)
        out[t.name] = col
    return out


def context_from_bench(data: BenchData, Vi: float, *, fluid: Fluid | None = None,
                       rho: float = 865.0, beta: float = 1.5e9) -> TermContext:
    """Regressor context from bench data: μ from the oil temperature of each reading.

    Parameters
    ----------
    data
        Steady test points.
    Vi
        Derived capacity [m³/rad].
    fluid
        Oil for μ(θ) (default ISO VG 46).
    rho, beta
        Density [kg/m³] and effective bulk modulus [Pa].
    """
    if not (Vi > 0 and rho > 0 and beta > 0):
        raise InputError("Vi, rho and beta must be positive", field="Vi")
    fl = fluid if fluid is not None else Fluid()
    return TermContext(dp=data.dp, omega=data.omega, mu=dynamic_viscosity(fl, data.theta),
                       rho=rho, beta=beta, Vi=Vi)
