"""Small slices of the real data sets, cut at test time from ``../shared/data/real``.

Nothing of the real data is copied into the repository: the V32HL56 map has no licence
("internal testing only, do not redistribute", its ``SOURCE.md``), so every slice is cut
from the shared files when the tests run (CI has ``../shared`` beside the clone) into a
temporary folder, once per process.  Where the shared data are absent the tests that need
a slice are skipped with the reason.

Slices (chosen without looking at any estimate):

* ZeMA 1 Hz: 18 cycles — valve 100 %, stable flag 0, three cycles each for leakage class
  0/1/2 × cooler 100 %/20 % — rows renumbered 1..18 (``cycles.txt`` gives each row's
  original cycle); ``profile.txt``, ``TS1.txt`` and ``data_compressed_1hz/{PS1,PS2,FS1,
  EPS1}_normalized.csv``.  ``fullres_cycle1092.csv``: the first 30 s of cycle 1092 at the
  native rates (PS1, PS2 100 Hz, FS1 10 Hz, TS1 1 Hz) from row 2 of
  ``fullres_samples/jeremiafourie/testing_sample.csv``.
* ZeMA native rates (``zema_native_slice``): the 1 Hz rows of the ten raw cycles of
  ``fullres_samples/jeremiafourie/testing_sample.csv`` (cycles 1967, 1092, … in its row
  order) and that file itself cut to the first 20 s of PS1, PS2, EPS1, FS1 and TS1, in the
  shared folder's layout.
* ZeMA load program (``zema_program_slice``): 21 cycles of cooler 100 %, leakage 0, stable
  flag 0 — three each of valve 73/80/90 % (accumulator 130 bar) and of accumulator
  130/115/100/90 bar (valve 100 %) — in the same layout, for the valve-lag and accumulator
  estimates.
* ZeMA temperature span (``zema_span_slice``): 18 cycles each of pump-leakage class 0 and 2,
  evenly spaced in record order over the whole campaign (so 35-57 °C of oil), in the same
  layout: the discrepancy workflow's held-out hottest fifth needs the span; the 18-cycle
  slice's healthy cycles cover 35-46 °C only, where a leak growing as the oil thins and a
  re-fit of the pump's own leak are not told apart out of sample.
* V32HL56: the header and every row whose displacement rounds to 23 or 57 cm³/rev.
* Rotary actuators (``vtnsi_slice``): the header and first 400 samples of the first
  recording (by name) of ``Act_1`` (baseline) and of ``Act_4 (Seal Defect)``, decompressed,
  tab-separated as the data set writes them, under their own names.
"""

from __future__ import annotations

import csv
import gzip
import tempfile
import threading
from pathlib import Path

import pytest

from diagnostics.real.zema import FULLRES_CYCLES, FULLRES_FILE, NATIVE_RATES, find_shared

__all__ = ["NATIVE_SLICE_S", "ZEMA_CYCLES", "ZEMA_PROGRAM_CYCLES", "ZEMA_SPAN_CYCLES",
           "v32hl56_slice", "vtnsi_slice", "zema_native_slice", "zema_program_slice",
           "zema_slice", "zema_span_slice"]

#: original 1-based cycle numbers of the ZeMA slice, in row order
ZEMA_CYCLES = (974, 1015, 1056, 1110, 1151, 1192, 1246, 1287, 1328, 1706, 1747, 1788, 1842,
               1883, 1927, 1978, 2019, 2189)
#: original cycle numbers of the temperature-span slice, in row order: 18 each of leakage
#: class 0 and 2, at evenly spaced positions of each class's cycles in record order
ZEMA_SPAN_CYCLES = tuple(sorted((
    1, 73, 145, 298, 452, 606, 760, 831, 903, 1057, 1293, 1446, 1518, 1590, 1662, 1897, 2051,
    2205, 211, 240, 361, 482, 511, 631, 952, 981, 1102, 1223, 1344, 1373, 1694, 1814, 1843,
    1964, 2085, 2114)))
#: seconds of each raw cycle in the native-rate slice [s]
NATIVE_SLICE_S = 20
#: original cycle numbers of the load-program slice, in row order
ZEMA_PROGRAM_CYCLES = (1760, 1763, 1766, 1770, 1773, 1776, 1780, 1783, 1786, 1790, 1793, 1796,
                       1922, 1925, 1928, 2055, 2058, 2061, 2188, 2191, 2194)
_ZEMA_FILES = ("profile.txt", "TS1.txt", "data_compressed_1hz/PS1_normalized.csv",
               "data_compressed_1hz/PS2_normalized.csv", "data_compressed_1hz/FS1_normalized.csv",
               "data_compressed_1hz/EPS1_normalized.csv")
_LOCK = threading.Lock()
_MADE: dict[str, Path] = {}


def _shared_real() -> Path:
    try:
        return find_shared() / "data" / "real"
    except Exception as exc:
        pytest.skip(f"the shared real data are not here: {exc}", allow_module_level=True)
        raise  # unreachable: skip raises


def _workdir() -> Path:
    if "root" not in _MADE:
        _MADE["root"] = Path(tempfile.mkdtemp(prefix="hydrodiag-real-slices-"))
    return _MADE["root"]


