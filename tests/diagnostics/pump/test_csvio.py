"""CSV with units in the column names: round trips, conversions, refusals."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from diagnostics.pump import BenchData, bench_from_frame, read_bench_csv, write_bench_csv
from sim.errors import InputError, MeasurementError


def test_round_trip_is_exact_and_keeps_the_simulated_flag(grid_bench: BenchData,
                                                          tmp_path: Path) -> None:
    path = tmp_path / "bench.csv"
    write_bench_csv(grid_bench, path)
    text = path.read_text()
    assert text.startswith("# SIMULATED")
    header = text.splitlines()[2]
    assert header.split(",")[:3] == ["p_in [Pa]", "p_out [Pa]", "n [rev/s]"]
    back = read_bench_csv(path)
    assert back.simulated and "virtual ISO 4409 bench" in back.provenance
    for name in ("p_in", "p_out", "omega", "theta", "q", "torque", "replicate"):
        np.testing.assert_allclose(getattr(back, name), getattr(grid_bench, name),
                                   rtol=1e-15, atol=0)


def test_engineering_units_are_converted_to_si() -> None:
    frame = pd.DataFrame({
        "p_in [bar]": [0.5, 0.5], "p_out [bar]": [100.5, 200.5], "n [rpm]": [1500.0, 600.0],
        "theta [K]": [333.15, 295.15], "q [L/min]": [21.5, 8.3], "T [Nm]": [25.0, 50.0],
        "comment": ["a", "b"],
    })
    d = bench_from_frame(frame)
    np.testing.assert_allclose(d.dp, [1e7, 2e7])
    np.testing.assert_allclose(d.omega, [1500 * 2 * math.pi / 60, 600 * 2 * math.pi / 60])
    np.testing.assert_allclose(d.theta, [60.0, 22.0])
    np.testing.assert_allclose(d.q, [21.5e-3 / 60, 8.3e-3 / 60])
    assert d.torque is not None and d.torque.tolist() == [25.0, 50.0]
    assert not d.simulated


def _frame() -> dict[str, list[float]]:
    return {"p_in [Pa]": [0.0], "p_out [Pa]": [1e7], "n [rev/s]": [25.0],
            "theta [degC]": [40.0], "q [m^3/s]": [3e-4], "T [N*m]": [25.0]}


def _drop(c: dict[str, list[float]]) -> None:
    del c["q [m^3/s]"]


def _unit(old: str, new: str) -> Callable[[dict[str, list[float]]], None]:
    def f(c: dict[str, list[float]]) -> None:
        c[new] = c.pop(old)
    return f


def _nan(c: dict[str, list[float]]) -> None:
    c["n [rev/s]"] = [float("nan")]


@pytest.mark.parametrize(("change", "field"), [
    (_drop, "q"),
    (_unit("p_out [Pa]", "p_out [L/min]"), "p_out [L/min]"),
    (_unit("theta [degC]", "theta [F]"), "theta [F]"),
    (_unit("T [N*m]", "T [bar]"), "T [bar]"),
    (_unit("p_out [Pa]", "p_out"), "p_out"),
    (_nan, "n [rev/s]"),
])
def test_bad_columns_are_refused_with_the_column_named(
        change: Callable[[dict[str, list[float]]], None], field: str) -> None:
    cols = _frame()
    change(cols)
    with pytest.raises(InputError) as e:
        bench_from_frame(pd.DataFrame(cols))
    assert e.value.field == field


def test_impossible_values_are_measurement_errors() -> None:
    cols = _frame()
    cols["p_out [Pa]"] = [-1.0]
    with pytest.raises(MeasurementError) as e:
        bench_from_frame(pd.DataFrame(cols))
    assert e.value.field == "p_out [Pa]"  # the column, as the user wrote it
    with pytest.raises(MeasurementError):
        BenchData(p_in=np.zeros(1), p_out=np.full(1, 1e7), omega=np.zeros(1),
                  theta=np.full(1, 40.0), q=np.full(1, 1e-4))
    # 20-200 bar written under "[Pa]": named as the unit slip it is (it was refused for
    # "too few pressure levels", a pump field engineer's pass)
    cols = _frame()
    cols["p_out [Pa]"] = [200.0]
    with pytest.raises(MeasurementError) as e:
        bench_from_frame(pd.DataFrame(cols))
    assert e.value.field == "p_out [Pa]" and "are these bar" in e.value.message


def test_missing_file_is_an_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError) as e:
        read_bench_csv(tmp_path / "nope.csv")
    assert e.value.field == "path"


def test_an_efficiency_map_given_as_a_bench_table_is_pointed_to_its_reader(
        tmp_path: Path) -> None:
    path = tmp_path / "map.csv"
    path.write_text("SpeedTheo,Speed,Torque,pLow,pHigh,Deltap,QOut,QDr,Displacement\n"
                    "500,500,22,0.1013,5.01,4.9087,10.8,1.83,23.3\n")
    with pytest.raises(InputError, match="hydrodiag calibrate pump-map FILE") as e:
        read_bench_csv(path)
    assert e.value.field == "p_in"
    other = tmp_path / "other.csv"
    other.write_text("p_out [Pa],n [rev/s],theta [degC],q [m^3/s]\n1e6,25,40,1e-4\n")
    with pytest.raises(InputError) as e:
        read_bench_csv(other)
    assert "pump-map" not in str(e.value)


@pytest.mark.parametrize("text", ['"', 'p_in [Pa],p_out [Pa]\n"1,2\n', "# only provenance\n\n"])
def test_a_file_that_is_not_a_csv_table_is_an_input_error(tmp_path, text):
    # found by the fuzzer: a file holding one double quote answered 500 through the upload
    path = tmp_path / "bench.csv"
    path.write_text(text)
    with pytest.raises(InputError):
        read_bench_csv(path)


def test_a_table_is_read_as_the_series_import_reads_it(grid_bench: BenchData,
                                                       tmp_path: Path) -> None:
    """Gzip-compressed, or a spreadsheet's export separated by semicolons with decimal
    commas: the same points as the comma file (the bench reader took commas only and said
    "'Pa]; p_out [Pa]; …' is not a unit")."""
    import gzip

    from diagnostics.pump import is_bench_table

    path = tmp_path / "bench.csv"
    write_bench_csv(grid_bench, path)
    text = path.read_text()
    header = [ln for ln in text.splitlines() if ln.startswith("#")]
    body = [ln for ln in text.splitlines() if not ln.startswith("#")]
    europe = "\n".join([*header, *(ln.replace(",", ";") if k == 0 else
                                   ";".join(c.replace(".", ",") for c in ln.split(","))
                                   for k, ln in enumerate(body))]) + "\n"
    for content in (gzip.compress(text.encode()), europe.encode()):
        assert is_bench_table(content)
        back = read_bench_csv(content)
        assert back.simulated
        np.testing.assert_allclose(back.p_out, grid_bench.p_out, rtol=1e-12)
        np.testing.assert_allclose(back.q, grid_bench.q, rtol=1e-12)
    assert not is_bench_table(b"t [s],p_out [Pa],q [m^3/s]\n0,1,2\n")


@pytest.mark.parametrize(("content", "says"), [
    (b"\x00\x01\x02PK\x03", "binary, not a text table"),  # was "no rows"
    # decimal commas in a comma-separated file: was "7.7e13 degC is outside ..."
    (b"p_in [Pa],p_out [bar],n [rpm],theta [degC],q [l/min]\n0,100,5,1500,40,10,5\n",
     "more field(s) than the header"),
])
def test_a_file_that_is_no_table_says_why(content: bytes, says: str) -> None:
    with pytest.raises(InputError) as e:
        read_bench_csv(content)
    assert says in e.value.message
