"""The workflow's statement of its solver error, in σ of the noise read from the records.

The solver states its error in σ of its default instruments (25 kPa pressure); said as
"of the sensors' noise" it read 3.8× small on records with 5 kPa of pressure noise and
18× small on quieter ones (a numerics pass).
"""

from __future__ import annotations

import pandas as pd
import pytest

from diagnostics.discrepancy.noise import Noise
from diagnostics.discrepancy.simulate import SOLVER, SOLVER_WELL_BELOW, solver_statement
from sim.solver.noise import DEFAULT_NOISE


def _table(errors: dict[str, float]) -> pd.DataFrame:
    table = pd.DataFrame({"t [s]": [0.0, 1e-3], "P1 [Pa]": [1e6, 1e6],
                          "Q_meter_B [m^3/s]": [4e-4, 4e-4], "v [m/s]": [0.2, 0.2]})
    table.attrs["solver"] = errors
    return table


def test_the_solver_error_is_said_in_the_records_sigma() -> None:
    # 0.0076 σ of 25 kPa is 190 Pa: 0.038 σ of 5 kPa records, 0.38 σ of 500 Pa ones
    tables = [_table({"P1": 0.0076, "Q_meter_B": 0.02}), _table({"P1": 0.004})]
    said = solver_statement(tables, {"P1": Noise(5e3), "Q_meter_B": Noise(8.3e-7)})
    assert said.startswith(SOLVER)
    p1 = 0.0076 * DEFAULT_NOISE["Pa"] / 5e3
    q = 0.02 * DEFAULT_NOISE["m^3/s"] / 8.3e-7
    assert p1 == pytest.approx(0.038) and q == pytest.approx(0.0561, rel=1e-3)
    assert f"P1 {p1:.2g} σ" in said and f"Q_meter_B {q:.2g} σ" in said
    assert "of the noise read from the records" in said and "not well below" not in said
    quiet = solver_statement(tables, {"P1": Noise(500.0)})
    assert 0.0076 * DEFAULT_NOISE["Pa"] / 500.0 > SOLVER_WELL_BELOW
    assert "P1 0.38 σ" in quiet and "not well below it on P1" in quiet
    # no error estimate, or no noise read for it: the method alone
    assert solver_statement([_table({})], {"P1": Noise(5e3)}) == SOLVER
    assert solver_statement(tables, {}) == SOLVER