def zema_slice() -> Path:
    """Folder with the ZeMA slice (module docstring), in the layout of the shared folder."""
    with _LOCK:
        if "zema" in _MADE:
            return _MADE["zema"]
        src = _shared_real() / "uci-hydraulic-zema"
        dst = _workdir() / "zema"
        (dst / "data_compressed_1hz").mkdir(parents=True)
        for name in _ZEMA_FILES:
            lines = (src / name).read_text(encoding="utf-8").splitlines()
            (dst / name).write_text("\n".join(lines[c - 1] for c in ZEMA_CYCLES) + "\n",
                                    encoding="utf-8")
        (dst / "cycles.txt").write_text("\n".join(map(str, ZEMA_CYCLES)) + "\n")
        with (src / "fullres_samples" / "jeremiafourie" / "testing_sample.csv").open(
                newline="") as fh:
            reader = csv.reader(fh)
            header = next(reader)
            next(reader)
            row = next(reader)
        keep = [i for i, col in enumerate(header)
                if (col.startswith(("PS1_", "PS2_")) and int(col[4:]) < 3000)
                or (col.startswith("FS1_") and int(col[4:]) < 300)
                or (col.startswith("TS1_") and int(col[4:]) < 30)]
        with (dst / "fullres_cycle1092.csv").open("w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow([header[i] for i in keep])
            writer.writerow([row[i] for i in keep])
        _MADE["zema"] = dst
        return dst


def _zema_rows(key: str, cycles: tuple[int, ...]) -> Path:
    """Folder with the ZeMA 1 Hz rows of ``cycles`` in the shared folder's layout."""
    with _LOCK:
        if key in _MADE:
            return _MADE[key]
        src = _shared_real() / "uci-hydraulic-zema"
        dst = _workdir() / key
        (dst / "data_compressed_1hz").mkdir(parents=True)
        for name in _ZEMA_FILES:
            lines = (src / name).read_text(encoding="utf-8").splitlines()
            (dst / name).write_text("\n".join(lines[c - 1] for c in cycles) + "\n",
                                    encoding="utf-8")
        (dst / "cycles.txt").write_text("\n".join(map(str, cycles)) + "\n")
        _MADE[key] = dst
        return dst


def zema_program_slice() -> Path:
    """Folder with the load-program slice (module docstring), in the shared folder's layout."""
    return _zema_rows("zema-program", ZEMA_PROGRAM_CYCLES)


def zema_span_slice() -> Path:
    """Folder with the temperature-span slice (module docstring), in the shared folder's
    layout."""
    return _zema_rows("zema-span", ZEMA_SPAN_CYCLES)


def zema_native_slice() -> Path:
    """Folder with the native-rate slice (module docstring), in the shared folder's layout."""
    with _LOCK:
        if "zema-native" in _MADE:
            return _MADE["zema-native"]
    dst = _zema_rows("zema-native-1hz", FULLRES_CYCLES)
    with _LOCK:
        src = _shared_real() / "uci-hydraulic-zema" / FULLRES_FILE
        with src.open(newline="") as fh:
            rows = list(csv.reader(fh))
        keep = [i for i, col in enumerate(rows[0]) if col.split("_")[0] in NATIVE_RATES
                and int(col.split("_")[1]) < NATIVE_SLICE_S * NATIVE_RATES[col.split("_")[0]]]
        out = dst / FULLRES_FILE
        out.parent.mkdir(parents=True)
        with out.open("w", newline="") as fh:
            csv.writer(fh).writerows([row[i] for i in keep] for row in rows)
        _MADE["zema-native"] = dst
        return dst


def v32hl56_slice() -> Path:
    """CSV file with the V32HL56 slice (module docstring)."""
    with _LOCK:
        if "v32" in _MADE:
            return _MADE["v32"]
        src = _shared_real() / "pump-efficiency-V32HL56" / "V32HL56-efficiency.csv"
        lines = src.read_text(encoding="utf-8").splitlines()
        col = lines[0].split(",").index("Displacement")
        rows = [ln for ln in lines[1:] if ln.strip()
                and round(float(ln.split(",")[col])) in (23, 57)]
        dst = _workdir() / "V32HL56-slice.csv"
        dst.write_text("\n".join([lines[0], *rows]) + "\n", encoding="utf-8")
        _MADE["v32"] = dst
        return dst


def vtnsi_slice() -> list[Path]:
    """The two rotary-actuator recordings of the slice (module docstring): baseline, seal."""
    with _LOCK:
        if "vtnsi" in _MADE:
            return sorted(_MADE["vtnsi"].iterdir())
        src = _shared_real() / "hydraulic-actuator-vtnsi" / "Data"
        dst = _workdir() / "vtnsi"
        dst.mkdir()
        for folder in ("Act_1", "Act_4 (Seal Defect)"):
            first = sorted((src / folder).glob("*.txt.gz"))[0]
            with gzip.open(first, "rt", encoding="utf-8") as fh:
                lines = [next(fh) for _ in range(401)]
            (dst / first.name.removesuffix(".gz")).write_text("".join(lines), encoding="utf-8")
        _MADE["vtnsi"] = dst
        return sorted(dst.iterdir())
