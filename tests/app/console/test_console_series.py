"""The console's measured-series pages: the stored records, one plotted (a cycle read as a
record that fills the diagnose form), and the discrepancy workflow started on ticked
records and followed to its report."""

from __future__ import annotations

import html
import json
import re
import threading
import time

import httpx
import numpy as np
import pytest
from markupsafe import escape

from app.console.web import SECURITY_HEADERS
from app.security import Scope
from app.services.keys import create_api_key
from tests.app.console.test_console_pages import error_box, plot_points
from tests.app.jobs_support import reports_until_cancelled
from tests.app.live import LiveServer


def test_the_rigs_records_are_listed_and_plotted_by_unit(console_server: LiveServer,
                                                        browser_client: httpx.Client) -> None:
    ids = console_server.series  # type: ignore[attr-defined]
    listed = browser_client.get("/console/series?rig=1")
    assert listed.status_code == 200
    for i in ids:
        assert f'name="series" value="{i}"' in listed.text
    assert "P1 [Pa]" in listed.text and "load 2100" in listed.text
    one = browser_client.get(f"/console/series/{ids[0]}")
    assert one.status_code == 200
    # pressures [bar], flows [l/min], speed, position, … each unit on its own axes
    assert "pressure [bar]" in one.text and "flow [l/min]" in one.text
    units = console_server.client.get(f"/series/{ids[0]}").json()["units"]
    points = plot_points(one.text)
    assert len(points) == len(set(units.values())) >= 3 and all(n > 0 for n in points)
    assert "return, working" in one.text          # the phases the workflow needs were kept
    assert browser_client.get("/console/series/99999").status_code == 404
    assert 'href="/console/series?rig=1"' in browser_client.get("/console/rigs/1").text


def test_ticked_records_are_checked_and_the_report_is_shown(console_server: LiveServer,
                                                           browser_client: httpx.Client) -> None:
    ids = console_server.series  # type: ignore[attr-defined]
    versions = console_server.row_counts()["rig_versions"]
    started = browser_client.post("/console/series/check",
                                  data={"rig": "1", "series": [str(i) for i in ids]})
    assert started.status_code == 303, started.text
    followed = started.headers["location"]       # a started check's page follows it
    assert re.fullmatch(r"/console/jobs/[0-9a-f-]{36}\?follow=true", followed)
    job_url = followed.removesuffix("?follow=true")
    deadline = time.monotonic() + 300.0
    while True:
        page = browser_client.get(followed)
        assert page.status_code == 200
        if 'http-equiv="refresh"' not in page.text:
            break
        assert time.monotonic() < deadline, page.text
        time.sleep(0.5)
    assert '<dd id="job-status">succeeded' in page.text, page.text
    # the worn spool (cv 60 µm against 34 µm) is the rig's own clearance moved: base drift
    assert "Verdict: base drift" in page.text and "valve.cv" in page.text
    # the re-fitted parameters as a table: the spool clearance up by 76 % (60/34 µm)
    row = re.search(r"<code>valve.cv</code>.*?</tr>", page.text, re.S)
    assert row is not None and "+76." in row.group(0)
    # in µm, as an engineer reads a clearance (was "3.4e-05" and "5.99e-05" [m])
    cells = re.findall(r'<td class="num">([^<]*)</td>', row.group(0))
    assert "[µm]" in row.group(0) and float(cells[0]) == 34.0
    assert 58.0 < float(cells[1]) < 62.0
    report = browser_client.get(f"{job_url}/report")
    assert report.status_code == 200 and "hydrodiag discrepancy report" in report.text
    assert "valve.cv [µm]" in report.text
    for name, value in SECURITY_HEADERS.items():
        assert report.headers[name] == value
    assert "<script" not in report.text and "<style" not in report.text
    # the console's style sheet (its policy allows it) and a way back to the job
    assert "href='/console/static/console.css'" in report.text
    assert f"href='{job_url}'" in report.text
    assert console_server.row_counts()["rig_versions"] == versions   # not asked to store
    listed = browser_client.get("/console/series?rig=1")
    assert job_url in listed.text                  # the rig's recent checks


