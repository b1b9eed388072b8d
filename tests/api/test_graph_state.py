"""#25 GUI state: the runs of one saved graph (results after reopening, fault 8) and uploaded files
as versioned content addressed by sha256 (fault 5)."""

import json

import pytest
from fastapi.testclient import TestClient

import toy_nodes as toy
from waamflow.api.app import create_app
from waamflow.settings import Settings


@pytest.fixture()
def client(tmp_path):
    gdir = tmp_path / "graphs"
    gdir.mkdir()
    (gdir / "example.json").write_text(json.dumps(toy.chain(stack={"count": 5})))
    s = Settings(data_dir=tmp_path / "data", graphs_dir=gdir, start_viewer=False, static_dir=None, workers=1)
    with TestClient(create_app(s)) as c:
        yield c


def test_runs_of_one_graph_newest_first(client):
    store = client.app.state.services.store
    for i, g in enumerate(["a", "b", "a", None, "b", "a"]):
        store.create_run(f"r{i}", g, {"nodes": []}, None)
    assert [r["id"] for r in client.get("/api/runs?graph=a").json()] == ["r5", "r2", "r0"]
    assert [r["id"] for r in client.get("/api/runs?graph=a&limit=1").json()] == ["r5"]
    assert [r["id"] for r in client.get("/api/runs?graph=b").json()] == ["r4", "r1"]
    assert client.get("/api/runs?graph=none-such").json() == []
    assert len(client.get("/api/runs").json()) == 6  # without the filter: every run, as before
    assert client.get("/api/runs?graph=../x").status_code == 422
