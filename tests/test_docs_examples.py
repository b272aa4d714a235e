"""The README's and the docs' examples, taken from the pages themselves, run and give what
the pages say they give.

A copy of an example in a test stays green while the README drifts; these tests read the
README's own code blocks and the results written beside them (``# 0.74``, ``# → "top":
"valve" (p ≈ 0.8)``), so an edit of either is checked:

* the Python block is executed as written, and every line ending in a number comment is
  evaluated against that number to the digits it is written with; the comment naming the
  diagnosis' answer and its spool clearance is checked on the diagnosis;
* the command-line block's ``python -m sim`` commands run and exit 0;
* the HTTP block's ``curl`` commands run, as written but for the server's address, against a
  live server on a fresh store, and the results its ``→`` comments state are checked: the
  diagnosis' top name, probability and clearances, the simulation's summary, the stored
  series' id, the record read back from it and its diagnosis, and the discrepancy job's
  verdict on the simulated cycle alone (the block's ``cycles.csv`` is the user's file; the
  README states what ``worn_valve.csv`` alone answers) and its page;
* every ``hydrodiag`` command of the README and the docs names a command the CLI has, with
  options it has;
* docs/real-data.md's Python example runs on the shared ZeMA data, and what it estimates
  without the labels orders them;
* every setting is named as its environment variable in the README or the docs, with the
  default the docs state.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import textwrap
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from diagnostics.table_files import _header_lines
from tests.app.live import LiveServer, live_server, store_settings

README = Path(__file__).resolve().parents[1] / "README.md"
ADDRESS = "http://127.0.0.1:8000"


def block_after(heading: str, language: str) -> str:
    """The first ``language`` block after the README line ``heading``."""
    text = README.read_text(encoding="utf-8")
    at = text.index(heading)
    found = re.search(rf"^```{language}\n(.*?)^```", text[at:], flags=re.S | re.M)
    assert found, f"no {language} block after {heading!r}"
    return found.group(1)


def close_to_written(value: float, written: str) -> bool:
    """Whether ``value`` rounds to ``written`` at the digits it is written with (0.74:
    within 0.005; 60: within 0.5)."""
    decimals = len(written.split(".")[1]) if "." in written else 0
    return abs(value - float(written)) <= 0.5 * 10.0 ** -decimals * (1 + 1e-9)


def examples(block: str) -> list[tuple[str, str]]:
    """The block's commands as the shell reads them (continuation lines and quotes open
    across lines joined, comment lines left out), each with what its ``→`` comments say:
    the one on its own last line and the comment lines after it, up to the next command."""
    out: list[tuple[str, list[str]]] = []
    pending = ""
    inside = False
    for line in block.splitlines():
        comment = line.strip()
        if not pending and (not comment or comment.startswith("#")):
            inside = "→" in comment or (inside and comment.startswith("#   "))
            if inside and out:
                out[-1][1].append(comment.split("→", 1)[-1].lstrip("# "))
            continue
        pending += line + "\n"
        if pending.rstrip().endswith("\\"):
            continue
        try:
            shlex.split(pending, comments=True)
        except ValueError:  # a quote still open: the command goes on
            continue
        inside = "→" in line
        out.append((pending.strip(), [line.split("→", 1)[1]] if inside else []))
        pending = ""
    return [(command, " ".join(said)) for command, said in out]


def commands(block: str) -> list[str]:
    """The block's commands (:func:`examples`)."""
    return [command for command, _ in examples(block)]


def number(pattern: str, text: str) -> str:
    found = re.search(pattern, text)
    assert found, f"the README no longer states {pattern!r}: {text!r}"
    return found.group(1)


# --- the Python example ---------------------------------------------------------------------


