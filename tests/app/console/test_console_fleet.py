"""The console with a fleet's rigs: every rig can be chosen, the rigs page pages.

Until a store-scale pass the menus read the first 500 rigs with their documents: the
501st rig of a fleet was counted on the rigs page ("Rigs (521)") and could not be chosen
anywhere.  The rigs are written straight to the store (copies of the reference rig's
document: 520 through ``POST /rigs`` would take minutes).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

FLEET = 520

#: the in-process client (the other console tests use a live server): starlette's test
#: client warns that it will want httpx2
pytestmark = pytest.mark.filterwarnings("ignore:Using `httpx` with `starlette.testclient`")


@pytest.fixture(scope="module")
def console(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    from fastapi.testclient import TestClient
    from sqlalchemy import insert, select

    from app.db.models import Rig, RigVersion
    from app.main import create_app
    from app.services.keys import create_api_key
    from app.settings import Settings

    app = create_app(Settings(data_dir=Path(tmp_path_factory.mktemp("fleet"))))
    with TestClient(app) as client:
        with app.state.sessions() as session:
            key = create_api_key(session, "fleet")[1]
            document = session.scalar(select(RigVersion.document).where(
                RigVersion.rig_id == 1))
            first = int(session.scalar(select(Rig.id).order_by(Rig.id.desc())) or 0) + 1
            ids = range(first, first + FLEET)
            session.execute(insert(Rig), [{"id": i, "name": f"fleet-{i}", "title": f"rig {i}",
                                           "latest_version": 1} for i in ids])
            session.execute(insert(RigVersion), [{"rig_id": i, "version": 1,
                                                  "document": document} for i in ids])
            session.commit()
        response = client.post("/console/login", data={"api_key": key, "next": ""},
                               follow_redirects=False)
        assert response.status_code == 303
        client.last = first + FLEET - 1  # type: ignore[attr-defined]
        yield client


def _options(html: str) -> list[int]:
    return [int(v) for v in re.findall(r'<option value="(\d+)"', html)]


@pytest.mark.parametrize("url", ["/console/history", "/console/trends?rig=1",
                                 "/console/simulate", "/console/series"])
def test_every_rig_of_a_fleet_is_in_the_menus(console: Any, url: str) -> None:
    response = console.get(url)
    assert response.status_code == 200, response.text[-300:]
    options = _options(response.text)
    assert console.last in options and len(options) >= FLEET
    assert options == sorted(options)


def test_the_rigs_page_lists_a_fleet_page_by_page(console: Any) -> None:
    first = console.get("/console/rigs").text
    total = FLEET + 1
    assert f"Rigs 1-500 of {total}." in first and 'rel="next"' in first
    assert f'href="/console/rigs/{console.last}"' not in first
    second = console.get("/console/rigs", params={"offset": 500}).text
    assert f'href="/console/rigs/{console.last}"' in second and 'rel="prev"' in second
    assert f"Rigs 501-{total} of {total}." in second and 'rel="next"' not in second
    # past the last page: the last page, not "No rigs stored"
    beyond = console.get("/console/rigs", params={"offset": 5000}).text
    assert f'href="/console/rigs/{console.last}"' in beyond and "No rigs stored" not in beyond
