"""``hydrodiag diagnose-batch``: a CSV or JSON Lines file of records, each diagnosed alone."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from app.cli import cli
from diagnostics.batch import diagnose_many
from sim.rigs import reference_rig
from tests.diagnostics.synth import FULL, readings, record

_CASES = ({"valve.cv": 60e-6}, {"cylinder.cc": 150e-6}, {})



def _rows() -> list[dict[str, float]]:
    rig = reference_rig()
    rows = []
    for k, faults in enumerate(_CASES):
        temperature, load = 35.0 + 5 * k, 1800.0 + 400 * k
        vals = readings(rig, faults, load, temperature)
        row = {f: vals[f] for f in FULL}
        row["condition.oil_temperature"] = temperature
        row["condition.load_force"] = load
        rows.append(row)
    return rows


def test_a_csv_batch_names_each_fault_and_writes_a_result_per_row(
        runner: CliRunner, tmp_path: Path) -> None:
    pd.DataFrame(_rows()).to_csv(tmp_path / "records.csv", index=False)
    out = tmp_path / "results.jsonl"
    result = runner.invoke(cli, ["diagnose-batch", str(tmp_path / "records.csv"), "--rig", "1",
                                 "--out", str(out)])
    assert result.exit_code == 0, result.output
    results = [json.loads(line) for line in out.read_text().splitlines()]
    assert [r["top"] for r in results] == ["valve", "cylinder", "healthy"]
    # each line names the record it answers: 1-based as the errors count, its rig, its time
    assert [(r["record"], r["rig_id"], r["measured_at"]) for r in results] == [
        (1, 1, None), (2, 1, None), (3, 1, None)]
    (cv,) = results[0]["parameters"]
    assert cv["name"] == "cv" and abs(cv["value"] - 60e-6) < 0.03 * 60e-6
    assert cv["low"] <= 60e-6 <= cv["high"]
    (cc,) = results[1]["parameters"]
    assert abs(cc["value"] - 150e-6) < 0.03 * 150e-6


def test_a_jsonl_batch_with_a_bad_record_is_refused_naming_the_line(
        runner: CliRunner, tmp_path: Path) -> None:
    lines = []
    for row in _rows():
        cond = {"oil_temperature": row.pop("condition.oil_temperature"),
                "load_force": row.pop("condition.load_force")}
        lines.append(json.dumps({**row, "condition": cond}))
    lines[1] = lines[1].replace('"p1"', '"p_one"')
    path = tmp_path / "records.jsonl"
    path.write_text("\n".join(lines) + "\n")
    bad = runner.invoke(cli, ["diagnose-batch", str(path)])
    assert bad.exit_code != 0
    assert getattr(bad.exception, "field", "").startswith("line 2")


def test_every_refused_record_is_listed_and_the_others_can_be_diagnosed(
        runner: CliRunner, tmp_path: Path) -> None:
    # one bad logger row threw the whole batch away, naming only the first (a fleet pass)
    rows = _rows()
    rows[0]["p1"] = -1.188e6            # below vacuum
    rows[2]["condition.oil_temperature"] = 400.0
    path = tmp_path / "night.csv"
    pd.DataFrame(rows).to_csv(path, index=False)
    refused = runner.invoke(cli, ["diagnose-batch", str(path), "--rig", "1"])
    assert refused.exit_code != 0
    message = getattr(refused.exception, "message", "")
    assert message.startswith("2 records of 3 would be refused")
    assert "row 1: p1" in message and "row 3: condition.oil_temperature" in message
    out = tmp_path / "results.jsonl"
    done = runner.invoke(cli, ["diagnose-batch", str(path), "--rig", "1", "--skip-invalid",
                               "--out", str(out)])
    assert done.exit_code == 0, done.output
    assert "refused (invalid record)" in done.stdout  # the table on stdout (a CLI pass)
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert [line["record"] for line in lines] == [1, 2, 3]   # in the file's order
    assert lines[0]["error"]["field"] == "row 1: p1" and "top" not in lines[0]
    assert lines[1]["top"] == "cylinder" and "error" not in lines[1]
    assert lines[2]["error"]["field"].startswith("row 3: condition.oil_temperature")
    # a record the diagnosis refuses (p1 in bar: it cannot push the load) has the same
    # shape, its field named from its row (two shapes broke a parser: a fleet pass)
    rows.append(dict(rows[1], p1=rows[1]["p1"] / 1e5))
    pd.DataFrame(rows).to_csv(path, index=False)
    again = runner.invoke(cli, ["diagnose-batch", str(path), "--rig", "1", "--skip-invalid",
                                "--out", str(out)])
    assert again.exit_code == 0, again.output
    last = json.loads(out.read_text().splitlines()[3])
    assert last["record"] == 4 and last["error"]["field"] == "row 4: p1", last
    assert set(last["error"]) == {"type", "field", "message"} and "bar" in last["error"]["message"]
    # a nan cell and a rig the store lacks are refused alone too (each refused the whole
    # batch: a CLI pass)
    rows.append(dict(rows[1], p1="nan"))
    rows.append(dict(rows[1], rig_id=99))
    pd.DataFrame(rows).to_csv(path, index=False)
    third = runner.invoke(cli, ["diagnose-batch", str(path), "--rig", "1", "--skip-invalid",
                                "--out", str(out)])
    assert third.exit_code == 0, third.output
    kept = [json.loads(line) for line in out.read_text().splitlines()]
    assert [line["record"] for line in kept] == [1, 2, 3, 4, 5, 6]
    assert kept[4]["error"]["field"] == "row 5" and "empty cell" in kept[4]["error"]["message"]
    assert kept[5]["error"] == {"type": "NotFoundError", "field": "row 6: rig_id",
                                "message": "no rig with id 99"}
    assert kept[1]["top"] == "cylinder"


def test_an_unreachable_dask_scheduler_is_named_by_the_option_that_gave_it(
        runner: CliRunner, tmp_path: Path) -> None:
    """``--dask tcp://…`` that does not answer was refused as HYDRODIAG_DASK_SCHEDULER's,
    "correct HYDRODIAG_DASK_SCHEDULER", a variable not set (a review's leftover): the
    option is named, as ``serve --port`` names ``--port``."""
    pytest.importorskip("distributed")
    pd.DataFrame(_rows()[:1]).to_csv(tmp_path / "records.csv", index=False)
    refused = runner.invoke(cli, ["diagnose-batch", str(tmp_path / "records.csv"),
                                  "--dask", "tcp://127.0.0.1:9"])
    assert refused.exit_code == 1, refused.output
    assert getattr(refused.exception, "field", None) == "--dask"
    message = refused.exception.message  # type: ignore[union-attr]
    assert "tcp://127.0.0.1:9 does not answer" in message
    assert message.endswith("start it or correct --dask")
    assert "HYDRODIAG_DASK_SCHEDULER" not in message


def test_diagnose_many_on_a_process_pool_and_a_dask_cluster_equals_in_process() -> None:
    """The same records give the same results, to the last digit, in-process, on 2
    processes and on a 2-worker Dask LocalCluster (through SweepExecutors, as sweeps use
    it)."""
    from distributed import LocalCluster

    from app.services.executors import SweepExecutors

    rig = reference_rig()
    records = [record(rig, f, load=1500.0 + 300 * k, temperature=30.0 + 7 * k)
               for k, f in enumerate(_CASES * 2)]
    seen: list[tuple[int, int]] = []
    here = diagnose_many(rig, records, progress=lambda d, t: seen.append((d, t)))
    assert seen[-1] == (len(records), len(records))
    pool = SweepExecutors(workers=2)
    assert pool.capacity() == 2
    try:
        on_pool = diagnose_many(rig, records, executor=pool.get(), chunk_size=2)
    finally:
        pool.shutdown()
    with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster:
        dask = SweepExecutors(dask_scheduler=cluster.scheduler_address)
        try:
            executor = dask.get()
            # the cluster's threads, which the Dask executor does not say itself (the
            # chunks were planned for 2 workers whatever the cluster: a design pass)
            assert dask.capacity() == 2 and not hasattr(executor, "_max_workers")
            on_dask = diagnose_many(rig, records, executor=executor, chunk_size=2,
                                    workers=dask.capacity())
        finally:
            dask.shutdown()
    # every digit: the workers start each diagnosis as this process does (they differed
    # by up to 3e-7 in a probability, 2e-5 relative in a χ², before a determinism pass:
    # the steady solver's start and the fast path's Newton states were carried over)
    assert json.dumps(on_pool) == json.dumps(here)
    assert json.dumps(on_dask) == json.dumps(here)
    assert [a["top"] for a in here] == [a["top"] for a in on_dask]
    # each line says how far its tested fit is from the χ² limit, as /diagnose does (the
    # noise-free records are explained: inside the limit)
    for line in here:
        assert line["explained"] and 0.0 <= line["uncertainty_factor"] <= 1.0
    # a cluster of another size than the local pool's default (2 on a 2-core machine):
    # the chunks are planned for its 3 threads, not for the fallback
    with LocalCluster(n_workers=1, threads_per_worker=3, processes=False,
                      dashboard_address=None) as cluster:
        three = SweepExecutors(dask_scheduler=cluster.scheduler_address)
        try:
            three.get()
            assert three.capacity() == 3
        finally:
            three.shutdown()


def test_a_row_is_read_as_written_or_refused_naming_its_line(runner: CliRunner,
                                                            tmp_path: Path) -> None:
    """A cut row (fewer cells than the header: its last readings became "not taken" and the
    row was diagnosed 'pump'), a ``nan`` cell (read as not taken, where JSON refuses NaN)
    and extra filled cells are refused naming the line; a spreadsheet's trailing commas on
    every line are read as the table (they shifted every column: 40 °C read as 2100)."""
    rows = _rows()
    header = ",".join(rows[0])
    line = ",".join(str(v) for v in rows[0].values())
    for body, words in [
        (f"{header}\n{line}\n{','.join(line.split(',')[:3])}\n", "line 3 has 3 cells"),
        (f"{header}\n{line.replace(str(rows[0]['p1']), 'nan')}\n", "line 2: p1 is 'nan'"),
        (f"{header}\n{line},7\n", "line 2 has"),
    ]:
        path = tmp_path / "bad.csv"
        path.write_text(body)
        result = runner.invoke(cli, ["diagnose-batch", str(path), "--rig", "1"])
        assert result.exit_code != 0
        assert words in str(result.exception), (words, result.output)
    path = tmp_path / "excel.csv"
    path.write_text(f"# exported\n{header},\n{line},\n")
    out = tmp_path / "results.jsonl"
    result = runner.invoke(cli, ["diagnose-batch", str(path), "--rig", "1", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert json.loads(out.read_text().splitlines()[0])["top"] == "valve"


def test_a_quoted_cell_may_span_lines_and_a_broken_quote_is_refused() -> None:
    """Rows are counted by the CSV reader, not by lines: a note with a line break in its
    cell kept the table one row short of its lines (a ValueError, a 500 on the console)."""
    import pytest

    from app.schemas.record_csv import record_rows
    from sim.errors import InputError

    rows = record_rows(b'rig_id,note\n1,"first\nsecond"\n2,x\n', field="file")
    assert rows == [{"rig_id": 1, "note": "first\nsecond"}, {"rig_id": 2, "note": "x"}]
    for broken in (b'rig_id,note\n1,"open\n', b'rig_id,note\n1,"a"b\n'):
        with pytest.raises(InputError) as err:
            record_rows(broken, field="file")
        assert err.value.field == "file" and "not a readable CSV" in err.value.message


def test_a_european_spreadsheets_records_are_read_as_the_series_import_reads() -> None:
    """A semicolon file with decimal commas was one column named 'rig_id;measured_at;…' (a
    maintenance planner's pass, on the console's upload); Excel's sep= line as well."""
    from app.schemas.record_csv import record_rows

    expected = [{"rig_id": 1, "condition": {"oil_temperature": 40.5}, "p1": 1188000}]
    for content in (b"rig_id;condition.oil_temperature;p1\n1;40,5;1188000\n",
                    b"sep=;\nrig_id;condition.oil_temperature;p1\n1;40,5;1188000\n",
                    b"rig_id\tcondition.oil_temperature\tp1\n1\t40.5\t1188000\n"):
        assert record_rows(content, field="file") == expected, content


def test_a_fleet_file_diagnoses_each_record_against_its_own_rig(
        runner: CliRunner, tmp_path: Path) -> None:
    """A file naming two rigs was refused ("one rig per batch"), where POST /diagnose takes
    mixed rigs (a fleet integrator's pass): the same readings of a spool at 60 µm are a
    worn valve on the paper rig and a healthy one on a rig whose document has that spool."""
    import copy

    import yaml

    from sim.rigs import reference_rig_document

    doc = copy.deepcopy(reference_rig_document())
    doc["name"] = "loose-spool-rig"
    doc["components"]["valve"]["parameters"]["cv"] = {"value": 60.0, "unit": "µm"}
    (tmp_path / "loose.yaml").write_text(yaml.safe_dump(doc, allow_unicode=True))
    added = runner.invoke(cli, ["rigs", "add", str(tmp_path / "loose.yaml")])
    assert added.exit_code == 0, added.output
    loose = int(added.stdout.split()[1])                 # "rig 2 'loose-spool-rig' stored"
    worn = _rows()[0]                                    # cv 60 µm, on rig 1's document
    rows = [dict(worn, rig_id=1), dict(worn, rig_id=loose)]
    pd.DataFrame(rows).to_csv(tmp_path / "fleet.csv", index=False)
    out = tmp_path / "fleet.jsonl"
    result = runner.invoke(cli, ["diagnose-batch", str(tmp_path / "fleet.csv"),
                                 "--out", str(out)])
    assert result.exit_code == 0, result.output
    results = [json.loads(line) for line in out.read_text().splitlines()]
    assert [(r["record"], r["rig_id"], r["top"]) for r in results] == [
        (1, 1, "valve"), (2, loose, "healthy")]


def test_a_batch_rate_reads_as_a_number() -> None:
    """0.22 records/s read "0", 312 read "3e+02" (a docs reader's and a verifier's pass)."""
    from app.cli_batch import _rate

    assert [_rate(x) for x in (0.22, 3.44, 312.4)] == ["0.22", "3.4", "312"]


def test_dask_asked_for_without_dask_installed_is_refused_not_run_locally(
        runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--dask`` on a machine without dask.distributed ran the batch on local processes
    with a log warning only (a review's leftover): the option asked for Dask by name."""
    from app.services import executors

    monkeypatch.setattr(executors, "dask_available", lambda: False)
    monkeypatch.setenv("HYDRODIAG_DATA_DIR", str(tmp_path / "store"))
    pd.DataFrame(_rows()[:1]).to_csv(tmp_path / "records.csv", index=False)
    refused = runner.invoke(cli, ["diagnose-batch", str(tmp_path / "records.csv"),
                                  "--dask", "tcp://127.0.0.1:8786"])
    assert refused.exit_code == 1, refused.output
    assert getattr(refused.exception, "field", None) == "--dask"
    assert "needs dask.distributed" in refused.exception.message  # type: ignore[union-attr]
    assert not (tmp_path / "store").exists()   # refused before the store is opened
