"""Real diagnoses of a wearing valve, the seed of the benchmarks' long histories
(``make console-bench``, ``make history-bench``): each record simulated on the steady path
and diagnosed and stored through the API."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime
from typing import Any

#: The valve's clearance from nominal to worn [m] (rig 1's document: 34 µm).
CLEARANCES_M = (34e-6, 60e-6)


def diagnose_wearing_valve(client: Any, times: Sequence[datetime],
                           headers: dict[str, str] | None = None) -> list[int]:
    """One stored diagnosis of rig 1 at each of ``times``, the valve's clearance rising
    evenly over :data:`CLEARANCES_M` (2.1 kN, 40 °C); their ids.  ``client`` is a
    ``fastapi.testclient.TestClient`` of the service (``headers``: its key, if the client
    does not send one)."""
    ids = []
    low, high = CLEARANCES_M
    for i, at in enumerate(times):
        cv = low + (high - low) * i / max(len(times) - 1, 1)
        answer = client.post("/simulate", json={
            "rig_id": 1, "overrides": {"valve.cv": cv}, "method": "steady",
            "condition": {"load": 2100.0, "oil_temperature": 40.0}})
        assert answer.status_code == 200, answer.text
        s = answer.json()["summary"]
        record = {"rig_id": 1, "condition": {"oil_temperature": 40.0, "load_force": 2100.0},
                  "pump_pressure": s["working.P_pump [Pa]"], "p1": s["working.P1 [Pa]"],
                  "p2": s["working.P2 [Pa]"], "flow_B": s["working.Q_meter_B [m^3/s]"],
                  "flow_C": s["working.Q_meter_C [m^3/s]"],
                  "speed_work": s["working.speed [m/s]"],
                  "speed_return": s["return.speed [m/s]"], "measured_at": at.isoformat()}
        answer = client.post("/diagnose", json={"record": record}, headers=headers)
        assert answer.status_code == 200, answer.text
        ids.append(int(answer.json()["diagnoses"][0]["id"]))
    return ids
