"""The console in a real Chromium (Debian's ``chromium`` driven by Playwright).

Every page is opened against a live service on a fresh store: no console error, no failed
request, every plot drawn with data; a diagnosis is submitted through the form and found
in the history and the trends; each page is screenshotted (into ``HYDRODIAG_SCREENSHOTS``
when set, as ``make screenshots`` does, else into the test's temporary folder).
Skipped, with the reason, where Chromium or Playwright is missing.
"""

from __future__ import annotations

import os
import shutil
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.app.conftest import simulated_record
from tests.app.jobs_support import reports_until_cancelled
from tests.app.live import LiveServer

CHROMIUM = os.environ.get("HYDRODIAG_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage"]

try:
    from playwright.sync_api import Page, sync_playwright
except ImportError:  # pragma: no cover - the dev extras install it
    sync_playwright = None

pytestmark = [
    pytest.mark.skipif(sync_playwright is None, reason="playwright is not installed "
                       "(pip install -e '.[dev]')"),
    pytest.mark.skipif(not Path(CHROMIUM).exists(), reason=f"no Chromium at {CHROMIUM} "
                       "(apt-get install -y chromium; .ci/run does it)"),
]

#: Page → (file name of its screenshot, least number of plots it draws).
PAGES = {
    "/console/rigs": ("rigs", 0),
    "/console/rigs/1": ("rig", 1),
    "/console/diagnose": ("diagnose", 0),
    "/console/history": ("history", 0),
    "/console/trends?rig=1": ("trends", 2),
    "/console/simulate?run=true&fault=worn_spool&load=2100": ("simulate", 4),
    "/console/pumps": ("pumps", 2),
    "/console/series?rig=1": ("series", 0),
    "/console/series/1": ("series-record", 3),
    "/console/jobs": ("jobs", 0),
}


