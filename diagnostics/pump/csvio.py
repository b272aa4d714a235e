"""Bench data as CSV with the unit in every column name.

Columns (``name [unit]``; order free, extra columns ignored):

=============  ==========================  ===========================================
name           accepted units              meaning
=============  ==========================  ===========================================
``p_in``       Pa, kPa, bar, MPa           inlet pressure (gauge)
``p_out``      Pa, kPa, bar, MPa           outlet pressure (gauge)
``n``          rev/s, rpm, rad/s, Hz       shaft speed (``omega`` is accepted as name)
``theta``      degC, °C, C, K              oil temperature at the pump inlet
``q``          m^3/s, L/min, l/min, cm^3/s delivered flow
``T``          N*m, N m, Nm, N·m           shaft torque (optional)
``replicate``  -                           replicate number (optional)
=============  ==========================  ===========================================

Written files use ``p_in [Pa]``, ``p_out [Pa]``, ``n [rev/s]``, ``theta [degC]``,
``q [m^3/s]``, ``T [N*m]``, ``replicate [-]``.  Inside, speed is converted to rad/s.  Lines
at the top starting with ``#`` are provenance; a line containing ``SIMULATED`` marks
virtual-bench data and sets :attr:`BenchData.simulated`.  Files are read as the time-series
import reads them: gzip-compressed or not, separated by commas, semicolons or tabs.
"""

from __future__ import annotations

import io
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from diagnostics.pump.data import MAX_REPLICATE, BenchData
from diagnostics.table_files import (
    MAX_DECOMPRESSED_BYTES,
    check_table,
    check_text,
    dialect,
    gunzipped,
    read_csv_exact,
)
from sim.errors import InputError
from sim.units import to_si

__all__ = ["bench_from_frame", "bench_to_frame", "is_bench_table", "read_bench_csv",
           "write_bench_csv"]

_HEADER = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*\[(.*)\]\s*$")
_NAMES = {"p_in": "p_in", "p_out": "p_out", "n": "n", "omega": "n", "theta": "theta",
          "q": "q", "T": "T", "replicate": "replicate"}
_TORQUE = {"N*m": 1.0, "N m": 1.0, "Nm": 1.0, "N·m": 1.0, "kN*m": 1e3}
_REQUIRED = ("p_in", "p_out", "n", "theta", "q")
#: the columns of an efficiency map (:func:`diagnostics.pump.piston.read_efficiency_map`),
#: named in the error when such a file is given as a bench table
MAP_LAYOUT = frozenset({"Speed", "Deltap", "QOut", "Displacement"})


def _factor(quantity: str, unit: str, column: str) -> tuple[float, float]:
    """(scale, offset) taking a value in ``unit`` to SI: si = value * scale + offset."""
    u = unit.strip()
    if quantity in ("p_in", "p_out"):
        return to_si(1.0, u, "Pa", field=column), 0.0
    if quantity == "n":
        return to_si(1.0, u, "rad/s", field=column), 0.0
    if quantity == "q":
        return to_si(1.0, u, "m^3/s", field=column), 0.0
    if quantity == "theta":
        if u in ("degC", "°C", "C"):
            return 1.0, 0.0
        if u == "K":
            return 1.0, -273.15
        raise InputError(f"unit {u!r} is not a temperature unit (degC, °C, C, K)", field=column)
    if quantity == "T":
        if u in _TORQUE:
            return _TORQUE[u], 0.0
        raise InputError(f"unit {u!r} is not a torque unit ({', '.join(_TORQUE)})", field=column)
    if u not in ("-", "", "1"):
        raise InputError(f"replicate is a count, unit '-' expected, got {u!r}", field=column)
    return 1.0, 0.0


def bench_from_frame(frame: pd.DataFrame, *, simulated: bool = False,
                     provenance: str = "") -> BenchData:
    """Bench data from a table whose column names carry units (``"p_out [bar]"``).

    Parameters
    ----------
    frame
        One row per steady test point; columns as in the module table.
    simulated, provenance
        Passed to :class:`BenchData`.

    Raises
    ------
    InputError
        Missing column, a column without a unit, a unit of the wrong dimension (``field`` is
        the column), a duplicated quantity; NaN values via :class:`BenchData`.
    """
    found: dict[str, tuple[str, float, float]] = {}
    for col in frame.columns:
        m = _HEADER.match(str(col))
        if m is None:
            if str(col).strip() in _NAMES:
                raise InputError("column name must carry its unit, e.g. 'p_out [Pa]'",
                                 field=str(col))
            continue
        name, unit = m.group(1), m.group(2)
        if name not in _NAMES:
            continue
        quantity = _NAMES[name]
        if quantity in found:
            raise InputError(f"quantity {quantity!r} given twice", field=str(col))
        scale, offset = _factor(quantity, unit, str(col))
        found[quantity] = (str(col), scale, offset)
    for req in _REQUIRED:
        if req not in found:
            names = {str(c).strip() for c in frame.columns}
            hint = ("; this is an efficiency map in the V32HL56 layout (Speed, Deltap, QOut, "
                    "Displacement): 'hydrodiag calibrate pump-map FILE' reads it, and its "
                    "--bench-dir writes each displacement setting as a bench CSV"
                    if names >= MAP_LAYOUT else "")
            raise InputError(f"missing column {req!r} (with its unit in brackets){hint}",
                             field=req)

    def get(quantity: str) -> np.ndarray:
        col, scale, offset = found[quantity]
        values = pd.to_numeric(frame[col], errors="coerce").to_numpy(dtype=np.float64)
        if np.any(np.isnan(values)):
            row = int(np.flatnonzero(np.isnan(values))[0])
            raise InputError(f"empty or non-numeric value (data row {row + 1})", field=col)
        return values * scale + offset

    def replicates() -> np.ndarray:
        values = get("replicate")
        if np.any(bad := (values != np.round(values)) | (values < 0)
                  | (values > MAX_REPLICATE)):
            row = int(np.flatnonzero(bad)[0])
            raise InputError(f"data row {row + 1}: replicate number {values[row]:g} is not a "
                             f"whole number 0 to {MAX_REPLICATE}", field=found["replicate"][0])
        return values.astype(np.int64)

    # BenchData's own checks name its fields; the user knows the columns
    columns = {"omega": "n", "torque": "T"}
    try:
        return BenchData(
            p_in=get("p_in"), p_out=get("p_out"), omega=get("n"), theta=get("theta"),
            q=get("q"), torque=get("T") if "T" in found else None,
            replicate=replicates() if "replicate" in found
            else np.zeros(len(frame), dtype=np.int64),
            simulated=simulated, provenance=provenance,
        )
    except InputError as exc:
        quantity = columns.get(exc.field or "", exc.field or "")
        if quantity not in found:
            raise
        raise type(exc)(exc.message, field=found[quantity][0]) from None


