"""Table files as loggers write them (diagnostics.table_files): the CSV dialect, gzip."""

from __future__ import annotations

import io

import numpy as np
import pandas as pd
import pytest

from diagnostics.table_files import dialect, read_table, table_bytes
from diagnostics.timeseries import read_series
from sim.errors import InputError


def test_the_dialect_is_found_from_the_first_lines():
    assert dialect(["t [s],P1 [bar]", "0,1.5"]) == (",", ".")
    assert dialect(["t [s];P1 [bar]", "0;1,5", "0,5;2,5"]) == (";", ",")
    assert dialect(["t [s];P1 [bar]", "0;1.5"]) == (";", ".")
    assert dialect(["t [s]\tP1 [bar]", "0\t1,5"]) == ("\t", ",")
    assert dialect(["t [s]\tP1 [bar]", "0\t4288"]) == ("\t", ".")  # integers: no mark
    # a comma file whose one text column holds a semicolon in a row: still commas
    assert dialect(["t [s],note", "0,a;b", "1,c"]) == (",", ".")
    frame, meta, name = read_table(b"# rig = \"x\"\nt [s];P1 [bar]\n0;1,5\n")
    assert meta == {"rig": "x"} and name == "upload"
    assert frame.to_dict("list") == {"t [s]": [0], "P1 [bar]": [1.5]}


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_a_written_table_reads_back_with_its_header(fmt):
    """What an export or an adapter writes (table_bytes) reads back to the same doubles,
    texts and header; a text holding a separator or quote is quoted, and only then."""
    values = np.array([0.1, 1 / 3, 2.5e-7, -1e6])
    header = {"rig": "preset", "condition": {"load": 4200.0}, "started_at": None}
    for names in (["r1", "r2", "r3", "r4"], ["a,b", 'say "x"', "c", "d"]):
        frame = pd.DataFrame({"record": names, "t [s]": values, "P1 [Pa]": values * 7})
        back, meta, _ = read_table(table_bytes(frame, header, fmt), fmt)
        assert meta == header
        assert back["record"].tolist() == names
        np.testing.assert_array_equal(back["P1 [Pa]"].to_numpy(), values * 7)  # every bit
    plain = table_bytes(frame.assign(record=["r1", "r2", "r3", "r4"]), {}, "csv")
    assert b'"' not in plain


def test_semicolons_and_decimal_commas_and_tabs_are_read():
    """A spreadsheet's CSV in many locales (';' and '1,5') and a tab-separated logger file
    read as the comma CSV does; a comma file with a decimal point stays as it was."""
    comma = read_series(b"t [s],P1 [bar]\n0,1.5\n0.5,2.5\n")[0]
    semi = read_series(b"t [s];P1 [bar]\n0;1,5\n0,5;2,5\n")[0]
    tab = read_series(b"t [s]\tP1 [bar]\n0\t1.5\n0.5\t2.5\n")[0]
    for rec in (semi, tab):
        np.testing.assert_array_equal(rec.t, comma.t)
        np.testing.assert_array_equal(rec.channel("P1"), comma.channel("P1"))
    np.testing.assert_allclose(comma.channel("P1"), [1.5e5, 2.5e5])
    # semicolons with decimal points (and thousands nowhere): points stay points
    point = read_series(b"t [s];P1 [bar]\n0;1.5\n0.5;2.5\n")[0]
    np.testing.assert_array_equal(point.channel("P1"), comma.channel("P1"))


def test_gzip_files_are_read_and_broken_ones_refused(tmp_path):
    """A .gz file (one member or several, as ``cat a.gz b.gz`` makes) reads as its text,
    the record named without .gz; truncated or over-large data is refused naming the
    file."""
    import gzip

    text = b"t [s];P1 [bar]\n0;1,5\n0,5;2,5\n"
    path = tmp_path / "run.csv.gz"
    path.write_bytes(gzip.compress(text))
    (rec,) = read_series(path)
    assert rec.name == "run.csv"
    np.testing.assert_allclose(rec.channel("P1"), [1.5e5, 2.5e5])
    two = gzip.compress(text[:20]) + gzip.compress(text[20:])
    np.testing.assert_array_equal(read_series(two)[0].channel("P1"), rec.channel("P1"))
    for raw, words in ((gzip.compress(text)[:-12], "end before"),
                       (gzip.compress(text * 100), "more than 1000 bytes"),
                       (b"\x1f\x8b" + b"\x00" * 20, "gzip")):
        with pytest.raises(InputError) as err:
            read_series(raw, max_bytes=1000)
        assert err.value.field == "file" and words in err.value.message


def test_a_loggers_time_is_read_from_the_file_name():
    """The vtnsi recordings' names carry their start (``…_9-10-2019-4-37-01 PM``): read in
    the zone given, or by the name's own offset; a directive the reader does not know, a
    missing or doubled zone and a name without such a time are refused naming the field."""
    from datetime import UTC, datetime

    from diagnostics.table_files import time_in_name

    name = "Leak_000_0_303_9-10-2019-4-37-01 PM.txt"
    fmt = "%m-%d-%Y-%I-%M-%S %p"
    assert time_in_name(name, fmt, "-04:00") == datetime(2019, 9, 10, 20, 37, 1, tzinfo=UTC)
    assert time_in_name(name, fmt, "Z") == datetime(2019, 9, 10, 16, 37, 1, tzinfo=UTC)
    assert time_in_name("run_20261120T081500+0100.csv", "%Y%m%dT%H%M%S%z") == datetime(
        2026, 11, 20, 7, 15, tzinfo=UTC)
    # the first place that reads as a date wins: 13-40-... is passed over
    assert time_in_name("13-40-2019_01-02-2020.csv", "%m-%d-%Y", "Z") == datetime(
        2020, 1, 2, tzinfo=UTC)
    for args, field in (((name, "%c", "Z"), "time_in_name"),
                        ((name, fmt), "time_in_name"),
                        (("x+0100", "x%z", "Z"), "time_in_name"),
                        ((name, fmt, "EST"), "zone"),
                        ((name, fmt, "+25:00"), "zone"),  # not an offset (was a ValueError)
                        ((name, fmt, "+01:75"), "zone"),
                        (("no-time.csv", fmt, "Z"), "time_in_name")):
        with pytest.raises(InputError) as err:
            time_in_name(*args)
        assert err.value.field == field, args


