"""``POST /rigs/{rig_id}/pump-leak``: the pump's leak per stored cycle of a rig without a
cylinder, over HTTP, on real ZeMA cycles imported as a user would (the temperature-span
slice: 18 healthy and 18 severely leaking cycles; the labels only score)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from app.services import pump_leak as pump_leak_service
from diagnostics.real.monitor import monitor_pump_leak
from diagnostics.real.zema import load_1hz, read_records
from sim.rigs import load_rig, load_rig_document
from tests.app.live import LiveServer
from tests.app.test_examples import example_body
from tests.real_slices import zema_span_slice

ZEMA = Path(__file__).resolve().parents[2] / "sim" / "rigs" / "zema.yaml"


def import_span_cycles(server: LiveServer) -> tuple[int, list[int], np.ndarray]:
    """The ZeMA rig registered on ``server`` and the slice's cycles imported over HTTP as a
    user would: (rig id, series ids in the cycles' order, leakage labels)."""
    r = server.client.post("/rigs", json={"document": load_rig_document(ZEMA)},
                           headers=server.auth)
    assert r.status_code == 201, r.text
    rig_id = int(r.json()["id"])
    data, labels = load_1hz(zema_span_slice())
    frames = [rec.frame().assign(record=rec.name) for rec in read_records(data)]
    r = server.client.post(f"/rigs/{rig_id}/series", data={"name": "span-cycles"},
                           files={"file": ("cycles.csv",
                                           pd.concat(frames).to_csv(index=False).encode())},
                           headers=server.auth)
    assert r.status_code == 201, r.text
    ids = [int(item["id"]) for item in r.json()["items"]]
    return rig_id, ids, np.asarray(labels.leakage).astype(int)


@pytest.fixture(scope="module")
def stored(server: LiveServer) -> tuple[int, list[int], np.ndarray]:
    """The ZeMA rig and the slice's cycles on this module's server."""
    return import_span_cycles(server)


def _post(server: LiveServer, rig_id: int, body: dict[str, Any]) -> Any:
    return server.client.post(f"/rigs/{rig_id}/pump-leak", json=body, headers=server.auth)


def test_every_stored_cycle_is_read_as_the_library_reads_it(
        server: LiveServer, stored: tuple[int, list[int], np.ndarray]) -> None:
    rig_id, ids, lab = stored
    before = server.row_counts()
    spec = server.client.get("/openapi.json").json()
    operation = spec["paths"]["/rigs/{rig_id}/pump-leak"]["post"]
    # the document's example (every default: all the rig's stored cycles)
    r = _post(server, rig_id, example_body(
        spec, operation["requestBody"]["content"]["application/json"]["schema"]))
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["rig_id"] == rig_id and out["rig_version"] == 1
    assert [c["series_id"] for c in out["cycles"]] == ids
    assert [c["leaking"] for c in out["cycles"]] == list(lab > 0)
    assert out["leaking"] == int((lab > 0).sum()) and out["reference"] == "batch"
    # the stored cycles give the library's answer on the files' records
    data, _ = load_1hz(zema_span_slice())
    lib = monitor_pump_leak(read_records(data), load_rig(ZEMA).fluid)
    np.testing.assert_allclose([c["size"] for c in out["cycles"]],
                               [c.size for c in lib.cycles], rtol=1e-9, atol=1e-18)
    assert out["shunt"] == pytest.approx(lib.shunt, rel=1e-9, abs=1e-30)
    assert len(out["shifts"]) == len(lib.shifts)
    # the same cycles named one by one: the same answer
    named = _post(server, rig_id, {"series_ids": ids})
    assert named.status_code == 200 and named.json()["cycles"] == out["cycles"]
    assert server.row_counts() == before  # nothing stored


def test_a_batch_of_healthy_cycles_needs_its_baseline(
        server: LiveServer, stored: tuple[int, list[int], np.ndarray]) -> None:
    rig_id, ids, lab = stored
    healthy = [i for i, k in zip(ids, lab, strict=True) if k == 0]
    leaking = [i for i, k in zip(ids, lab, strict=True) if k > 0]
    alone = _post(server, rig_id, {"series_ids": healthy})
    assert alone.status_code == 422, alone.text
    assert alone.json()["error"]["field"] == "baseline_series_ids"
    assert "no separate leaking group" in alone.json()["error"]["message"]
    r = _post(server, rig_id, {"series_ids": healthy[12:] + leaking,
                               "baseline_series_ids": healthy[:12]})
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["reference"] == "baseline" and out["separation"] is None
    judged = [c for c in out["cycles"] if c["size"] is not None]
    assert judged and all(c["leaking"] == (c["series_id"] in leaking) for c in judged)
    # without naming the batch: every stored cycle but the baseline's
    every = _post(server, rig_id, {"baseline_series_ids": healthy[:12]})
    assert every.status_code == 200, every.text
    assert [c["series_id"] for c in every.json()["cycles"]] == [
        i for i in ids if i not in healthy[:12]]  # no clock times: in order of import


@pytest.mark.parametrize(("body", "status", "field", "said"), [
    ({"series_ids": [1, 2], "baseline_series_ids": None, "windw": 1.0}, 422, "windw",
     "window"),
    ({"relaxation": 120.0}, 422, "relaxation", ""),
    ({"window": 0}, 422, "window", ""),
    ({"series_ids": [10**9, 10**9 + 1]}, 404, "series_ids", "no series"),
])
def test_bad_requests_name_their_field(server: LiveServer,
                                       stored: tuple[int, list[int], np.ndarray],
                                       body: dict[str, Any], status: int, field: str,
                                       said: str) -> None:
    rig_id, _, _ = stored
    r = _post(server, rig_id, body)
    assert r.status_code == status, r.text
    error = r.json()["error"]
    assert error["field"].endswith(field), error
    assert said in r.text


def test_cycles_of_another_rig_or_none_are_refused(
        server: LiveServer, stored: tuple[int, list[int], np.ndarray]) -> None:
    rig_id, ids, _ = stored
    before = server.row_counts()
    other = _post(server, 1, {"series_ids": ids[:3]})
    assert other.status_code == 422 and other.json()["error"]["field"] == "series_ids"
    assert "another rig" in other.json()["error"]["message"]
    empty = _post(server, 1, {})
    assert empty.status_code == 422 and "import its cycles first" in empty.text
    # a cylinder rig's stored cycle: refused by its channels before its samples are read
    cycle = server.client.post("/rigs/1/series", headers=server.auth, data={"name": "stroke"},
                               files={"file": ("stroke.csv", b"t [s],P1 [bar],v [m/s]\n"
                                               b"0,10,0.1\n0.001,10,0.1\n0.002,10,0.1\n")})
    assert cycle.status_code == 201, cycle.text
    stroke = int(cycle.json()["items"][0]["id"])
    before = server.row_counts()
    lacking = _post(server, 1, {"series_ids": [stroke, stroke]})
    assert lacking.status_code == 422, lacking.text  # (the id twice: refused after)
    assert lacking.json()["error"]["field"] == "series_ids"
    assert f"series {stroke} has no p_pump, q_work channel" in lacking.text
    assert "P1, v" in lacking.text
    both = _post(server, rig_id, {"series_ids": ids[:20], "baseline_series_ids": ids[10:22]})
    assert both.status_code == 422
    assert both.json()["error"]["field"] == "baseline_series_ids" and "both" in both.text
    assert _post(server, 10**9, {}).status_code == 404
    assert server.row_counts() == before


def test_the_latest_cycles_are_read_when_the_rig_has_more(
        server: LiveServer, stored: tuple[int, list[int], np.ndarray],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A monitored rig stores a cycle a minute, 5,000 in three and a half days: past that the
    default request was refused ("name them in series_ids"); it reads the latest cycles and
    says how many it left out."""
    rig_id, ids, lab = stored
    latest = _post(server, rig_id, {"last": 24})
    assert latest.status_code == 200, latest.text
    out = latest.json()
    # no clock times in the slice: the latest by order of import
    assert [c["series_id"] for c in out["cycles"]] == ids[-24:]
    assert [c["leaking"] for c in out["cycles"]] == list(lab[-24:] > 0)
    assert out["notes"][0] == (f"read the latest 24 of the rig's {len(ids)} stored cycles (by "
                               "clock time, then order of import); name others in series_ids")
    # more stored cycles than a request reads: the latest of them, said so
    baseline = [i for i, k in zip(ids, lab, strict=True) if k == 0][:12]
    rest = [i for i in ids if i not in baseline]
    monkeypatch.setattr(pump_leak_service, "MAX_CYCLES", 18)
    capped = _post(server, rig_id, {"baseline_series_ids": baseline})
    assert capped.status_code == 200, capped.text
    assert [c["series_id"] for c in capped.json()["cycles"]] == rest[-18:]
    assert capped.json()["notes"][0] == (
        f"read the latest 18 of the rig's {len(rest)} stored cycles besides the baseline (by "
        "clock time, then order of import: at most 18 a request); name others in series_ids")
    monkeypatch.undo()
    every = _post(server, rig_id, {})
    assert every.status_code == 200 and not any("latest" in n for n in every.json()["notes"])
    both = _post(server, rig_id, {"series_ids": ids[:24], "last": 24})
    assert both.status_code == 422 and both.json()["error"]["field"] == "last"