def test_a_check_without_records_or_with_a_read_key_names_the_field(
        console_server: LiveServer, browser_client: httpx.Client) -> None:
    before = console_server.row_counts()
    empty = browser_client.post("/console/series/check", data={"rig": "1"})
    assert empty.status_code == 422 and error_box(empty.text)[0] == "series_ids"
    many = browser_client.post("/console/series/check",
                               data={"rig": "1", "series": [str(i) for i in range(1, 202)]})
    assert many.status_code == 422 and error_box(many.text)[0] == "series_ids"
    with console_server.session() as session:
        _, plaintext = create_api_key(session, "console-series-read", Scope.READ)
    first = str(console_server.series[0])  # type: ignore[attr-defined]
    with httpx.Client(base_url=console_server.base_url, timeout=60.0) as client:
        client.post("/console/login", data={"api_key": plaintext, "next": ""})
        assert client.get("/console/series?rig=1").status_code == 200
        refused = client.post("/console/series/check", data={"rig": "1", "series": [first]})
    assert refused.status_code == 403 and error_box(refused.text)[0] == "api_key"
    after = console_server.row_counts()
    assert {k: v for k, v in after.items() if k != "api_keys"} == {
        k: v for k, v in before.items() if k != "api_keys"}
    # the fields hold what the form accepts (a 250-character name replaced the page), and
    # a reload of the post's address returns to the form (it read "import" as an id)
    page = browser_client.get("/console/series?rig=1").text
    assert 'name="name" maxlength="200"' in page and 'maxlength="20000"' in page
    for path in ("/console/series/import", "/console/series/check"):
        back = browser_client.get(path)
        assert back.status_code == 303 and back.headers["location"] == "/console/series"


def test_a_job_is_cancelled_from_its_page(console_server: LiveServer,
                                          browser_client: httpx.Client) -> None:
    started = threading.Event()
    job = console_server.app.state.jobs.submit("endless", {}, reports_until_cancelled(started))
    assert started.wait(60.0)
    url = f"/console/jobs/{job.id}"
    running = browser_client.get(url)
    # it reloads itself only when followed: each reload sent a keyboard's focus and a
    # screen reader back to the top, and the cancel button was never reached (an
    # accessibility pass); the button comes first in the page's main part
    assert 'id="cancel-job"' in running.text and 'http-equiv="refresh"' not in running.text
    assert running.text.index('id="cancel-job"') < running.text.index('id="job-status"')
    assert f'href="{url}?follow=true" id="follow"' in running.text
    followed = browser_client.get(f"{url}?follow=true")
    assert '<meta http-equiv="refresh" content="5">' in followed.text
    assert 'id="stop-following"' in followed.text
    asked = browser_client.post(f"{url}/cancel")   # then followed until it stops
    assert asked.status_code == 303 and asked.headers["location"] == f"{url}?follow=true"
    deadline = time.monotonic() + 60.0
    while 'id="job-cancelled"' not in (shown := browser_client.get(f"{url}?follow=true")).text:
        assert time.monotonic() < deadline, shown.text
        time.sleep(0.1)
    assert 'http-equiv="refresh"' not in shown.text      # done: nothing left to follow
    assert '<dd id="job-status">cancelled' in shown.text and 'id="job-cancelled"' in shown.text
    assert 'id="cancel-job"' not in shown.text
    assert console_server.client.get(f"/jobs/{job.id}").json()["status"] == "cancelled"
    # a job that is over cannot be cancelled: the page says so, with the field
    again = browser_client.post(f"{url}/cancel")
    assert again.status_code == 303  # a cancelled job: asking again changes nothing
    done = console_server.app.state.jobs.submit("short", {}, lambda params, progress: {})
    while console_server.client.get(f"/jobs/{done.id}").json()["status"] != "succeeded":
        assert time.monotonic() < deadline
        time.sleep(0.05)
    refused = browser_client.post(f"/console/jobs/{done.id}/cancel")
    assert refused.status_code == 409 and error_box(refused.text)[0] == "job_id"


