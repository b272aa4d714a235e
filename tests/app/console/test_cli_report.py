"""``hydrodiag report``: the console's pages as files, from the store the CLI uses."""

from __future__ import annotations

import io
import json
from pathlib import Path

import matplotlib.image as mpimg
import pytest
from typer.testing import CliRunner

from app.cli import cli
from sim.errors import InputError, NotFoundError
from tests.app.conftest import cli_store

RECORD = {"rig_id": 1, "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
          "pump_pressure": 1453085.96, "p1": 1189895.92, "p2": 121490.42,
          "flow_B": 4.642448567e-4, "flow_C": 4.369589056e-4, "speed_work": 0.197543918,
          "speed_return": 0.218641119, "measured_at": "2026-05-01T08:00:00Z"}


@pytest.fixture
def store(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A CLI store with one diagnosis (id 1) of a worn valve's readings."""
    cli_store(monkeypatch, tmp_path / "data")
    path = tmp_path / "record.json"
    path.write_text(json.dumps({"record": RECORD}))
    result = CliRunner().invoke(cli, ["diagnose", str(path)])
    assert result.exit_code == 0, result.output
    return tmp_path


def test_diagnosis_report_as_html_and_png(store: Path) -> None:
    runner = CliRunner()
    html_path = store / "report.html"
    result = runner.invoke(cli, ["report", "diagnosis", "1", "--output", str(html_path)])
    assert result.exit_code == 0, result.output
    html = html_path.read_text()
    assert "Diagnosis 1: valve" in html and 'class="hd-plot"' in html
    assert "<style>" in html and "/console/static" not in html  # stands alone
    png_path = store / "report.png"
    assert runner.invoke(cli, ["report", "diagnosis", "1", "--output",
                               str(png_path)]).exit_code == 0
    image = mpimg.imread(io.BytesIO(png_path.read_bytes()), format="png")
    assert image.shape[0] > 3 * 250  # three charts one below the other


def test_trends_report_and_refusals(store: Path) -> None:
    runner = CliRunner()
    out = store / "trends.html"
    assert runner.invoke(cli, ["report", "trends", "--rig", "1", "--output",
                               str(out)]).exit_code == 0
    assert "Trends of rig 1" in out.read_text() and "valve" in out.read_text()
    # every point as CSV for a spreadsheet, and the summary printed (a planner found no
    # export of the trends)
    csv_path = store / "trends.csv"
    done = runner.invoke(cli, ["report", "trends", "--rig", "1", "--output", str(csv_path)])
    assert done.exit_code == 0, done.output
    import pandas as pd

    frame = pd.read_csv(csv_path)
    assert list(frame.columns[:5]) == ["component", "quantity", "unit", "measured_at", "value"]
    valve = frame[frame["component"] == "valve"]
    assert len(valve) == 1 and valve["unit"].iloc[0] == "m"
    assert valve["value"].iloc[0] == pytest.approx(54.3e-6, rel=0.1)
    # the answer on stdout, where "> summary.txt" takes it (it went to stderr: a CLI pass)
    assert "trends of rig 1" in done.stdout and "valve" in done.stdout
    assert "last visit [UTC]" in done.output and "2026-05-01 08:00" in done.output
    # each row with its trend's forecast; one component, its threshold and a window (the
    # report took a rig only, the export the points only: a reliability engineer's pass)
    assert {"threshold", "status", "time_left_days", "crossing_at"} <= set(frame.columns)
    assert valve["status"].iloc[0] == "insufficient_data"
    one = runner.invoke(cli, ["report", "trends", "--rig", "1", "--output", str(csv_path),
                              "--component", "valve", "--threshold", "80e-6",
                              "--until", "2026-05-01"])
    assert one.exit_code == 0, one.output
    chosen = pd.read_csv(csv_path)
    assert set(chosen["component"]) == {"valve"} and chosen["threshold"].iloc[0] == 8e-5
    later = runner.invoke(cli, ["report", "trends", "--rig", "1", "--output", str(csv_path),
                                "--since", "2026-05-02"])
    assert later.exit_code == 0 and len(pd.read_csv(csv_path)) == 0
    # a component with no trend is refused by its option's name (a KeyError traceback: a
    # CLI pass), and nothing is written
    for typo in ("gearbox", "Valve", "relief"):
        refused = runner.invoke(cli, ["report", "trends", "--rig", "1", "--output",
                                      str(store / "typo.csv"), "--component", typo])
        assert isinstance(refused.exception, InputError), refused.output
        assert refused.exception.field == "--component"
        assert "cylinder, valve, pump" in refused.exception.message
    assert not (store / "typo.csv").exists()
    unread = runner.invoke(cli, ["report", "trends", "--since", "May 2nd"])
    assert isinstance(unread.exception, InputError) and unread.exception.field == "--since"
    wrong = runner.invoke(cli, ["report", "diagnosis", "1", "--output", str(store / "r.pdf")])
    assert isinstance(wrong.exception, InputError) and wrong.exception.field == "--output"
    missing = runner.invoke(cli, ["report", "diagnosis", "7", "--output", str(store / "r.html")])
    assert isinstance(missing.exception, NotFoundError)
    assert not (store / "r.pdf").exists() and not (store / "r.html").exists()


def test_a_joint_visit_is_shown_against_its_own_records_predictions(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Two records of one visit at 2.1 and 6.3 kN diagnosed jointly are stored with the
    later one; its page compares it with the predictions *of that record* (it once drew
    the 6.3 kN readings against the 2.1 kN predictions: 3.43 MPa measured, 1.45 MPa
    predicted), and shows the σ the diagnosis weighed each reading by (at least the
    instrument's)."""
    from app.cli_support import store_session
    from app.console.views import diagnosis_view
    from sim.rigs import reference_rig
    from tests.diagnostics.synth import FULL, readings

    cli_store(monkeypatch, tmp_path / "data")
    rig = reference_rig()
    records = []
    for day, load in ((1, 2100.0), (2, 6300.0)):
        values = readings(rig, {"valve.cv": 45e-6}, load, 40.0)
        records.append({"rig_id": 1, "measured_at": f"2026-05-0{day}T08:00:00Z",
                        "condition": {"oil_temperature": 40.0, "load_force": load},
                        **{k: values[k] for k in FULL}})
    path = tmp_path / "visit.json"
    path.write_text(json.dumps({"records": records, "joint": True}))
    result = CliRunner().invoke(cli, ["diagnose", str(path)])
    assert result.exit_code == 0, result.output
    with store_session() as session:
        view = diagnosis_view(session, 1)
    assert view.result["record_index"] == 1 and view.result["n_records"] == 2
    for row in view.readings:
        assert row["value"] == pytest.approx(records[1][row["name"]])
        assert row["predicted"]["valve"] == pytest.approx(row["value"], rel=5e-3)
        assert row["sigma"] >= row["u"]
