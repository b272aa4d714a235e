"""``hydrodiag history``: the stored diagnoses read back from the shell, as GET /diagnoses
reads them (a fleet integrator could diagnose and store from the CLI but not list)."""

from __future__ import annotations

import json
from pathlib import Path

import yaml
from typer.testing import CliRunner

from app.cli import cli
from app.cli_support import store_session
from app.services.readback import get_diagnosis, public_diagnosis


def _worn_spool_records(runner: CliRunner, tmp_path: Path) -> Path:
    """Two readings of a worn spool (cv 60 µm) a week apart and one healthy reading."""
    summaries = []
    for options in (["--set", "valve.cv=60e-6"], []):
        shown = runner.invoke(cli, ["simulate", "--steady", "--json", *options])
        assert shown.exit_code == 0, shown.output
        summaries.append(json.loads(shown.stdout)["summary"])
    records = []
    for s, at in ((summaries[0], "2026-05-01T10:00:00Z"), (summaries[0], "2026-05-08T10:00:00Z"),
                  (summaries[1], "2026-04-20T10:00:00Z")):
        records.append({"rig_id": 1, "measured_at": at,
                        "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
                        "p1": s["working.P1 [Pa]"], "p2": s["working.P2 [Pa]"],
                        "flow_B": s["working.Q_meter_B [m^3/s]"],
                        "flow_C": s["working.Q_meter_C [m^3/s]"],
                        "speed_work": s["working.speed [m/s]"],
                        "speed_return": s["return.speed [m/s]"]})
    path = tmp_path / "records.yaml"
    path.write_text(yaml.safe_dump(records))
    return path


def test_history_lists_and_shows_what_diagnose_stored(runner: CliRunner,
                                                      tmp_path: Path) -> None:
    path = _worn_spool_records(runner, tmp_path)
    stored = runner.invoke(cli, ["diagnose", str(path), "--json"])
    assert stored.exit_code == 0, stored.output
    ids = [d["id"] for d in json.loads(stored.stdout)["diagnoses"]]
    listed = runner.invoke(cli, ["history", "list", "--rig", "1", "--json"])
    assert listed.exit_code == 0, listed.output
    body = json.loads(listed.stdout)
    # newest record first, as GET /diagnoses lists them, the healthy one (20 April) last
    assert body["total"] == 3 and [d["id"] for d in body["items"]] == [ids[1], ids[0], ids[2]]
    assert [d["top"] for d in body["items"]] == ["valve", "valve", "healthy"]
    # each item is the HTTP read back without its full result
    with store_session(existing=True) as session:
        http = public_diagnosis(get_diagnosis(session, ids[0])).model_dump(mode="json")
    assert body["items"][1] == {k: v for k, v in http.items() if k != "result"}
    # the window and the component filter, as the query parameters read them
    may = json.loads(runner.invoke(cli, ["history", "list", "--since", "2026-05-01",
                                         "--until", "2026-05-01", "--json"]).stdout)
    assert [d["id"] for d in may["items"]] == [ids[0]]
    # a date and time without its zone is UTC, as the option says (and as the console
    # reads it; it was refused here: a verification pass)
    zoneless = json.loads(runner.invoke(cli, ["history", "list", "--since", "2026-05-01 09:59",
                                              "--until", "2026-05-01 10:01", "--json"]).stdout)
    assert [d["id"] for d in zoneless["items"]] == [ids[0]]
    valve = json.loads(runner.invoke(cli, ["history", "list", "--component", "valve",
                                           "--json"]).stdout)
    assert valve["total"] == 2
    # the table: the spool's clearance in µm with its interval, near the simulated 60 µm
    table = runner.invoke(cli, ["history", "list"])
    assert table.exit_code == 0, table.output
    (row,) = [line for line in table.stdout.splitlines()
              if line.startswith(f"│ {ids[0]} ")]
    cv = next(e for e in http["estimates"] if e["quantity"] == "cv")
    assert 55e-6 < cv["value"] < 65e-6 and f"cv {1e6 * cv['value']:.4g} µm (" in row, row
    healthy = next(line for line in table.stdout.splitlines() if f"│ {ids[2]} " in line)
    assert "Cs " in healthy and "e-08 1 (" not in healthy   # a coefficient shows no unit
    shown = runner.invoke(cli, ["history", "show", str(ids[0])])
    assert shown.exit_code == 0, shown.output
    assert "answer: valve, p = " in shown.stdout and "µm" in shown.stdout
    full = json.loads(runner.invoke(cli, ["history", "show", str(ids[0]), "--json"]).stdout)
    assert full == http


def test_history_refuses_what_it_cannot_read(runner: CliRunner, tmp_path: Path) -> None:
    _worn_spool_records(runner, tmp_path)      # the store exists, with the reference rig
    wrong = runner.invoke(cli, ["history", "list", "--since", "May 1st"])
    assert wrong.exit_code != 0 and getattr(wrong.exception, "field", None) == "--since"
    unknown = runner.invoke(cli, ["history", "list", "--component", "spool"])
    assert unknown.exit_code != 0
    assert getattr(unknown.exception, "field", None) == "--component"
    assert "cylinder" in str(unknown.exception)
    missing = runner.invoke(cli, ["history", "show", "99"])
    assert missing.exit_code != 0 and getattr(missing.exception, "field", None) == "diagnosis_id"