def test_a_read_key_cannot_cancel_a_job(console_server: LiveServer) -> None:
    started = threading.Event()
    job = console_server.app.state.jobs.submit("endless", {}, reports_until_cancelled(started))
    assert started.wait(60.0)
    with console_server.session() as session:
        _, plaintext = create_api_key(session, "console-cancel-read", Scope.READ)
    with httpx.Client(base_url=console_server.base_url, timeout=60.0) as client:
        client.post("/console/login", data={"api_key": plaintext, "next": ""})
        refused = client.post(f"/console/jobs/{job.id}/cancel")
    assert refused.status_code == 403 and error_box(refused.text)[0] == "api_key"
    body = console_server.client.get(f"/jobs/{job.id}").json()
    assert (body["status"], body["cancel_requested_at"]) == ("running", None)
    assert console_server.client.post(f"/jobs/{job.id}/cancel").status_code == 202


def test_a_cycle_is_shown_as_a_record_and_fills_the_diagnose_form(
        console_server: LiveServer, browser_client: httpx.Client) -> None:
    first = console_server.series[0]  # type: ignore[attr-defined]
    one = browser_client.get(f"/console/series/{first}")
    assert 'id="record-readings"' in one.text and f'/console/diagnose?series={first}' in one.text
    api = console_server.client.get(f"/series/{first}/record").json()["record"]
    assert "<td>speed_work</td>" in one.text and "<td>m/s</td>" in one.text
    # pressures in bar, flows in l/min, as the charts beside them (they read 1.533e+06 Pa
    # and 0.00046412 m³/s: a discrepancy pass)
    p1 = re.search(r"<td>p1</td><td>([^<]+)</td><td>([^<]+)</td>", one.text)
    assert p1 is not None and p1.group(2) == "bar"
    assert float(p1.group(1)) == pytest.approx(api["p1"] / 1e5, rel=1e-4)
    flow = re.search(r"<td>flow_B</td><td>([^<]+)</td><td>([^<]+)</td>", one.text)
    assert flow is not None and flow.group(2) == "l/min"
    assert float(flow.group(1)) == pytest.approx(api["flow_B"] * 6e4, rel=1e-4)
    form = browser_client.get(f"/console/diagnose?series={first}")
    assert form.status_code == 200
    filled = re.search(r'<textarea id="document"[^>]*>(.*?)</textarea>', form.text, re.S)
    assert filled is not None
    assert json.loads(html.unescape(filled.group(1))) == api
    missing = browser_client.get("/console/diagnose?series=99999")
    assert missing.status_code == 404 and error_box(missing.text)[0] == "series"


def test_a_series_that_is_no_cycle_says_why(console_server: LiveServer,
                                           browser_client: httpx.Client) -> None:
    r = console_server.client.post("/rigs/1/series", data={"name": "flat"},
                                   files={"file": ("flat.csv", b"t [s],P_pump [bar]\n0,1\n1,2\n",
                                                   "text/csv")},
                                   headers=console_server.auth)
    assert r.status_code == 201, r.text
    page = browser_client.get(f"/console/series/{r.json()['items'][0]['id']}")
    assert page.status_code == 200 and 'id="record-unread"' in page.text
    assert "no piston position" in page.text


def _new_rig(server: LiveServer, name: str) -> int:
    from sim.rigs import reference_rig_document

    made = server.client.post("/rigs", json={"document": reference_rig_document() | {
        "name": name}})
    assert made.status_code == 201, made.text
    return int(made.json()["id"])


