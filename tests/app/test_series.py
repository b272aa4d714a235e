"""POST /rigs/{id}/series: measured time series stored as measurements of a rig, read back."""

from __future__ import annotations

import json
from typing import Any

import httpx
import numpy as np
import pytest

from diagnostics.real.zema import COLUMN_MAP, cycles_frame, load_1hz
from sim.rigs import reference_rig_document
from tests.app.live import LiveServer
from tests.real_slices import zema_slice

SLICE = zema_slice()
CMAP = json.dumps({k: list(v) for k, v in COLUMN_MAP.items()})


@pytest.fixture(scope="module")
def zema_csv() -> tuple[bytes, Any]:
    """Three ZeMA cycles as a long CSV without a time column (1 Hz)."""
    data, _ = load_1hz(SLICE, cycles=[1, 7, 13])
    return cycles_frame(data).to_csv(index=False).encode(), data


def _upload(server: LiveServer, content: bytes, form: dict[str, Any], rig: int = 1) -> Any:
    return server.client.post(f"/rigs/{rig}/series", data=form,
                              files={"file": ("zema.csv", content, "text/csv")},
                              headers=server.auth)


def test_zema_cycles_are_stored_and_read_back(server: LiveServer, zema_csv: Any) -> None:
    content, data = zema_csv
    response = _upload(server, content, {"name": "zema-slice", "column_map": CMAP,
                                         "sample_rate": "1"})
    assert response.status_code == 201, response.text
    items = response.json()["items"]
    assert [i["record"] for i in items] == ["cycle-1", "cycle-7", "cycle-13"]
    first = items[0]
    assert first["measured"] is True and first["sample_rate"] == pytest.approx(1.0)
    assert first["n_samples"] == 60
    assert first["units"] == {"p_pump": "Pa", "p_work": "Pa", "q_work": "m^3/s",
                              "motor_power": "W", "oil_temperature": "degC"}
    listed = server.client.get("/rigs/1/series").json()
    assert listed["total"] == 3 and listed["items"] == items
    full = server.client.get(f"/series/{first['id']}").json()
    assert full["t"][:3] == [0.0, 1.0, 2.0]
    assert full["channels"]["p_pump"][5] == pytest.approx(data.sensors["PS1"][0, 5] * 1e5)
    assert full["channels"]["q_work"][20] == pytest.approx(data.sensors["FS1"][0, 20] / 6e4)


@pytest.mark.parametrize(
    ("content", "form", "field"),
    [
        (b"record,PS1\nc,1\nc,2\n", {"column_map": '{"PS1": ["p_pump", "psi"]}',
                                     "sample_rate": "1"}, "file.PS1"),
        (b"record,PS1\nc,1\nc,nan\n", {"column_map": '{"PS1": ["p_pump", "bar"]}',
                                       "sample_rate": "1"}, "file.PS1"),
        (b"record,PS1\nc,1\nc,2\n", {"column_map": '{"PS1": ["p_pump", "bar"]}'}, "file.t"),
        (b"t [s],p [bar]\n0,1\n1,2\n", {"column_map": "{not json"}, "column_map"),
        (b"t [s],p [bar]\n0,1\n1,2\n", {"sample_rate": "-1"}, "sample_rate"),
        (b"p [bar]\n1\n2\n", {"sample_rate": "1e308"}, "sample_rate"),  # t of 1e-308 s
        (b"t [s],p [bar]\n0,1\n1,2\n", {"extra": "x"}, "extra"),
        (b"record,PS1\nc,1\nc,2\n", {"column_map": '{"PS1": ["p_pump", "bar", "x", 0]}',
                                     "sample_rate": "1"}, "column_map.PS1"),
        (b"record,PS1\nc,1\nc,2\n", {"column_map": '{"PS1": ["p_pump", "bar", 0, 0]}',
                                     "sample_rate": "1"}, "column_map.PS1"),
    ],
)
def test_bad_files_are_422_naming_the_column_and_store_nothing(
        server: LiveServer, content: bytes, form: dict[str, Any], field: str) -> None:
    before = server.row_counts()
    response = _upload(server, content, {"name": "bad"} | form)
    assert response.status_code == 422, response.text
    assert response.json()["error"]["field"] == field
    assert server.row_counts() == before


