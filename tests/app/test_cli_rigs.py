"""``hydrodiag rigs``: rig descriptions into the store and back, as ``/rigs`` does."""

from __future__ import annotations

from pathlib import Path

import yaml
from typer.testing import CliRunner

from app.cli import cli
from sim.rigs import load_rig

ZEMA = Path(__file__).resolve().parents[2] / "sim" / "rigs" / "zema.yaml"


def test_a_rig_file_is_added_listed_shown_and_versioned(runner: CliRunner,
                                                         tmp_path: Path) -> None:
    added = runner.invoke(cli, ["rigs", "add", str(ZEMA), "--comment", "from the repo"])
    assert added.exit_code == 0, added.output
    assert "rig 2 'zema-hydraulic-rig' stored (version 1)" in added.stdout
    listed = runner.invoke(cli, ["rigs", "list"])
    assert "paper002-reference" in listed.stdout and "pump-relief-orifice" in listed.stdout
    shown = runner.invoke(cli, ["rigs", "show", "2"])
    doc = yaml.safe_load(shown.stdout)
    # the stored, canonical document loads as the file does: the same parameter values
    assert load_rig(doc).values() == load_rig(ZEMA).values()
    doc["components"]["pump"]["parameters"]["Rlp"]["value"] = 1.75e12
    doc["title"] = "ZeMA [worn]"  # brackets are text, not markup
    (tmp_path / "worn.yaml").write_text(yaml.safe_dump(doc, allow_unicode=True))
    updated = runner.invoke(cli, ["rigs", "update", "2", str(tmp_path / "worn.yaml")])
    assert "version 2 stored" in updated.stdout, updated.output
    # the same document again stores nothing and says so (it said "version 2 stored")
    same = runner.invoke(cli, ["rigs", "update", "2", str(tmp_path / "worn.yaml")])
    assert same.exit_code == 0 and "the document is version 2's; nothing stored" in \
        " ".join(same.stdout.split())
    versions = runner.invoke(cli, ["rigs", "show", "2", "--version", "3"])
    assert versions.exit_code != 0
    latest = yaml.safe_load(runner.invoke(cli, ["rigs", "show", "2"]).stdout)
    first = yaml.safe_load(runner.invoke(cli, ["rigs", "show", "2", "--version", "1",
                                               "--json"]).stdout)
    assert load_rig(latest).values()["pump.Rlp"] == 1.75e12
    assert load_rig(first).values()["pump.Rlp"] == 3.5e12
    assert "ZeMA [worn]" in runner.invoke(cli, ["rigs", "list"]).stdout


def test_bad_rig_files_are_refused_with_the_field_and_store_nothing(runner: CliRunner,
                                                                    tmp_path: Path) -> None:
    again = [runner.invoke(cli, ["rigs", "add", str(ZEMA)]) for _ in range(2)]
    assert again[0].exit_code == 0 and again[1].exit_code != 0
    assert "exists; update it instead" in str(again[1].exception)
    doc = yaml.safe_load(ZEMA.read_text(encoding="utf-8"))
    doc["name"] = "leaky"
    doc["components"]["pump"]["parameters"]["Rlp"]["value"] = -1.0
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(doc, allow_unicode=True))
    bad = runner.invoke(cli, ["rigs", "add", str(tmp_path / "bad.yaml")])
    assert bad.exit_code != 0 and "document.components.pump" in str(bad.exception)
    (tmp_path / "list.yaml").write_text("- 1\n- 2\n")
    assert "not a rig description" in str(
        runner.invoke(cli, ["rigs", "add", str(tmp_path / "list.yaml")]).exception)
    missing = runner.invoke(cli, ["rigs", "show", "7"])
    assert missing.exit_code != 0 and "no rig with id 7" in str(missing.exception)
    listed = runner.invoke(cli, ["rigs", "list"])
    assert "2 rigs" in listed.stdout and "leaky" not in listed.stdout
