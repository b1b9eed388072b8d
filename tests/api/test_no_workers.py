"""A server started without run workers (`start_workers=False`: the OpenAPI export, tests,
WAAMFLOW_START_WORKERS=0) answers the run routes with 503 naming why, never a 500 traceback
(mypy found `Services.runs`, None then, used unchecked by every run route; issue 27)."""

from fastapi.testclient import TestClient

import toy_nodes as toy
from waamflow.api.app import create_app
from waamflow.settings import Settings


def test_run_routes_without_workers_answer_503(tmp_path):
    s = Settings(data_dir=tmp_path / "data", graphs_dir=None, start_viewer=False, static_dir=None, start_workers=False)
    with TestClient(create_app(s), raise_server_exceptions=False) as c:
        assert c.put("/api/graphs/g", json=toy.chain()).status_code == 201
        r = c.post("/api/runs", json={"graph": "g"})
        assert r.status_code == 503
        body = r.json()["detail"]
        assert body["kind"] == "unavailable"
        assert "without run workers" in body["message"]
        assert c.get("/api/runs").json() == []  # nothing was queued
        assert c.get("/api/graphs/g").status_code == 200  # the rest of the API answers