@pytest.fixture(scope="module")
def shots(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Where the screenshots go."""
    target = os.environ.get("HYDRODIAG_SCREENSHOTS")
    folder = Path(target) if target else tmp_path_factory.mktemp("screenshots")
    folder.mkdir(parents=True, exist_ok=True)
    return folder


@pytest.fixture(scope="module")
def page(console_server: LiveServer) -> Iterator[Any]:
    """A logged-in Chromium page recording console errors and failed requests.

    Playwright starts the browser on a fresh temporary profile of its own.
    """
    assert sync_playwright is not None
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=FLAGS)
        context = browser.new_context(viewport={"width": 1200, "height": 900})
        tab = context.new_page()
        problems: list[str] = []
        tab.on("console", lambda m: problems.append(f"console {m.type}: {m.text}")
               if m.type in ("error", "warning") else None)
        tab.on("pageerror", lambda e: problems.append(f"page error: {e}"))
        tab.on("requestfailed", lambda r: problems.append(f"failed: {r.url} {r.failure}"))
        tab.on("response", lambda r: problems.append(f"HTTP {r.status}: {r.url}")
               if r.status >= 400 else None)
        tab.problems = problems  # type: ignore[attr-defined]
        tab.goto(f"{console_server.base_url}/console/rigs")
        assert "/console/login" in tab.url  # not logged in yet
        tab.fill("#api_key", console_server.key)
        tab.click("button[type=submit]")
        tab.wait_for_url("**/console/rigs")
        yield tab
        context.close()
        browser.close()


def _plots(tab: Page) -> list[int]:
    return [int(n) for n in tab.eval_on_selector_all(
        "svg.hd-plot", "els => els.map(e => e.getAttribute('data-points'))")]


def _visible_plots(tab: Page) -> int:
    """Plots the browser actually laid out with a size (drawn, not just present)."""
    return int(tab.eval_on_selector_all(
        "svg.hd-plot", "els => els.filter(e => { const r = e.getBoundingClientRect(); "
        "return r.width > 100 && r.height > 50; }).length"))


def test_every_page_opens_cleanly_with_its_plots(console_server: LiveServer, page: Any,
                                                 shots: Path) -> None:
    for url, (name, least) in PAGES.items():
        page.problems.clear()
        response = page.goto(f"{console_server.base_url}{url}")
        assert response is not None and response.status == 200, url
        page.wait_for_load_state("networkidle")
        points = _plots(page)
        assert len(points) >= least and all(n > 0 for n in points), (url, points)
        assert _visible_plots(page) >= least, url
        # the stylesheet applied: the header bar is dark, not the browser's default
        assert page.eval_on_selector("header.top", "e => getComputedStyle(e).backgroundColor") \
            == "rgb(29, 36, 48)", url
        assert page.problems == [], (url, page.problems)
        page.screenshot(path=str(shots / f"console-{name}.png"), full_page=True)


def test_a_diagnosis_from_the_form_reaches_history_and_trends(
        console_server: LiveServer, page: Any, shots: Path) -> None:
    record = simulated_record(console_server, {"valve.cv": 50e-6},
                              measured_at="2026-03-06T08:00:00Z")
    yaml_text = "\n".join(f"{k}: {v}" for k, v in record.items() if k != "condition")
    yaml_text += (f"\ncondition: {{oil_temperature: {record['condition']['oil_temperature']}, "
                  f"load_force: {record['condition']['load_force']}}}")
    trend_points_before = _trend_points(console_server, page)
    page.problems.clear()
    page.goto(f"{console_server.base_url}/console/diagnose")
    page.fill("#document", yaml_text)
    page.click("#diagnose-form button[type=submit]")
    page.wait_for_url("**/console/diagnoses/*")
    diagnosis_id = page.url.rsplit("/", 1)[1]
    assert page.inner_text("h1").startswith(f"Diagnosis {diagnosis_id}: valve")
    assert len(_plots(page)) >= 3 and min(_plots(page)) > 0
    assert page.problems == [], page.problems
    page.screenshot(path=str(shots / "console-diagnosis.png"), full_page=True)
    page.goto(f"{console_server.base_url}/console/history")
    page.select_option("#rig", "1")  # the filter form, its time fields left blank
    page.click("form.filters button[type=submit]")
    page.wait_for_url("**/console/history?rig=1*")
    page.click(f"a[href='/console/diagnoses/{diagnosis_id}']")
    page.wait_for_url(f"**/console/diagnoses/{diagnosis_id}")
    assert _trend_points(console_server, page) == trend_points_before + 1
    page.screenshot(path=str(shots / "console-trends.png"), full_page=True)
    assert page.problems == [], page.problems


def test_charts_keep_their_size_and_a_narrow_window_does_not_scroll_sideways(
        console_server: LiveServer, page: Any, shots: Path) -> None:
    """At 1280 px two charts side by side shrank to 519 px (tick text ~7 px); at 800 px
    the diagnosis and measured-series tables were 854-922 px wide and the page scrolled
    sideways (a console pass)."""
    for width, url in ((1280, "/console/series/{first}"), (800, "/console/diagnoses/1"),
                       (800, "/console/series")):
        page.set_viewport_size({"width": width, "height": 900})
        first = console_server.series[0]  # type: ignore[attr-defined]
        page.goto(f"{console_server.base_url}{url.format(first=first)}?rig=1"
                  if url == "/console/series" else f"{console_server.base_url}"
                  f"{url.format(first=first)}")
        page.wait_for_load_state("networkidle")
        wide = page.evaluate("document.scrollingElement.scrollWidth")
        assert wide <= width, (url, width, wide)
        if width == 1280:
            sizes = page.eval_on_selector_all(
                ".grid svg.hd-plot", "els => els.map(e => e.getBoundingClientRect().width)")
            assert sizes and min(sizes) >= 650, sizes
    page.screenshot(path=str(shots / "console-narrow.png"), full_page=True)
    page.set_viewport_size({"width": 1200, "height": 900})


def _trend_points(server: LiveServer, tab: Page) -> int:
    """Diagnoses in the valve's trend, as its section states."""
    tab.goto(f"{server.base_url}/console/trends?rig=1")
    heading = tab.inner_text("section.trend:has(code:text-is('cv')) h2")
    return int(heading.rsplit(",", 1)[1].split()[0])


def test_a_bad_record_shows_the_field_on_the_page(console_server: LiveServer, page: Any) -> None:
    before = console_server.row_counts()
    page.problems.clear()
    page.goto(f"{console_server.base_url}/console/diagnose")
    page.fill("#document", "rig_id: 1\ncondition: {oil_temperature: 40, load_force: 2100}\n"
                           "p1: -5.0e5")
    page.click("#diagnose-form button[type=submit]")
    error = page.locator("div.error")
    assert error.get_attribute("data-field") == "record.p1"
    assert "Nothing was stored" in error.inner_text()
    assert console_server.row_counts() == before
    # the one expected problem: the form's answer is a 422 page
    assert [p for p in page.problems if "422" not in p] == []
    assert any("HTTP 422" in p for p in page.problems)


def test_pumps_page_draws_measured_against_model(console_server: LiveServer, page: Any,
                                                 shots: Path) -> None:
    sets = console_server.client.get("/pump-sets").json()["items"]
    chosen = next(s for s in sets if "points_q_held_out" in s["quantities"])
    n = len(chosen["quantities"]["points_q"]["value"])
    page.problems.clear()
    page.goto(f"{console_server.base_url}/console/pumps?set_id={chosen['id']}")
    page.wait_for_load_state("networkidle")
    drawn = page.eval_on_selector_all(
        "svg.hd-plot", "els => els.map(e => { const r = e.getBoundingClientRect(); return "
        "[e.getAttribute('aria-label'), e.getAttribute('data-points'), r.width, r.height,"
        " e.querySelectorAll('circle, path, polyline').length]; })")
    by_title = {title.split(" (")[0]: (int(pts), w, h, marks)
                for title, pts, w, h, marks in drawn}
    for title in ("Flow: measured and model", "Torque: measured and model",
                  "Held-out flow residual, measured − model"):
        pts, w, h, marks = by_title[title]
        # laid out with a size, and with a mark per measured point at least
        assert pts >= n and w > 100 and h > 50 and marks >= 1, (title, pts, w, h, marks)
    assert page.problems == [], page.problems
    page.screenshot(path=str(shots / "console-pumps-check.png"), full_page=True)


def test_ticked_records_are_checked_and_the_page_follows_the_job(
        console_server: LiveServer, page: Any, shots: Path) -> None:
    first = console_server.series[0]  # type: ignore[attr-defined]
    page.problems.clear()
    page.goto(f"{console_server.base_url}/console/series?rig=1")
    page.check(f"#series-{first}")
    page.click("#check-form button[type=submit]")
    page.wait_for_url("**/console/jobs/*")
    # the page reloads itself (a meta refresh: the console has no script) until done
    page.wait_for_selector("#verdict", timeout=300_000)
    assert page.inner_text("#job-status") == "succeeded"
    assert page.inner_text("#verdict").startswith("Verdict: ")
    page.screenshot(path=str(shots / "console-job.png"), full_page=True)
    page.click("#report")
    page.wait_for_url("**/report")
    assert page.inner_text("h1") == "hydrodiag discrepancy report"
    # styled by the console's sheet (it rendered in the browser's default serif)
    assert "Times" not in page.evaluate("getComputedStyle(document.body).fontFamily")
    page.screenshot(path=str(shots / "console-report.png"), full_page=True)
    assert page.problems == [], page.problems


def test_a_stored_cycle_is_diagnosed_from_its_page(console_server: LiveServer, page: Any,
                                                   shots: Path) -> None:
    """The series page reads the cycle as a record; its link fills the diagnose form, whose
    submission diagnoses and stores it like a typed record."""
    second = console_server.series[1]  # type: ignore[attr-defined]
    page.problems.clear()
    page.goto(f"{console_server.base_url}/console/series/{second}")
    assert "speed_work" in page.inner_text("#record-readings")
    page.click("#diagnose-record")
    page.wait_for_url(f"**/console/diagnose?series={second}")
    assert '"speed_return"' in page.input_value("#document")
    page.screenshot(path=str(shots / "console-diagnose-cycle.png"), full_page=True)
    page.click("#diagnose-form button[type=submit]")
    page.wait_for_url("**/console/diagnoses/*")
    assert page.inner_text("h1").split(": ", 1)[1].startswith("valve")
    assert f"read from stored series {second}" in page.inner_text("main")
    page.click("#source-series")  # the diagnosis links back to the cycle it was read from
    page.wait_for_url(f"**/console/series/{second}")
    assert page.problems == [], page.problems


def test_a_running_job_is_cancelled_with_its_button(console_server: LiveServer, page: Any,
                                                     shots: Path) -> None:
    started = threading.Event()
    job = console_server.app.state.jobs.submit("endless", {},
                                             reports_until_cancelled(started, 120.0))
    assert started.wait(60.0)
    page.problems.clear()
    page.goto(f"{console_server.base_url}/console/jobs/{job.id}")
    assert page.inner_text("#job-status") == "running"
    page.screenshot(path=str(shots / "console-job-running.png"), full_page=True)
    # not reloading by itself: a keyboard reaches the button (an accessibility pass)
    assert page.query_selector('meta[http-equiv="refresh"]') is None
    page.click("#cancel-job")
    # asked to stop, the page follows the job until it stops at its next progress report
    page.wait_for_selector("#job-cancelled", timeout=60_000)
    assert page.inner_text("#job-status") == "cancelled"
    assert page.query_selector("#cancel-job") is None
    assert page.problems == [], page.problems


def test_a_loggers_cycle_is_imported_from_the_measured_page(console_server: LiveServer,
                                                           page: Any, shots: Path,
                                                           tmp_path: Path) -> None:
    """The import form of the measured page: a cycle as a logger writes it (own names,
    ';' and decimal commas, the spool command), its column map typed in, lands on the
    record's page, read as a record."""
    exported = console_server.client.get(f"/series/{console_server.series[1]}").json()  # type: ignore[attr-defined]
    cond = exported["condition"]
    rows = ["time;spool;pos;PA;PB;oil;force"] + [
        f"{t * 1e3:.6g};{1 if ph == 'working' else -1};{x * 1e3:.9g};{p1 / 1e5:.9g};"
        f"{p2 / 1e5:.9g};{cond['oil_temperature']:.4g};{cond['load']:.6g}".replace(".", ",")
        for t, ph, x, p1, p2 in zip(exported["t"], exported["phase"],
                                    exported["channels"]["x"], exported["channels"]["P1"],
                                    exported["channels"]["P2"], strict=True)]
    logged = tmp_path / "logger-run.csv"
    logged.write_text("\n".join(rows) + "\n")
    page.problems.clear()
    page.goto(f"{console_server.base_url}/console/series?rig=1")
    page.click("#import summary")
    page.set_input_files("#import-file", str(logged))
    page.fill("#import-map", '{"time": ["t", "ms"], "spool": ["phase", "-"], '
                             '"pos": ["x", "mm"], "PA": ["P1", "bar"], "PB": ["P2", "bar"], '
                             '"oil": ["oil_temperature", "degC"], "force": ["load", "kN", '
                             '0.001, 0]}')
    page.fill("#import-start", "2026-11-20T08:00:00Z")
    page.screenshot(path=str(shots / "console-series-import.png"), full_page=True)
    page.click("#import-form button[type=submit]")
    page.wait_for_url("**/console/series/*")
    assert "logger-run.csv" in page.inner_text("h1")
    assert "2026-11-20 08:00:00" in page.inner_text("main")
    assert "p1" in page.inner_text("#record-readings")  # its pressures read as a record
    assert page.problems == [], page.problems


def test_the_pump_leak_page_draws_in_chromium(console_server: LiveServer, page: Any,
                                              shots: Path) -> None:
    """A rig without a cylinder: its measured page links to its pump's leak, which draws
    one chart of every cycle, laid out, without a console error."""
    from tests.app.console.test_console_series import zema_cycles

    rig_id, ids, _ = zema_cycles(console_server)
    page.problems.clear()
    page.goto(f"{console_server.base_url}/console/series?rig={rig_id}")
    page.click("#pump-leak-link")
    page.wait_for_url(f"**/console/series/pump-leak?rig={rig_id}")
    page.wait_for_load_state("networkidle")
    (points,) = _plots(page)
    assert points >= len(ids) and _visible_plots(page) == 1
    assert "leaking" in page.inner_text("#leak-summary")
    assert page.locator("#leak-segments tbody tr").count() >= 1
    assert page.problems == [], page.problems
    page.screenshot(path=str(shots / "console-pump-leak.png"), full_page=True)
