"""Pump characterisation (issue 4): paper 000's loss coefficients, paper 001's empirical models.

* :mod:`~diagnostics.pump.data`, :mod:`~diagnostics.pump.csvio` — steady test points in SI
  units, CSV with units in the column names;
* :mod:`~diagnostics.pump.bench` — a virtual ISO 4409 bench (simulated data, never measured);
* :mod:`~diagnostics.pump.capacity` — derived capacity: ISO 8426 intercept, Toet, Vimax;
* :mod:`~diagnostics.pump.coefficients`, :mod:`~diagnostics.pump.surfaces` — Cs, Cst, Cv, Cf
  (paper 000 eqs. 7-9, 17-19) and their polynomial surfaces in pressure and speed;
* :mod:`~diagnostics.pump.terms`, :mod:`~diagnostics.pump.selection` — paper 001 Table 1 term
  library, best subsets by AIC with VIF, R² and S;
* :mod:`~diagnostics.pump.plans`, :mod:`~diagnostics.pump.psr` — Latin hypercube and
  orthogonal test plans, progressively sequenced regression;
* :mod:`~diagnostics.pump.field_record`, :mod:`~diagnostics.pump.field`,
  :mod:`~diagnostics.pump.field_slip` — generated field records (simulated), the duty-cycle
  validation of paper 000 §4-5 with residual tests for the documented model gaps, and Cs
  from field records (eq. 7) with its trend over a campaign.  Import them from their
  modules (they pull in the compiled duty-cycle circuit and statsmodels).
"""

from diagnostics.pump.bench import InstrumentNoise, default_levels, iso4409_grid, run_virtual_bench
from diagnostics.pump.capacity import (
    CapacityEstimate,
    derived_capacity_intercept,
    derived_capacity_toet,
    derived_capacity_vimax,
    volumetric_efficiency,
)
from diagnostics.pump.coefficients import (
    PairedPoints,
    PointEstimates,
    PumpParameterisation,
    pair_set_points,
    parameterise,
    point_coefficients,
)
from diagnostics.pump.csvio import (
    bench_from_frame,
    bench_to_frame,
    is_bench_table,
    read_bench_csv,
    write_bench_csv,
)
from diagnostics.pump.data import BenchData
from diagnostics.pump.levels import cluster_levels, group_keys
from diagnostics.pump.plans import latin_hypercube_plan, orthogonal_plan
from diagnostics.pump.psr import PSRSummary, PSRTrace, progressive_regression, psr_saturation
from diagnostics.pump.selection import (
    RegressionModel,
    SubsetSelection,
    best_subset,
    fit_ols,
    vif,
)
from diagnostics.pump.surfaces import SurfaceFit, fit_surface
from diagnostics.pump.terms import (
    FLOW_TERMS,
    TORQUE_TERMS,
    Term,
    TermContext,
    context_from_bench,
    design_columns,
    expected_signs,
)

__all__ = [
    "FLOW_TERMS",
    "TORQUE_TERMS",
    "BenchData",
    "CapacityEstimate",
    "InstrumentNoise",
    "PSRSummary",
    "PSRTrace",
    "PairedPoints",
    "PointEstimates",
    "PumpParameterisation",
    "RegressionModel",
    "SubsetSelection",
    "SurfaceFit",
    "Term",
    "TermContext",
    "bench_from_frame",
    "bench_to_frame",
    "best_subset",
    "cluster_levels",
    "context_from_bench",
    "default_levels",
    "derived_capacity_intercept",
    "derived_capacity_toet",
    "derived_capacity_vimax",
    "design_columns",
    "expected_signs",
    "fit_ols",
    "fit_surface",
    "group_keys",
    "is_bench_table",
    "iso4409_grid",
    "latin_hypercube_plan",
    "orthogonal_plan",
    "pair_set_points",
    "parameterise",
    "point_coefficients",
    "progressive_regression",
    "psr_saturation",
    "read_bench_csv",
    "run_virtual_bench",
    "vif",
    "volumetric_efficiency",
    "write_bench_csv",
]