def test_the_python_example_runs_and_gives_its_numbers() -> None:
    """Every statement of the block runs; each line ``EXPR  # NUMBER`` evaluates to the
    number as written, and the diagnosis answers what its comment says."""
    code = block_after("### From Python", "python")
    namespace: dict[str, Any] = {}
    exec(compile(code, "README.md", "exec"), namespace)  # the README's own code
    checked = 0
    for line in code.splitlines():
        found = re.match(r"^(\S.*?)\s+#\s*([-+]?\d+(?:\.\d+)?)\s*$", line)
        if found:
            value = float(eval(found.group(1), namespace))  # the README's own code
            assert close_to_written(value, found.group(2)), (line, value)
            checked += 1
    assert checked >= 1, "no line of the Python example states a number any more"
    answer = number(r'd\.answer == "(\w+)"', code)
    diagnosis = namespace["d"]
    assert diagnosis.answer == answer
    cv = number(r"cv ≈ (\d+(?:\.\d+)?) µm", code)
    (estimate,) = diagnosis.top.parameters
    assert estimate.name == "cv"
    assert close_to_written(estimate.value * 1e6, cv), estimate.value


# --- the command line -------------------------------------------------------------------------


def test_the_simulators_commands_run(tmp_path: Path) -> None:
    """``python -m sim demo`` and ``sim graph --format dot`` as the README writes them (the
    project's interpreter for ``.venv/bin/python``): exit 0, a summary, a dot graph."""
    block = block_after("### From the command line", "sh")
    ran = 0
    for command in commands(block):
        argv = shlex.split(command.replace(".venv/bin/python", shlex.quote(sys.executable)),
                           comments=True)
        target = None
        if ">" in argv:
            at = argv.index(">")
            target, argv = tmp_path / argv[at + 1], argv[:at]
        done = subprocess.run(argv, capture_output=True, text=True, timeout=600,
                              cwd=README.parent, check=False)
        assert done.returncode == 0, (command, done.stderr[-2000:])
        if target is not None:
            target.write_text(done.stdout)
            assert done.stdout.lstrip().startswith(("digraph", "graph")), done.stdout[:200]
        else:
            assert "velocity" in done.stdout.lower(), done.stdout[-2000:]
        ran += 1
    assert ran == 2


# --- over HTTP --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    """A server on a fresh store, as ``make run`` starts one (the reference rig is rig 1)."""
    with live_server(store_settings(tmp_path_factory.mktemp("store"))) as live:
        yield live


def _curl(command: str, server: LiveServer, cwd: Path) -> str:
    done = subprocess.run(
        ["bash", "-c", command.replace(ADDRESS, server.base_url)], capture_output=True,
        text=True, timeout=600, cwd=cwd, check=False,
        env={"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HYDRODIAG_KEY": server.key})
    assert done.returncode == 0, (command, done.stderr)
    return done.stdout