def test_a_loggers_file_is_imported_from_the_page(console_server: LiveServer,
                                                 browser_client: httpx.Client) -> None:
    """The list's import form: a semicolon file with decimal commas and a 4-20 mA pressure
    through a column map, its clock time given; one record goes to its page, stored in SI
    with its time; two records to the rig's list."""
    rig = _new_rig(console_server, "console-import")
    content = b"n;PT1 signal;note\n0;4,0;a\n1;12,0;\n2;20,0;b\n"
    cmap = json.dumps({"n": ["t", "s", 0.5, 0], "PT1 signal": ["P1", "bar", 15.625, -62.5],
                       "note": ["skip", "-"]})
    done = browser_client.post("/console/series/import", data={
        "rig": str(rig), "column_map": cmap, "started_at": "2026-11-20T08:00:00Z"},
        files={"file": ("run 7.csv", content, "text/csv")})
    assert done.status_code == 303, done.text
    series_id = int(done.headers["location"].rsplit("/", 1)[1])
    stored = console_server.client.get(f"/series/{series_id}").json()
    assert stored["rig_id"] == rig and stored["name"] == "run-7.csv"
    assert stored["channels"]["P1"] == [0.0, 125e5, 250e5] and stored["t"] == [0.0, 0.5, 1.0]
    assert stored["measured_at"] == "2026-11-20T08:00:00Z"
    page = browser_client.get(done.headers["location"])
    assert "2026-11-20 08:00:00" in page.text
    two = browser_client.post("/console/series/import", data={"rig": str(rig), "name": "two"},
                              files={"file": ("two.csv", b"record,t [s],P1 [bar]\na,0,1\na,1,2\n"
                                              b"b,0,3\nb,1,4\n", "text/csv")})
    assert two.status_code == 303 and two.headers["location"] == f"/console/series?rig={rig}"
    listed = browser_client.get(two.headers["location"]).text
    assert listed.count('name="series" value=') == 3
    named = browser_client.post("/console/series/import", data={
        "rig": str(rig), "time_in_name": "%Y%m%d-%H%M%S", "zone": "+01:00"},
        files={"file": ("log_20261120-093000.csv", b"t [s],P1 [bar]\n2,1.5\n3,2.5\n",
                        "text/csv")})
    assert named.status_code == 303, named.text
    stored = console_server.client.get(named.headers["location"].replace("/console", "")).json()
    assert stored["measured_at"] == "2026-11-20T08:30:02Z"


def test_a_bad_import_names_the_field_and_keeps_what_was_entered(
        console_server: LiveServer, browser_client: httpx.Client) -> None:
    rig = _new_rig(console_server, "console-import-bad")
    before = console_server.row_counts()
    good = b"t [s],P1 [bar]\n0,1\n1,2\n"
    cases = [
        ({"column_map": '{"P1": ["P1", "bar", 0, 0]}'}, good, "column_map.P1"),
        ({"column_map": '{"PT": ["P1", "bar", "x", 0]}'}, good, "column_map.PT"),
        ({"started_at": "2026-11-20T08:00:00"}, good, "started_at"),
        ({"sample_rate": "fast"}, good, "sample_rate"),
        ({"time_in_name": "%Y%m%d-%H%M%S", "zone": "Z"}, good, "time_in_name"),
        ({"zone": "+01:00"}, good, "zone"),
        ({"name": "a name with spaces"}, good, "name"),
        ({}, b"t [s],P1 [psi]\n0,1\n1,2\n", "file.P1"),
        ({}, None, "file"),
    ]
    for form, content, field in cases:
        files = None if content is None else {"file": ("f.csv", content, "text/csv")}
        refused = browser_client.post("/console/series/import", data={"rig": str(rig)} | form,
                                      files=files)
        assert refused.status_code == 422, (form, refused.text)
        assert error_box(refused.text)[0].startswith(field), (form, error_box(refused.text))
        for value in form.values():
            assert str(escape(value)) in refused.text  # as Jinja writes it into the form
    with console_server.session() as session:
        _, plaintext = create_api_key(session, "console-import-read", Scope.READ)
    with httpx.Client(base_url=console_server.base_url, timeout=60.0) as client:
        client.post("/console/login", data={"api_key": plaintext, "next": ""})
        refused = client.post("/console/series/import", data={"rig": str(rig)},
                              files={"file": ("f.csv", good, "text/csv")})
    assert refused.status_code == 403 and error_box(refused.text)[0] == "api_key"
    after = console_server.row_counts()
    assert {k: v for k, v in after.items() if k != "api_keys"} == {
        k: v for k, v in before.items() if k != "api_keys"}