@pytest.mark.parametrize(("content", "says"), [
    (b"\x00\x01\x02PK\x03", "binary, not a text table"),
    (b"t [s],P1 [bar]\n0,1,5\n0.001,2,5\n", "more field(s) than the header"),
])
def test_a_series_file_that_is_no_table_says_why(content: bytes, says: str) -> None:
    with pytest.raises(InputError) as e:
        read_series(content, format="csv")
    assert e.value.field == "file" and says in e.value.message


@pytest.mark.parametrize(("content", "field", "says"), [
    # pandas read the second as "P1 [bar].1" and asked for its unit in brackets
    (b"t [s],P1 [bar],P1 [bar]\n0,1,2\n1,1,2\n", "P1 [bar]", "names 'P1 [bar]' twice (columns 2 and 3)"),
    (b"t [s],,P1 [bar]\n0,3,1\n1,3,2\n", "column 2", "column 2 has no name"),
    ("t [s];Öl [degC]\n0;40\n".encode("cp1252"), "file", "cp1252?); save it as UTF-8"),
])
def test_a_header_as_written_is_named_in_the_refusal(content: bytes, field: str,
                                                      says: str) -> None:
    """An analyst's pass: the duplicate reported as 'P1 [bar].1' with a wrong reason, a
    column without a name as 'Unnamed: 1', a cp1252 file as "not UTF-8" alone."""
    with pytest.raises(InputError) as exc:
        read_table(content)
    assert exc.value.field == field and says in exc.value.message, exc.value.message


def test_excels_separator_line_and_a_trailing_delimiter_are_read() -> None:
    for content in (b"sep=;\nt [s];P1 [bar]\n0;1,5\n1;1,6\n", b"t [s];P1 [bar];\n0;1,5;\n1;1,6;\n"):
        frame, _, _ = read_table(content)
        assert list(frame.columns) == ["t [s]", "P1 [bar]"]
        assert frame["P1 [bar]"].tolist() == [1.5, 1.6]


def test_a_table_of_too_many_columns_is_refused_before_any_work_per_column() -> None:
    """200,000 columns held a worker for more than ten minutes (a security review's pass):
    the duplicate-channel check scanned every earlier column.  A table is refused past
    MAX_COLUMNS, in its CSV header or its Parquet metadata; within it the check is a set."""
    import time

    from diagnostics.table_files import MAX_COLUMNS
    from diagnostics.timeseries import series_from_frame

    wide = ",".join(["t [s]"] + [f"c{i} [Pa]" for i in range(MAX_COLUMNS + 5)])
    content = (wide + "\n" + ",".join(["0"] + ["1"] * (MAX_COLUMNS + 5)) + "\n").encode()
    with pytest.raises(InputError, match=r"1,006 columns, more than the 1,000") as caught:
        read_table(content)
    assert caught.value.field == "file"
    # nor rows of more fields than that under a short header (pandas tokenised 200,000
    # fields for 16.5 s before refusing them: a verification pass)
    short = ("t [s],P1 [Pa]\n0,1\n" + ",".join(["1"] * 200_000) + "\n").encode()
    with pytest.raises(InputError, match=r"200,000 columns"):
        read_table(short)
    frame = pd.DataFrame(np.zeros((3, MAX_COLUMNS + 5)),
                         columns=["t [s]"] + [f"c{i} [Pa]" for i in range(MAX_COLUMNS + 4)])
    frame["t [s]"] = [0.0, 0.001, 0.002]
    with pytest.raises(InputError, match="columns, more than"):
        read_table(table_bytes(frame, {}, "parquet"))
    # the limit itself: as many columns as allowed read in a moment (quadratic: seconds)
    allowed = frame.iloc[:, :MAX_COLUMNS]
    started = time.perf_counter()
    series_from_frame(read_table(table_bytes(allowed, {}, "parquet"))[0])
    assert time.perf_counter() - started < 30.0   # a bound on a runaway, not a timing claim


def test_a_parquet_file_that_decodes_beyond_the_limit_is_refused_before_decoding() -> None:
    """262 kB of zstd-compressed zeros decoded to 480 MB and grew a worker by 1 GB."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    zeros = pa.table({"t [s]": np.zeros(2_000_000), "P1 [Pa]": np.zeros(2_000_000)})
    buffer = io.BytesIO()
    pq.write_table(zeros, buffer, compression="zstd")
    assert len(buffer.getvalue()) < 200_000
    with pytest.raises(InputError, match=r"decodes to 31 MiB, more than the 16 MiB"):
        read_table(buffer.getvalue(), max_bytes=16 * 2**20)
    assert read_table(buffer.getvalue())[0].shape == (2_000_000, 2)   # within 64 MiB