def test_an_import_name_outside_its_characters_is_told_in_words(server: LiveServer) -> None:
    """The form once answered with the raw pattern '^[A-Za-z0-9_.:-]{1,200}$'."""
    response = _upload(server, b"t [s],P1 [bar]\n0,10\n1,11\n", {"name": "Prüfstand Öl"})
    assert response.status_code == 422 and response.json()["error"]["field"] == "name"
    message = response.json()["error"]["message"]
    assert "no spaces or accents" in message and "^[" not in message
    schema = server.client.get("/openapi.json").text
    assert "[A-Za-z0-9_.:-]{1,200}" in schema   # still documented as a pattern


def test_unknown_rig_and_series(server: LiveServer) -> None:
    before = server.row_counts()
    response = _upload(server, b"t [s],p [bar]\n0,1\n1,2\n", {"name": "x"}, rig=999)
    assert response.status_code == 404 and response.json()["error"]["field"] == "rig_id"
    assert server.row_counts() == before
    assert server.client.get("/series/99999").status_code == 404


def test_a_series_is_deleted_and_then_its_rig(server: LiveServer) -> None:
    """A rig with measured series names them when its deletion is refused; an admin deletes
    a series (404 after), and then the rig."""
    document = reference_rig_document() | {"name": "delete-me"}
    created = server.client.post("/rigs", json={"document": document}, headers=server.auth)
    assert created.status_code == 201, created.text
    rig = int(created.json()["id"])
    stored = _upload(server, b"t [s],p [bar]\n0,1\n1,2\n", {"name": "wrong-file"}, rig=rig)
    series = int(stored.json()["items"][0]["id"])
    before = server.row_counts()
    refused = server.client.delete(f"/rigs/{rig}", headers=server.auth)
    assert refused.status_code == 409, refused.text
    error = refused.json()["error"]
    assert error["field"] == "rig_id" and "1 measured series" in error["message"]
    assert server.row_counts() == before
    assert server.anon.delete(f"/series/{series}").status_code == 401
    assert server.client.delete(f"/series/{series}", headers=server.auth).status_code == 204
    assert server.client.get(f"/series/{series}").status_code == 404
    assert server.client.delete(f"/series/{series}", headers=server.auth).status_code == 404
    assert server.client.delete(f"/rigs/{rig}", headers=server.auth).status_code == 204
    after = server.row_counts()
    assert after["measured_series"] == before["measured_series"] - 1
    assert after["rigs"] == before["rigs"] - 1


def test_a_loggers_semicolon_file_with_raw_signals(server: LiveServer) -> None:
    """A logger's export as a spreadsheet in many locales writes it (';', decimal commas),
    its pressure a 4-20 mA signal and its time a sample count, with a column of notes:
    read through the calibrations of the column map, the notes left out, the record
    named after the file."""
    content = b"sample;PT1 signal;note\n0;4,0;start\n1;12,0;\n2;20,0;end\n"
    cmap = json.dumps({"sample": ["t", "ms", 10, 0], "PT1 signal": ["P1", "bar", 15.625, -62.5],
                       "note": ["skip", "-"]})
    response = server.client.post("/rigs/1/series", data={"name": "logger", "column_map": cmap},
                                  files={"file": ("run-7.csv", content, "text/csv")},
                                  headers=server.auth)
    assert response.status_code == 201, response.text
    [item] = response.json()["items"]
    assert item["record"] == "run-7.csv" and item["units"] == {"P1": "Pa"}
    assert item["sample_rate"] == pytest.approx(100.0)
    full = server.client.get(f"/series/{item['id']}").json()
    assert full["t"] == pytest.approx([0.0, 0.01, 0.02])
    assert full["channels"]["P1"] == pytest.approx([0.0, 125e5, 250e5])