def test_a_diagnosis_of_a_deleted_series_says_so(console_server: LiveServer,
                                                 browser_client: httpx.Client) -> None:
    """Its link went to the series' id, which after the delete pointed at another cycle
    (ids were reused) and now would be a 404: the page says the series was deleted."""
    export = console_server.client.post("/simulate", json={
        "rig_id": 1, "fault": "worn_spool", "condition": {"load": 4200},
        "sample_rate": 200, "timeseries": "csv"})
    assert export.status_code == 200, export.text
    stored = console_server.client.post(
        "/rigs/1/series", data={"name": "to-delete"}, headers=console_server.auth,
        files={"file": ("cycle.csv", export.content, "text/csv")}).json()["items"][0]
    record = console_server.client.get(f"/series/{stored['id']}/record").json()["record"]
    answer = console_server.client.post("/diagnose", json={"record": record},
                                        headers=console_server.auth).json()["diagnoses"][0]
    page = browser_client.get(f"/console/diagnoses/{answer['id']}").text
    assert f'href="/console/series/{stored["id"]}"' in page
    assert console_server.client.delete(f"/series/{stored['id']}",
                                        headers=console_server.auth).status_code == 204
    page = browser_client.get(f"/console/diagnoses/{answer['id']}").text
    assert f'href="/console/series/{stored["id"]}"' not in page
    assert f"read from series {stored['id']}, since deleted" in page


def test_a_cycle_without_its_temperature_is_read_with_the_one_stated_on_its_page(
        console_server: LiveServer, browser_client: httpx.Client) -> None:
    """A logger's file without an oil-temperature column could be imported but never read
    as a record from the console: no field took the condition.  The series page states it,
    reads the record with it, and its link fills the diagnose form with the same record."""
    import io

    import pandas as pd

    export = console_server.client.post("/simulate", json={
        "rig_id": 1, "fault": "worn_spool", "condition": {"load": 2100.0},
        "sample_rate": 500, "timeseries": "csv"}).text
    frame = pd.read_csv(io.StringIO(export), comment="#").drop(
        columns=["oil_temperature [degC]"])
    stored = console_server.client.post("/rigs/1/series", data={"name": "no-temperature"},
                                        files={"file": ("c.csv", frame.to_csv(index=False)
                                                        .encode(), "text/csv")})
    assert stored.status_code == 201, stored.text
    series = stored.json()["items"][0]["id"]
    bare = browser_client.get(f"/console/series/{series}")
    assert 'id="record-unread"' in bare.text and 'id="state-condition"' in bare.text
    # a condition typed wrong is an alert tied to its field (it was a grey note: an
    # accessibility pass); a series that lacks one is not
    assert '<p class="muted" id="record-unread">' in bare.text
    typo = browser_client.get(f"/console/series/{series}?oil_temperature=warm")
    assert '<p class="error" role="alert" id="record-unread">' in typo.text
    assert re.search(r'id="stated-oil_temperature"[^>]*aria-invalid="true" '
                     r'aria-describedby="record-unread"', typo.text)
    stated = browser_client.get(f"/console/series/{series}?oil_temperature=40")
    assert 'id="record-readings"' in stated.text
    assert f"/console/diagnose?series={series}&amp;oil_temperature=40" in stated.text
    api = console_server.client.get(f"/series/{series}/record",
                                    params={"oil_temperature": 40}).json()["record"]
    form = browser_client.get(f"/console/diagnose?series={series}&oil_temperature=40")
    filled = re.search(r'<textarea id="document"[^>]*>(.*?)</textarea>', form.text, re.S)
    assert filled is not None and json.loads(html.unescape(filled.group(1))) == api
    # a decimal comma, as a German keyboard (or a tablet's decimal keypad) types it, reads
    # as the API's point
    halves = console_server.client.get(f"/series/{series}/record",
                                       params={"oil_temperature": 40.5}).json()["record"]
    comma = browser_client.get(f"/console/diagnose?series={series}&oil_temperature=40,5")
    filled = re.search(r'<textarea id="document"[^>]*>(.*?)</textarea>', comma.text, re.S)
    assert filled is not None and json.loads(html.unescape(filled.group(1))) == halves
    assert halves != api
    bad = browser_client.get(f"/console/series/{series}?oil_temperature=warm")
    assert "valid number" in bad.text and "oil_temperature" in bad.text  # as the API says