def test_the_http_examples_give_what_their_comments_say(server: LiveServer,
                                                        tmp_path: Path) -> None:
    """The block's curl commands in order; what each ``→`` comment states is checked."""
    if shutil.which("curl") is None:
        pytest.skip("curl is not installed: the README's HTTP examples are curl commands")
    block = block_after("### Over HTTP", "sh")
    said = {c: claims for c, claims in examples(block) if c.startswith("curl")}
    curls = list(said)
    out: dict[str, str] = {}
    for command in curls:
        if "/discrepancy" in command:  # cycles.csv is the user's: after the others
            continue
        out[command] = _curl(command, server, tmp_path)

    (diagnose,) = [c for c in out if "/diagnose" in c]
    (answer,) = json.loads(out[diagnose])["diagnoses"]
    text = said[diagnose]
    assert answer["top"] == number(r'"top": "(\w+)"', text)
    assert close_to_written(answer["probability"], number(r"p ≈ (\d\.\d+)", text))
    assert answer["explained"] is (number(r'"explained": (\w+)', text) == "true")
    estimates = {e["quantity"]: e for e in answer["estimates"]}
    for quantity in ("cv", "cc"):
        written = number(rf"{quantity} ≈ (\d+) µm", text)
        assert close_to_written(estimates[quantity]["value"] * 1e6, written), estimates
    assert answer["result"]["isolability"]["statements"], "the comment promises them"

    (simulate,) = [c for c in out if "/simulate" in c]
    text = said[simulate]
    header, _ = _header_lines((tmp_path / "worn_valve.csv").read_text())
    summary = header["summary"]  # the export's own header, read as the importer reads it
    assert close_to_written(summary["working.speed [m/s]"],
                            number(r"working speed (\d\.\d+) m/s", text)), summary
    assert close_to_written(summary["velocity_ratio [-]"],
                            number(r"velocity ratio (\d\.\d+)", text)), summary

    (upload,) = [c for c in out if "/series" in c and "-F" in c]
    stored = json.loads(out[upload])
    assert stored["items"][0]["id"] == int(number(r'"items": \[\{"id": (\d+)', said[upload]))
    (read,) = [c for c in out if "/record" in c]
    record = json.loads(out[read])["record"]
    text = said[read]
    assert close_to_written(record["p1"] / 1e6, number(r'"p1": (\d\.\d+)e6', text)), record
    assert close_to_written(record["speed_work"], number(r'"speed_work": (\d\.\d+)', text))
    again = server.client.post("/diagnose", json={"record": record, "store": False})
    assert again.status_code == 200, again.text
    assert again.json()["diagnoses"][0]["top"] == number(r'"top": "(\w+)"', text)

    (discrepancy,) = [c for c in curls if "/discrepancy" in c]
    shutil.copy(tmp_path / "worn_valve.csv", tmp_path / "cycles.csv")
    job = json.loads(_curl(discrepancy, server, tmp_path))["job_id"]
    deadline = time.monotonic() + 600.0
    while (status := server.client.get(f"/jobs/{job}").json())["status"] in ("queued",
                                                                               "running"):
        assert time.monotonic() < deadline, status
        time.sleep(0.5)
    assert status["status"] == "succeeded", status
    verdict = number(r'worn_valve\.csv alone answers "([^"]+)"', block)
    assert status["result"]["verdict"] == verdict, status["result"]["message"]
    page = server.client.get(f"/jobs/{job}", params={"format": "html"})
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    assert verdict in page.text


def test_every_curl_of_the_readme_is_checked() -> None:
    """The test above checks five curl examples by what they do (diagnose, simulate,
    series upload, record read-back, discrepancy); one added to the README's HTTP block
    needs its check there."""
    block = block_after("### Over HTTP", "sh")
    curls = [c for c in commands(block) if c.startswith("curl")]
    kinds = ("/diagnose", "/simulate", "/rigs/1/series", "/record", "/discrepancy")
    assert len(curls) == len(kinds)
    assert all(sum(k in c for c in curls) == 1 for k in kinds), curls


# --- the hydrodiag command line -----------------------------------------------------------


DOCS = sorted((README.parent / "docs").glob("*.md"))


def _hydrodiag_lines() -> list[list[str]]:
    """Every ``hydrodiag`` command of the README's sh blocks and of the README's and the
    docs' inline code (``hydrodiag keys rotate ID [--grace S]``: optional parts' brackets
    dropped), as words after the program."""
    text = README.read_text(encoding="utf-8")
    found = []
    for block in re.findall(r"^```sh\n(.*?)^```", text, flags=re.S | re.M):
        for command in commands(block):
            words = shlex.split(command, comments=True)
            at = [i for i, w in enumerate(words) if w.endswith("bin/hydrodiag")]
            if at:
                found.append(words[at[0] + 1:])
    for page in (README, *DOCS):
        for span in re.findall(r"`hydrodiag ([^`]+)`", page.read_text(encoding="utf-8")):
            found.append(shlex.split(span.replace("[", " ").replace("]", " ")))
    return found


