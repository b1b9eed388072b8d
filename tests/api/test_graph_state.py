"""#25 GUI state: the runs of one saved graph (results after reopening, fault 8) and uploaded files
as versioned content addressed by sha256 (fault 5)."""

import hashlib
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


def _box_stl(height: float) -> bytes:
    """An ASCII STL box 60 x 12 x `height` mm (12 triangles, outward normals)."""
    import trimesh

    m = trimesh.creation.box(extents=(60, 12, height))
    m.apply_translation((0, 0, height / 2))
    return trimesh.exchange.stl.export_stl_ascii(m).encode()


def _mesh_recipe(pins=None):
    r = {
        "format": "waamflow/1",
        "name": "up",
        "description": "",
        "inputs": {},
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "part.stl"}},
            {"id": "layers", "type": "slice", "params": {"layer_height": 1.5}},
        ],
        "edges": [{"from": "part.mesh", "to": "layers.mesh"}],
    }
    if pins is not None:
        r["files"] = pins
    return r


def test_uploads_are_versioned_content_and_a_pinned_recipe_runs_with_its_content(client):
    from api_util import wait_for_run

    tall, low = _box_stl(24), _box_stl(12)
    assert client.put("/api/graphs/up", json=_mesh_recipe()).status_code == 201
    r1 = client.put("/api/graphs/up/files/part.stl", content=tall)
    assert r1.status_code == 204
    sha_tall = hashlib.sha256(tall).hexdigest()
    assert r1.headers["etag"] == f'"{sha_tall}"'
    # If-None-Match: * asks before replacing: 412 with what is stored, nothing stored
    r = client.put("/api/graphs/up/files/part.stl", content=low, headers={"If-None-Match": "*"})
    assert r.status_code == 412
    assert r.json()["detail"]["theirs"] == {"sha256": sha_tall, "size": len(tall)}
    assert len(client.get("/api/graphs/up/files/part.stl/versions").json()) == 1
    assert client.put("/api/graphs/up/files/other.stl", content=low, headers={"If-None-Match": "*"}).status_code == 204
    # the existing route replaces at once, as before; the old content stays stored
    sha_low = hashlib.sha256(low).hexdigest()
    assert client.put("/api/graphs/up/files/part.stl", content=low).headers["etag"] == f'"{sha_low}"'
    versions = client.get("/api/graphs/up/files/part.stl/versions").json()
    assert [(v["version"], v["sha256"], v["size"]) for v in versions] == [
        (2, sha_low, len(low)),
        (1, sha_tall, len(tall)),
    ]
    files = {f["name"]: f for f in client.get("/api/graphs/up/files").json()}
    assert files["part.stl"]["sha256"] == sha_low and files["part.stl"]["size"] == len(low)

    def layers(body):
        res = client.post("/api/runs", json=body)
        assert res.status_code == 202, res.text
        run = wait_for_run(client, res.json()["id"], timeout=60)
        assert run["status"] == "done", run
        return run["summary"]["layer_count"], json.dumps(run["summary"])

    # unpinned: the name's current content (as before); pinned: exactly the pinned content
    assert layers({"graph": "up"})[0] == 8
    n, summary = layers({"graph": "up", "recipe": _mesh_recipe({"part.stl": sha_tall})})
    assert n == 16 and sha_tall in summary
    assert layers({"graph": "up", "recipe": _mesh_recipe({"part.stl": sha_low})})[0] == 8
    # a saved recipe's pins hold for a run of the graph alone too
    client.put("/api/graphs/up", json=_mesh_recipe({"part.stl": sha_tall}))
    assert layers({"graph": "up"})[0] == 16
    # content the graph never had: 422 naming the file
    bad = client.post("/api/runs", json={"graph": "up", "recipe": _mesh_recipe({"part.stl": "0" * 64})})
    assert bad.status_code == 422 and "part.stl" in bad.json()["detail"]["message"]
    assert client.put("/api/graphs/up", json=_mesh_recipe({"part.stl": "not-a-hash"})).status_code == 422
    assert client.get("/api/graphs/up/files/none.stl/versions").status_code == 404


def test_a_file_by_name_or_by_content(client):
    a, b = b"solid a\nendsolid a\n", b"solid b\nendsolid b\n"
    client.put("/api/graphs/g", json=_mesh_recipe())
    client.put("/api/graphs/g/files/part.stl", content=a)
    client.put("/api/graphs/g/files/part.stl", content=b)
    now = client.get("/api/graphs/g/files/part.stl")
    assert now.status_code == 200 and now.content == b and now.headers["etag"] == f'"{hashlib.sha256(b).hexdigest()}"'
    assert client.get(f"/api/graphs/g/files/part.stl?sha256={hashlib.sha256(a).hexdigest()}").content == a
    # content another graph holds is out of reach by hash
    client.put("/api/graphs/h", json=_mesh_recipe())
    client.put("/api/graphs/h/files/secret.stl", content=b"solid s\nendsolid s\n")
    other = hashlib.sha256(b"solid s\nendsolid s\n").hexdigest()
    assert client.get(f"/api/graphs/g/files/part.stl?sha256={other}").status_code == 404
    assert client.get("/api/graphs/g/files/none.stl").status_code == 404
    assert client.get("/api/graphs/g/files/part.stl?sha256=xyz").status_code == 422


def test_latest_run_says_whether_it_is_of_the_saved_recipe(client):
    from api_util import wait_for_run

    def run(body):
        rid = client.post("/api/runs", json=body).json()["id"]
        assert wait_for_run(client, rid)["status"] == "done"
        return rid

    r = toy.chain(stack={"count": 3})
    client.put("/api/graphs/t", json=r)
    a = run({"graph": "t"})
    latest = lambda: client.get("/api/runs?graph=t&limit=1").json()[0]  # noqa: E731
    assert (latest()["id"], latest()["same_as_saved"]) == (a, True)
    edited = toy.chain(stack={"count": 4})
    b = run({"graph": "t", "recipe": edited})  # unsaved edits
    assert (latest()["id"], latest()["same_as_saved"]) == (b, False)
    client.put("/api/graphs/t", json=edited)  # saved now: the same run is of the saved recipe
    assert latest()["same_as_saved"] is True
    assert client.get("/api/runs?graph=t").json()[1]["same_as_saved"] is False  # run a: an older revision
    assert (
        "same_as_saved" not in client.get("/api/runs").json()[0]
        or client.get("/api/runs").json()[0]["same_as_saved"] is None
    )


def test_a_run_with_other_input_values_is_not_of_the_saved_recipe(client):
    from api_util import wait_for_run

    client.put("/api/graphs/t", json=toy.chain(stack={"count": 3}, inputs={"speed": 10}))
    rid = client.post("/api/runs", json={"graph": "t", "inputs": {"speed": 20}}).json()["id"]
    assert wait_for_run(client, rid)["status"] == "done"
    assert client.get("/api/runs?graph=t&limit=1").json()[0]["same_as_saved"] is False