def test_every_job_is_listed_and_a_sweeps_page_shows_its_table(
        console_server: LiveServer, browser_client: httpx.Client) -> None:
    """A sweep posted over HTTP could not be found from the console, and its page showed
    only its state (a maintenance planner's pass): a jobs list, and the sweep's table."""
    body = {"rig_id": 1, "faults": ["healthy", "worn_spool"], "method": "steady"}
    accepted = console_server.client.post("/scenarios", json=body, headers=console_server.auth)
    assert accepted.status_code == 202, accepted.text
    job_id = accepted.json()["job_id"]
    deadline = time.monotonic() + 60.0
    while console_server.client.get(f"/jobs/{job_id}").json()["status"] != "succeeded":
        assert time.monotonic() < deadline, "the sweep never finished"
        time.sleep(0.05)
    listed = browser_client.get("/console/jobs")
    assert listed.status_code == 200 and 'href="/console/jobs"' in listed.text   # in the nav
    row = re.search(rf'<a href="/console/jobs/{job_id}"><code>{job_id[:8]}</code></a></td>'
                    r"<td>sweep</td><td>succeeded</td>", listed.text)
    assert row is not None, listed.text
    shown = browser_client.get(f"/console/jobs/{job_id}").text
    table = re.search(r'<table id="sweep-table">(.*?)</table>', shown, re.S)
    assert table is not None and "<th>fault</th>" in table.group(1)
    assert "worn_spool" in table.group(1) and "Result: 2 point(s)" in shown


def zema_cycles(server: LiveServer) -> tuple[int, list[int], list[int]]:
    """The ZeMA rig registered and the temperature-span slice's cycles imported (18 healthy,
    18 severely leaking): (rig id, series ids, leakage labels), once per server."""
    made = getattr(server, "zema_cycles", None)
    if made is not None:
        return made  # type: ignore[no-any-return]
    from tests.app.test_pump_leak import import_span_cycles

    rig_id, ids, labels = import_span_cycles(server)
    made = (rig_id, ids, [int(k) for k in labels])
    server.zema_cycles = made  # type: ignore[attr-defined]
    return made


def test_the_pump_leak_page_shows_each_cycles_leak_and_its_steps(
        console_server: LiveServer, browser_client: httpx.Client) -> None:
    """The leak of a rig without a cylinder, as POST /rigs/{id}/pump-leak answers it: the
    summary, the chart (a point a cycle and the segments' medians), the segments; a bad
    baseline or a rig whose cycles lack the pump's channels is the field-naming error."""
    rig_id, ids, labels = zema_cycles(console_server)
    listed = browser_client.get(f"/console/series?rig={rig_id}")
    assert f'href="/console/series/pump-leak?rig={rig_id}"' in listed.text
    page = browser_client.get(f"/console/series/pump-leak?rig={rig_id}")
    assert page.status_code == 200, page.text
    leaking = sum(k > 0 for k in labels)
    assert f"36 cycles, <strong>{leaking} leaking</strong>" in page.text
    answer = console_server.client.post(f"/rigs/{rig_id}/pump-leak", json={},
                                        headers=console_server.auth).json()
    (points,) = plot_points(page.text)
    assert points == 36 + 2 * (len(answer["shifts"]) + 1)  # cycles + each segment's ends
    assert "leak at the plateau pressure [l/min]" in page.text
    assert page.text.count("<tr><td>") == len(answer["shifts"]) + 1  # one row a segment
    # the table's median leak is the chart's line: the segment's median (an even count's
    # two middle cycles averaged, as the CLI's table)
    if not answer["shifts"]:
        flows = [c["leak_flow"] for c in answer["cycles"]]
        assert f'{float(np.median(flows)) * 6e4:.3g}' in page.text
    healthy = [i for i, k in zip(ids, labels, strict=True) if k == 0]
    against = browser_client.get("/console/series/pump-leak", params={
        "rig": rig_id, "baseline": ",".join(map(str, healthy[:12]))})
    assert against.status_code == 200 and "cycles known healthy" in against.text
    bad = browser_client.get("/console/series/pump-leak",
                             params={"rig": rig_id, "baseline": "3,x"})
    assert bad.status_code == 422 and error_box(bad.text)[0] == "baseline_series_ids"
    few = browser_client.get("/console/series/pump-leak", params={"rig": rig_id,
                                                                  "baseline": "3,4"})
    assert few.status_code == 422 and error_box(few.text)[0] == "baseline_series_ids"
    reference = browser_client.get("/console/series/pump-leak?rig=1")
    assert reference.status_code == 422 and error_box(reference.text)[0] == "series_ids"
    assert "p_pump" in reference.text
