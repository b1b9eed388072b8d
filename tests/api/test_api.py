import json
import time

import pytest
from fastapi.testclient import TestClient

import slow_nodes  # noqa: F401  (registers toy-slow)
import toy_nodes as toy
from api_util import wait_for_run as wait
from waamflow.api.app import create_app
from waamflow.settings import Settings


@pytest.fixture()
def client(tmp_path):
    gdir = tmp_path / "graphs"
    gdir.mkdir()
    (gdir / "example.json").write_text(json.dumps(toy.chain(stack={"count": 5})))
    s = Settings(data_dir=tmp_path / "data", graphs_dir=gdir, start_viewer=False, static_dir=None, workers=2)
    with TestClient(create_app(s)) as c:
        yield c


def test_health_and_nodes(client):
    h = client.get("/api/health").json()
    assert h["status"] == "ok" and h["viewer_url"] is None
    types = {n["type"] for n in client.get("/api/nodes").json()}
    assert {"toy-stack", "toy-grow"} <= types


def test_graph_crud_and_names(client):
    assert [g["name"] for g in client.get("/api/graphs").json()] == ["example"]
    r = client.put("/api/graphs/mine", json=toy.chain())
    assert r.status_code == 201 and r.json()["problems"] == []
    assert client.put("/api/graphs/mine", json=toy.chain()).status_code == 200
    assert client.get("/api/graphs/mine").json()["name"] == "mine"
    # half-wired graph: saved, problem reported
    half = toy.chain()
    half["edges"] = []
    r = client.put("/api/graphs/half", json=half)
    assert r.status_code == 201 and "required input" in r.json()["problems"][0]["message"]
    # schema errors: 422, names the field
    r = client.put("/api/graphs/bad", json={"nodes": [{"id": "1x", "type": "t"}]})
    assert r.status_code == 422 and "invalid node id" in r.json()["detail"]["message"]
    assert (
        client.put("/api/graphs/bad", content=b"{nope", headers={"content-type": "application/json"}).status_code == 422
    )
    for name in ("..%2Fetc", ".hidden", "a" * 81):
        assert client.get(f"/api/graphs/{name}").status_code in (404, 422)
    assert client.delete("/api/graphs/mine").status_code == 204
    assert client.get("/api/graphs/mine").status_code == 404
    assert client.delete("/api/graphs/mine").status_code == 404


def test_run_lifecycle_events_artifacts(client):
    r = client.post("/api/runs", json={"graph": "example", "inputs": {}})
    assert r.status_code == 202
    run = wait(client, r.json()["id"])
    assert run["status"] == "done" and run["progress"] == 1.0
    assert run["summary"]["layer_count"] == 5
    arts = {a["name"] for a in client.get(f"/api/runs/{run['id']}/artifacts").json()}
    assert arts == {"summary.json", "area.area.txt"}
    assert float(client.get(f"/api/runs/{run['id']}/artifacts/area.area.txt").text) == pytest.approx(5 * 144)
    assert client.get(f"/api/runs/{run['id']}/artifacts/..%2Fsecret").status_code in (400, 404)
    with client.stream("GET", f"/api/runs/{run['id']}/events") as s:
        events = [json.loads(line[6:]) for line in s.iter_lines() if line.startswith("data: ")]
    kinds = [e["kind"] for e in events]
    assert kinds[0] == "run_started" and kinds[-1] == "run_finished" and kinds.count("node_finished") == 3
    # the same graph again: all cached
    run2 = wait(client, client.post("/api/runs", json={"graph": "example"}).json()["id"])
    assert all(n["cached"] for n in run2["summary"]["nodes"].values())


def test_run_failures_are_4xx_or_failed_status(client):
    assert client.post("/api/runs", json={"graph": "nope"}).status_code == 404
    assert client.post("/api/runs", json={}).status_code == 422
    bad = toy.chain()
    bad["nodes"][1]["type"] = "nope"
    r = client.post("/api/runs", json={"recipe": bad})
    assert r.status_code == 422 and r.json()["detail"]["node"] == "grow"
    failing = toy.recipe(
        [("s", "toy-stack", {"count": 12}), ("m", "toy-fail", {"fail_at": 9})], [("s.layers", "m.layers")]
    )
    run = wait(client, client.post("/api/runs", json={"recipe": failing}).json()["id"])
    assert run["status"] == "failed"
    assert (run["error"]["node"], run["error"]["layer"], run["error"]["section"]) == ("m", 9, "bs1/A")
    assert client.get("/api/runs/zzz").status_code == 404


def test_cancel(client):
    # 40 layers × 0.25 s (at least 5 s on 2 workers): the cancel always lands mid-run, so the
    # only right answer is "cancelled", within a second or two, with layers left undone
    slow = toy.recipe(
        [("stack", "toy-stack", {"count": 40}), ("slow", "toy-slow", {"seconds": 0.25})],
        [("stack.layers", "slow.layers")],
    )
    rid = client.post("/api/runs", json={"recipe": slow}).json()["id"]
    t0 = time.monotonic()
    while client.get(f"/api/runs/{rid}").json()["status"] != "running":
        assert time.monotonic() - t0 < 10, "the run never started"
        time.sleep(0.02)
    t1 = time.monotonic()
    assert client.delete(f"/api/runs/{rid}").status_code == 202
    run = wait(client, rid)
    assert run["status"] == "cancelled"
    assert time.monotonic() - t1 < 2.5
    assert run["progress"] < 1.0


def test_preview_one_layer(client):
    data = toy.chain(stack={"count": 40})
    r = client.post("/api/preview", json={"recipe": data, "node": "grow", "layer": 12})
    assert r.status_code == 200
    body = r.json()
    assert body["layer"]["index"] == 12 and body["layer"]["area_mm2"] == pytest.approx(144)
    assert body["layer_count"] == 40 and body["error"] is None
    assert client.post("/api/preview", json={"recipe": data, "node": "grow", "layer": 99}).status_code == 422
    assert client.post("/api/preview", json={"recipe": data, "node": "zz", "layer": 1}).status_code == 422
    failing = toy.recipe(
        [("s", "toy-stack", {"count": 12}), ("m", "toy-fail", {"fail_at": 3})], [("s.layers", "m.layers")]
    )
    body = client.post("/api/preview", json={"recipe": failing, "node": "m", "layer": 3}).json()
    assert body["error"]["layer"] == 3 and body["error"]["section"] == "bs1/A"
    assert body["layer"]["index"] == 3  # the layer is still shown so the user can fix the mask


def test_restart_keeps_graphs_and_runs(tmp_path):
    s = Settings(data_dir=tmp_path / "d", graphs_dir=None, start_viewer=False, static_dir=None)
    with TestClient(create_app(s)) as c:
        c.put("/api/graphs/keep", json=toy.chain())
        rid = c.post("/api/runs", json={"graph": "keep"}).json()["id"]
        assert wait(c, rid)["status"] == "done"
    with TestClient(create_app(s)) as c:
        assert c.get("/api/graphs/keep").status_code == 200
        assert c.get(f"/api/runs/{rid}").json()["status"] == "done"
        with c.stream("GET", f"/api/runs/{rid}/events") as st:
            kinds = [json.loads(l[6:])["kind"] for l in st.iter_lines() if l.startswith("data: ")]
        assert kinds[-1] == "run_finished"