def test_a_compressed_upload_is_read_and_a_bomb_refused(server: LiveServer) -> None:
    """A gzip-compressed file is read as its text (the record named without ``.gz``); one
    that decompresses beyond the series limit is a 422 naming the file, nothing stored."""
    import gzip

    from app.services.series import MAX_SERIES_BYTES

    text = b"t [s],P1 [bar]\n0,1.5\n1,2.5\n"
    r = server.client.post("/rigs/1/series", data={"name": "packed"},
                           files={"file": ("run.csv.gz", gzip.compress(text), "application/gzip")},
                           headers=server.auth)
    assert r.status_code == 201, r.text
    [item] = r.json()["items"]
    assert item["record"] == "run.csv"
    assert server.client.get(f"/series/{item['id']}").json()["channels"]["P1"] == [1.5e5, 2.5e5]
    before = server.row_counts()
    bomb = gzip.compress(b"t [s],P1 [bar]\n" + b"0,1\n" * (MAX_SERIES_BYTES // 4 + 1))
    assert len(bomb) < 100_000
    r = server.client.post("/rigs/1/series", data={"name": "bomb"},
                           files={"file": ("bomb.csv.gz", bomb, "application/gzip")},
                           headers=server.auth)
    assert r.status_code == 422 and r.json()["error"]["field"] == "file", r.text
    assert server.row_counts() == before


def test_a_file_over_the_series_limit_is_refused_by_the_route_not_the_body_limit(
        server: LiveServer) -> None:
    """A file between the series cap (20 MiB) and the upload body limit (64 MiB) reaches the
    route, which reads one byte past its cap and says the file is larger than the cap."""
    from app.services.series import MAX_SERIES_BYTES

    before = server.row_counts()
    content = b"t [s],P1 [bar]\n" + b"0.000,1.000\n" * (MAX_SERIES_BYTES // 12 + 10)
    assert MAX_SERIES_BYTES < len(content) < server.settings.max_upload_bytes
    r = server.client.post("/rigs/1/series", data={"name": "too-long"},
                           files={"file": ("long.csv", content, "text/csv")},
                           headers=server.auth)
    assert r.status_code == 422, r.text
    error = r.json()["error"]
    assert error["field"] == "file"
    assert f"larger than {MAX_SERIES_BYTES} bytes (20 MiB)" in error["message"]
    assert server.row_counts() == before


def test_the_start_is_read_from_the_file_name_a_logger_wrote(server: LiveServer) -> None:
    """``time_in_name``: the clock time in the uploaded file's name (its zone given, or by %z
    in the format) is the time at which its t reads 0; conflicting or unreadable fields are a
    422 naming them, nothing stored."""
    content = b"t [s],P1 [bar]\n1.5,10\n2.5,11\n"
    name = "PS1_9-10-2019-4-37-01 PM.txt.gz"
    import gzip

    r = server.client.post("/rigs/1/series", data={
        "name": "named", "time_in_name": "%m-%d-%Y-%I-%M-%S %p", "zone": "-04:00"},
        files={"file": (name, gzip.compress(content), "application/gzip")}, headers=server.auth)
    assert r.status_code == 201, r.text
    [item] = r.json()["items"]
    assert item["measured_at"] == "2019-09-10T20:37:02.500000Z"  # 16:37:01 −04:00 + 1.5 s
    before = server.row_counts()
    for form, field in [
        ({"time_in_name": "%m-%d-%Y-%I-%M-%S %p"}, "time_in_name"),  # no zone
        ({"time_in_name": "%Y%m%d", "zone": "Z"}, "time_in_name"),  # not in the name
        ({"time_in_name": "%m-%d-%Y-%I-%M-%S %p", "zone": "+25:00"}, "zone"),
        ({"time_in_name": "%m-%d-%Y-%I-%M-%S %p", "zone": "Z",
          "started_at": "2026-11-20T08:00:00Z"}, "started_at"),
        ({"zone": "Z"}, "zone"),
        ({"time_in_name": "%Q-%d", "zone": "Z"}, "time_in_name"),
    ]:
        refused = server.client.post("/rigs/1/series", data={"name": "named-bad"} | form,
                                     files={"file": (name, content, "text/csv")},
                                     headers=server.auth)
        assert refused.status_code == 422, (form, refused.text)
        assert refused.json()["error"]["field"] == field, (form, refused.json())
    assert server.row_counts() == before


def test_a_start_that_cannot_be_a_measurements_time_is_refused(server: LiveServer) -> None:
    """A series dated 2999 or 1900 was stored, and a diagnosis of it went to the top of the
    history and stretched the trends' axis: refused, from the form, from the file's header
    and from its name, nothing stored."""
    content = b"t [s],P1 [bar]\n0,10\n1,11\n"
    before = server.row_counts()
    cases = [({"started_at": "2999-01-01T00:00:00Z"}, content, "x.csv"),
             ({"started_at": "1900-01-01T00:00:00Z"}, content, "x.csv"),
             ({}, b'# started_at = "2999-01-01T00:00:00Z"\n' + content, "x.csv"),
             ({"time_in_name": "%Y%m%d", "zone": "Z"}, content, "log_19000101.csv")]
    for form, body, name in cases:
        refused = server.client.post("/rigs/1/series", data={"name": "dated"} | form,
                                     files={"file": (name, body, "text/csv")},
                                     headers=server.auth)
        assert refused.status_code == 422, (form, refused.text)
        assert refused.json()["error"]["field"] == "started_at", (form, refused.json())
    assert server.row_counts() == before
    # yesterday's and an hour ahead (a logger's clock a little fast) are stored
    from datetime import UTC, datetime, timedelta

    for delta in (timedelta(days=-1), timedelta(hours=1)):
        when = (datetime.now(UTC) + delta).isoformat()
        ok = server.client.post("/rigs/1/series", data={"name": "dated", "started_at": when},
                                files={"file": ("x.csv", content, "text/csv")},
                                headers=server.auth)
        assert ok.status_code == 201, ok.text


def test_a_channel_of_the_rig_in_a_unit_of_another_quantity_is_refused(
        server: LiveServer) -> None:
    """A pressure column mapped in L/min was stored, and the workflow then read P1
    985,787,553,649 σ off; a misspelt channel (P9 for P1) was stored without a word."""
    content = b"time;PA;PB\n0;10;1\n1;11;1\n"
    before = server.row_counts()
    wrong = server.client.post("/rigs/1/series", data={
        "name": "units", "column_map": json.dumps({"time": ["t", "s"], "PA": ["P1", "L/min"],
                                                   "PB": ["P2", "bar"]})},
        files={"file": ("log.csv", content, "text/csv")}, headers=server.auth)
    assert wrong.status_code == 422, wrong.text
    assert wrong.json()["error"]["field"] == "file.PA"
    assert "expected Pa" in wrong.json()["error"]["message"]
    assert server.row_counts() == before
    typo = server.client.post("/rigs/1/series", data={
        "name": "units", "column_map": json.dumps({"time": ["t", "s"], "PA": ["P9", "bar"],
                                                   "PB": ["P2", "bar"]})},
        files={"file": ("log.csv", content, "text/csv")}, headers=server.auth)
    assert typo.status_code == 201, typo.text
    # (and a 2-sample file holds no stroke: said last, with its own note)
    note, load, temperature, short = typo.json()["notes"]
    assert "holds 2 sample(s), too few to hold a stroke" in short
    assert note.startswith("channel(s) P9 are not channels of the rig's model")
    # stored without a load or temperature: said now, not only when a reader refuses it
    assert "state no load" in load and "'load [N]' column" in load
    assert "state no oil temperature" in temperature
    listed = server.client.get("/rigs/1/series").json()
    assert listed["notes"] == []
    # a pump flow meter is no output of the model, yet a cycle's readings use it: no note
    metered = server.client.post("/rigs/1/series", data={
        "name": "units", "column_map": json.dumps({"time": ["t", "s"], "PA": ["Q_pump", "L/min"],
                                                   "PB": ["P2", "bar"]})},
        files={"file": ("log.csv", content, "text/csv")}, headers=server.auth)
    assert metered.status_code == 201
    assert not any("not channels" in n for n in metered.json()["notes"])


def test_the_same_import_twice_is_refused_and_a_days_new_file_is_not(
        server: LiveServer) -> None:
    # a real-data pass: importing the same cycles under the same name twice stored them
    # twice, and a discrepancy check of the campaign counted each twice
    day1 = b"t [s],P1 [bar]\n0,10.25\n1,11.25\n"    # samples no other test stores
    day2 = b"t [s],P1 [bar]\n0,12.25\n1,13.25\n"

    def send(content: bytes) -> httpx.Response:
        return server.client.post("/rigs/1/series", data={"name": "daily-log"},
                                  files={"file": ("log.csv", content, "text/csv")},
                                  headers=server.auth)

    assert send(day1).status_code == 201
    before = server.row_counts()
    again = send(day1)
    assert again.status_code == 409 and again.json()["error"]["field"] == "file"
    assert "stored already" in again.json()["error"]["message"]
    assert server.row_counts() == before
    # with a start stated on one import and not the other: the same samples (a
    # discrepancy pass stored them twice, then held out a record it had trained on)
    started = server.client.post("/rigs/1/series", data={
        "name": "daily-log-2", "started_at": "2026-11-20T08:00:00Z"},
        files={"file": ("log.csv", day1, "text/csv")}, headers=server.auth)
    assert started.status_code == 409 and "stored already" in started.text
    # a corrected stated condition: refused as the same samples, and told how to replace
    first = send(b"t [s],P1 [bar],load [N]\n0,20,2.1\n1,21,2.1\n")      # kN under [N]
    assert first.status_code == 201, first.text
    fixed = send(b"t [s],P1 [bar],load [N]\n0,20,2100\n1,21,2100\n")
    assert fixed.status_code == 409
    message = fixed.json()["error"]["message"]
    assert f"delete series {first.json()['items'][0]['id']}" in message
    assert "to correct a stated condition" in message
    assert server.row_counts() == before | {"measured_series": before["measured_series"] + 1}
    assert send(day2).status_code == 201   # the logger's next file, same name: new data
    # the same samples under another channel name (a column map changed): the same data,
    # stored four times over in a real-data analyst's pass
    renamed = send(day1.replace(b"P1 [bar]", b"P2 [bar]"))
    assert renamed.status_code == 409 and "stored already" in renamed.text
    # other values under the same names: new data
    assert send(b"t [s],P1 [bar],P2 [bar]\n0,10.25,11\n1,11.25,10\n").status_code == 201


def test_the_same_file_sent_by_several_clients_at_once_is_stored_once(
        server: LiveServer) -> None:
    """Ten clients posting one file at once stored it 2-4 times (an SRE pass, 11 of 16
    rounds): each checked for the samples before any had stored them.  The check and the
    insert now hold the rig's write lock together."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    content = b"t [s],P1 [bar]\n0,14.75\n1,15.75\n2,16.75\n"  # samples no other test stores
    start = threading.Barrier(6)

    def send(k: int) -> int:
        start.wait()
        return server.client.post("/rigs/1/series", data={"name": f"twin-{k}"},
                                  files={"file": ("log.csv", content, "text/csv")},
                                  headers=server.auth).status_code

    before = server.row_counts()["measured_series"]
    with ThreadPoolExecutor(6) as pool:
        codes = sorted(pool.map(send, range(6)))
    assert codes == [201] + [409] * 5, codes
    assert server.row_counts()["measured_series"] == before + 1


def test_a_cycle_imported_at_a_wrong_sample_rate_is_said(server: LiveServer) -> None:
    """A 100 Hz logger's stroke imported as '1 Hz' was stored without a word: the piston
    then crosses its travel ~140× slower than the pump can drive it (a note naming the
    factor; stored, since a throttled piston can be that slow); at its rate, no note."""
    t = np.arange(0.0, 6.0, 0.01)
    x = np.clip((t - 0.5) * 0.16, 0.0, 0.5)                 # 0.16 m/s out over 0.5 m
    body = "x [m],load [N],oil_temperature [degC]\n" + "".join(
        f"{float(xi)!r},4200,40\n" for xi in x)
    for rate, said in ((1.0, True), (100.0, False)):
        answer = server.client.post("/rigs/1/series", data={
            "name": f"rate-{rate:g}", "sample_rate": str(rate)},
            files={"file": ("stroke.csv", body.encode(), "text/csv")}, headers=server.auth)
        assert answer.status_code == 201, answer.text
        notes = [n for n in answer.json()["notes"] if "crosses its travel" in n]
        if said:
            (note,) = notes
            assert f"{100 * 0.2200660941517565 / 0.16:.3g}×" in note and "too long" in note
        else:
            assert notes == []


def test_a_cycle_whose_own_values_contradict_its_units_is_stored_with_a_note(
        server: LiveServer) -> None:
    """A discrepancy pass: bar under [Pa], l/min under [m^3/s], kN under [N], and records too
    short or too coarse to hold a stroke were stored without a word (and read back as a
    record with p1 = 12.7 Pa, or as a stalled stroke); the import now says what the
    discrepancy workflow and /diagnose would refuse, and a sound cycle gets none of it."""
    import io

    import pandas as pd

    r = server.client.post("/simulate", json={
        "rig_id": 1, "fault": "worn_spool", "condition": {"load": 3300.0, "oil_temperature": 45.0},
        "timeseries": "csv", "sample_rate": 1000.0}, headers=server.auth)
    assert r.status_code == 200, r.text
    frame = pd.read_csv(io.BytesIO(r.content), comment="#")

    def notes(table: pd.DataFrame, name: str) -> list[str]:
        answer = server.client.post("/rigs/1/series", data={"name": name},
                                    files={"file": (f"{name}.csv", table.to_csv(index=False),
                                                    "text/csv")}, headers=server.auth)
        assert answer.status_code == 201, answer.text
        return list(answer.json()["notes"])

    slips = ("is it in bar", "is it in l/min", "is the load in kN", "too few", "sampled every")
    assert not [n for n in notes(frame, "sound") for s in slips if s in n]
    bar = frame.assign(**{c: frame[c] / 1e5 for c in frame.columns if c.endswith("[Pa]")})
    assert any("is it in bar" in n and "stored as given" in n for n in notes(bar, "bar"))
    lpm = frame.assign(**{"Q_meter_B [m^3/s]": frame["Q_meter_B [m^3/s]"] * 6e4})
    assert any("is it in l/min" in n for n in notes(lpm, "lpm"))
    # (a sample less: the same samples at another stated load are the sound cycle's twin)
    kn = frame.iloc[1:].assign(**{"load [N]": frame["load [N]"].iloc[1:] / 1e3})
    assert any("is the load in kN" in n for n in notes(kn, "kn"))
    assert any("holds 5 sample(s), too few" in n for n in notes(frame.iloc[:5], "five"))
    coarse = notes(frame.iloc[::200], "coarse")           # 5 Hz
    assert any("sampled every 200 ms (5 Hz)" in n for n in coarse), coarse
    # a logger dropout and a stated rate the times contradict: stored, with a note each
    dropout = notes(frame.drop(index=range(700, 900)), "dropout")
    assert any("1 gap(s) in its time, about 200 sample(s) missing" in n for n in dropout)
    answer = server.client.post("/rigs/1/series", data={"name": "rate", "sample_rate": "100"},
                                files={"file": ("rate.csv", frame.iloc[2:].to_csv(index=False),
                                                "text/csv")}, headers=server.auth)
    assert answer.status_code == 201, answer.text
    assert any("the sample rate given, 100 Hz" in n and "(1000 Hz)" in n
               for n in answer.json()["notes"]), answer.json()["notes"]


def test_a_column_map_entry_the_file_lacks_is_named_in_a_note(server: LiveServer) -> None:
    """A map naming 'Durchfluss' for a file without it stored the records with a note that
    sent the analyst back to a map that was right (an analyst's pass)."""
    content = b"Zeit;PA;PB\n0;31.5;1.25\n1;31.7;1.25\n2;31.6;1.25\n"
    cmap = {"Zeit": ["t", "s"], "PA": ["P1", "bar"], "PB": ["P2", "bar"],
            "Durchfluss": ["Q_meter_C", "l/min"], "Spule": ["phase", "-"]}
    answer = server.client.post("/rigs/1/series", data={"name": "lacks",
                                                        "column_map": json.dumps(cmap)},
                                files={"file": ("lacks.csv", content, "text/csv")},
                                headers=server.auth)
    assert answer.status_code == 201, answer.text
    (first, *_) = answer.json()["notes"]
    assert first.startswith("the column map names 'Durchfluss' (as Q_meter_C), which the file "
                            "does not have"), first
    assert not any("'Spule'" in n for n in answer.json()["notes"])   # labels are not channels