def test_every_hydrodiag_command_of_the_docs_exists_with_its_options() -> None:
    """Each ``hydrodiag …`` command of the README and the docs names a command the CLI has, and every
    ``--option`` it writes is one of that command's (a renamed option or command leaves
    the README wrong without a word otherwise)."""
    import typer

    from app.cli import cli

    root = typer.main.get_command(cli)  # typer's own click: groups known by their commands
    lines = _hydrodiag_lines()
    assert len(lines) >= 50, len(lines)
    for words in lines:
        command: Any = root
        path = []
        for word in words:
            if word in getattr(command, "commands", {}):
                command = command.commands[word]
                path.append(word)
            else:
                break
        assert not hasattr(command, "commands"), f"no command in {words}"
        known = {name for p in command.params for name in (*p.opts, *p.secondary_opts)}
        used = {w.split("=", 1)[0] for w in words if w.startswith("--")}
        assert used <= known, (path, sorted(used - known))


# --- docs/real-data.md's Python example -------------------------------------------------------


def test_the_real_data_example_runs_and_its_estimates_order_the_labels() -> None:
    """docs/real-data.md's Python block, as written, on ZeMA cycles 201-500: the leak size,
    the switching lag and the pre-charge it computes without the labels order them (the
    labels only score: Spearman 0.93 / −0.97 / 0.84 on these cycles when written; the
    page's figures over all 2205 cycles are 0.897 / 0.923 / 0.951)."""
    from scipy.stats import spearmanr

    from diagnostics.real.zema import zema_root

    if not (zema_root() / "profile.txt").exists():
        pytest.skip(f"the shared real data are not here: {zema_root()}")
    page = (README.parent / "docs" / "real-data.md").read_text(encoding="utf-8")
    found = re.search(r"^( *)```python\n(.*?)^ *```", page, flags=re.S | re.M)
    assert found, "docs/real-data.md has no Python example any more"
    code = textwrap.dedent(found.group(2))
    namespace: dict[str, Any] = {}
    exec(compile(code, "docs/real-data.md", "exec"), namespace)  # the page's own code
    labels = namespace["labels"]
    assert spearmanr(namespace["leak"].size, labels.leakage).statistic > 0.85
    assert spearmanr(namespace["lag"], labels.valve).statistic < -0.9  # later when worn
    p0 = namespace["p0_20"]
    assert np.isfinite(p0).sum() >= 0.5 * p0.size
    assert spearmanr(p0, labels.accumulator, nan_policy="omit").statistic > 0.75


# --- the settings -------------------------------------------------------------------------------


def test_every_setting_is_documented() -> None:
    """Each setting of :class:`app.settings.Settings` is named, as the environment variable
    an operator sets, in the README or the docs (``HYDRODIAG_ACCESS_LOG`` and
    ``HYDRODIAG_LOG_LEVEL`` were read but named nowhere)."""
    from app.settings import Settings

    text = "\n".join(p.read_text(encoding="utf-8") for p in (README, *DOCS))
    missing = [f"HYDRODIAG_{name.upper()}" for name in Settings.model_fields
               if f"HYDRODIAG_{name.upper()}" not in text]
    assert not missing, missing


def test_the_defaults_the_docs_state_are_the_settings_defaults() -> None:
    """Where the README or the docs write a setting with a number after it
    (```HYDRODIAG_JOB_WORKERS` (2)``, ``(8 MiB``, ``(10 s``, ``(30 d``), that number is the
    setting's default."""
    from app.settings import Settings

    scale = {"MiB": 2.0**20, "s": 1.0, "d": 1.0, "": 1.0}
    text = "\n".join(p.read_text(encoding="utf-8") for p in (README, *DOCS))
    defaults = {name: field.get_default(call_default_factory=True)
                for name, field in Settings.model_fields.items()}
    checked = 0
    for name, number, unit in re.findall(
            r"`HYDRODIAG_([A-Z_0-9]+)`,? \((\d[\d,]*(?:\.\d+)?)(?: (MiB|s|d)\b)?", text):
        key = name.lower()
        if key not in defaults:
            continue  # a study's variable (HYDRODIAG_SEEDS), not a setting
        assert float(number.replace(",", "")) * scale[unit] == pytest.approx(
            float(defaults[key])), (name, number, unit, defaults[key])
        checked += 1
    assert checked >= 12, checked