def bench_to_frame(data: BenchData) -> pd.DataFrame:
    """The canonical table: ``p_in [Pa]``, ``p_out [Pa]``, ``n [rev/s]``, ``theta [degC]``,
    ``q [m^3/s]``, ``T [N*m]`` (if any), ``replicate [-]``."""
    cols: dict[str, np.ndarray] = {
        "p_in [Pa]": data.p_in,
        "p_out [Pa]": data.p_out,
        "n [rev/s]": data.omega / (2.0 * math.pi),
        "theta [degC]": data.theta,
        "q [m^3/s]": data.q,
    }
    if data.torque is not None:
        cols["T [N*m]"] = data.torque
    cols["replicate [-]"] = data.replicate
    return pd.DataFrame(cols)


def write_bench_csv(data: BenchData, path: str | Path) -> None:
    """Write ``data`` as CSV (full float precision) with provenance header lines.

    Simulated data get a first line ``# SIMULATED virtual ISO 4409 bench - not measured data``.
    """
    lines = []
    if data.simulated:
        lines.append("# SIMULATED virtual ISO 4409 bench - not measured data")
    if data.provenance:
        lines.extend(f"# {ln}" for ln in data.provenance.splitlines())
    body = bench_to_frame(data).to_csv(index=False, float_format="%.17g", lineterminator="\n")
    Path(path).write_text("\n".join([*lines, body]) if lines else body, encoding="utf-8")


def read_bench_csv(source: str | Path | bytes, *, field: str = "path") -> BenchData:
    """Read bench data written by :func:`write_bench_csv` or by a real test rig: a path or
    the file's bytes, gzip-compressed or not, separated by commas, semicolons or tabs (a
    semicolon or tab table may write decimal commas), as the time-series import reads
    them (:mod:`diagnostics.table_files`).

    Raises
    ------
    InputError
        If the file is missing, empty, not UTF-8 or not a CSV table (naming ``field``), or
        as :func:`bench_from_frame`.
    """
    if isinstance(source, str | Path):
        p = Path(source)
        if not p.is_file():
            raise InputError(f"no such file: {p}", field=field)
        try:
            raw = p.read_bytes()
        except OSError as exc:
            raise InputError(f"cannot read {p}: {exc.strerror}", field=field) from None
    else:
        raw = bytes(source)
    try:
        text = gunzipped(raw, MAX_DECOMPRESSED_BYTES).decode("utf-8-sig")
    except InputError as exc:
        raise InputError(exc.message, field=field) from None
    except UnicodeDecodeError:
        raise InputError("the file is not UTF-8 text", field=field) from None
    check_text(text, field)
    lines = text.splitlines()
    header: list[str] = []
    while lines and lines[0].lstrip().startswith("#"):
        header.append(lines.pop(0).lstrip()[1:].strip())
    lines = [ln for ln in lines if ln.strip()]
    if not lines:
        raise InputError("file has no table", field=field)
    sep, decimal = dialect(lines[:6])
    try:
        frame = read_csv_exact(io.StringIO("\n".join(lines)), sep=sep, decimal=decimal)
    except (pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise InputError(f"not a readable CSV table: {exc}", field=field) from None
    check_table(frame, field)
    if frame.empty:
        raise InputError("the bench table has no rows", field=field)
    simulated = any("SIMULATED" in h for h in header)
    provenance = "\n".join(h for h in header if "SIMULATED" not in h)
    return bench_from_frame(frame, simulated=simulated, provenance=provenance)


def is_bench_table(content: bytes) -> bool:
    """Whether ``content`` (gzip-compressed or not) is a pump-bench CSV: ``p_out`` and ``q``
    columns, no ``t`` column, in any of the separators :func:`read_bench_csv` reads."""
    try:
        text = gunzipped(content, MAX_DECOMPRESSED_BYTES).decode("utf-8-sig", errors="replace")
    except InputError:
        return False
    lines = [ln for ln in text.splitlines()[:50] if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        return False
    sep, _ = dialect(lines[:6])
    names = {c.split("[")[0].strip().strip('"') for c in lines[0].split(sep)}
    return {"p_out", "q"} <= names and "t" not in names
