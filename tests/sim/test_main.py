"""``python -m sim``: the demo and the bond graph of a rig file."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml

from sim.__main__ import main
from sim.rigs import reference_rig_document


def _file(tmp_path: Path) -> Path:
    doc = copy.deepcopy(reference_rig_document())
    doc["name"] = "own-condition"
    doc["condition"] = {"force": {"value": 3.3, "unit": "kN"},
                        "oil_temperature": {"value": 47.0, "unit": "degC"}}
    path = tmp_path / "own.yaml"
    path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    return path


def test_the_demo_runs_a_rig_file_at_its_own_condition(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    """The demo ran a rig file at 2100 N and 40 °C whatever its file said (a modelling
    engineer's pass: P1 12 bar where the rig's own 10 kN gives 34)."""
    assert main(["demo", "--rig", str(_file(tmp_path))]) == 0
    assert capsys.readouterr().out.startswith("rig own-condition, fault healthy, load 3300 N, "
                                              "oil 47 °C")
    assert main(["demo", "--rig", str(_file(tmp_path)), "--load", "2000"]) == 0
    assert "load 2000 N, oil 47 °C" in capsys.readouterr().out


def test_the_graph_of_a_rig_file_is_its_circuits(capsys: pytest.CaptureFixture[str]) -> None:
    zema = Path(__file__).resolve().parents[2] / "sim" / "rigs" / "zema.yaml"
    assert main(["graph", "--rig", str(zema), "--format", "dot"]) == 0
    assert capsys.readouterr().out.startswith('digraph "pump-relief-orifice"')
