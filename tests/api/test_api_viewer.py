"""/api/viewer: the GUI picks the open recipe's scene, changes the view, reads state and legend."""

import socket
import sys
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from waamflow.api.app import create_app
from waamflow.settings import Settings

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "viewer"))
from viewer_fixtures import RECIPE, outputs  # noqa: E402


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture()
def client(tmp_path):
    s = Settings(
        data_dir=tmp_path / "data",
        graphs_dir=None,
        start_viewer=True,
        viewer_port=free_port(),
        static_dir=None,
        workers=1,
    )
    with TestClient(create_app(s)) as c:
        yield c


def test_select_view_state(client):
    viewer = client.app.state.services.viewer
    viewer.publish("mine", RECIPE, outputs(4))
    viewer.publish("other", RECIPE, outputs(2))  # ran last, but not the open recipe
    assert client.post("/api/viewer/select", json={"graph": "mine"}).status_code == 204
    st = client.get("/api/viewer/state").json()
    assert st["running"] and st["key"] == "mine" and st["layers"] == {"lo": 0, "hi": 3}
    assert [n["id"] for n in st["nodes"]] == ["part", "layers", "mask", "zone", "simulate"]
    r = client.post(
        "/api/viewer/view", json={"hidden": ["part"], "layer_lo": 1, "layer_hi": 2, "sim_color": "speed", "fit": True}
    )
    assert r.status_code == 204
    st = client.get("/api/viewer/state").json()
    assert st["view"]["hidden"] == ["part"] and st["view"]["layer_lo"] == 1 and st["view"]["sim_color"] == "speed"
    assert client.post("/api/viewer/view", json={"path_color": "rainbow"}).status_code == 422
    assert client.post("/api/viewer/view", json={"colour": "zone"}).status_code == 422
    # the embedded page hides viser's notices (?embedded), the stock client files are served as they are
    import urllib.request

    html = urllib.request.urlopen(f"{viewer.url}/?embedded", timeout=5).read().decode()
    assert "wf-embedded" in html and ".mantine-Notifications-root" in html


def test_view_without_preview_is_409(tmp_path):
    s = Settings(data_dir=tmp_path / "data", graphs_dir=None, start_viewer=False, static_dir=None, workers=1)
    with TestClient(create_app(s)) as c:
        assert c.post("/api/viewer/view", json={"time_s": 1}).status_code == 409
        assert c.get("/api/viewer/state").json() == {"running": False}
        assert c.post("/api/viewer/select", json={"graph": "x"}).status_code == 204


def test_scene_of_a_run_made_before_a_restart_is_rebuilt(tmp_path):
    """Scenes live in memory: after a restart, selecting a graph rebuilds its latest finished run
    from the store (recipe + the draft XML it used) through the engine and the disk cache."""
    import json
    import time

    from api_util import wait_for_run

    graphs = Path(__file__).resolve().parents[2] / "graphs"
    recipe = json.loads((graphs / "mpp-cross.json").read_text())
    recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] in ("part", "layers", "mask")]
    recipe["nodes"][1]["params"]["layer_count"] = 3
    recipe["edges"] = [e for e in recipe["edges"] if e["to"].split(".")[0] in ("layers", "mask")]

    def settings():
        return Settings(
            data_dir=tmp_path / "data",
            graphs_dir=graphs,
            start_viewer=True,
            viewer_port=free_port(),
            static_dir=None,
            workers=1,
        )

    with TestClient(create_app(settings())) as c:
        assert c.put("/api/graphs/mini", json=recipe).status_code == 201
        run = wait_for_run(c, c.post("/api/runs", json={"graph": "mini"}).json()["id"], timeout=120)
        assert run["status"] == "done"
        draft = (graphs / "mpp-cross.params.xml").read_text()  # a draft XML is kept with its run
        newer = wait_for_run(
            c, c.post("/api/runs", json={"graph": "mini", "params_xml": draft}).json()["id"], timeout=120
        )
        assert c.app.state.services.store.get_run_params_xml(newer["id"]) == draft
        assert c.app.state.services.store.get_run_params_xml(run["id"]) is None
        assert c.get("/api/graphs/mini/params").status_code == 404  # never the graph's XML
        before = c.app.state.services.viewer
        deadline = time.time() + 30
        while before.scene_runs.get("mini") != newer["id"] and time.time() < deadline:
            time.sleep(0.05)
        assert c.post("/api/viewer/select", json={"graph": "mini"}).status_code == 204
        st0 = c.get("/api/viewer/state").json()
        assert st0["run"] == newer["id"]

    with TestClient(create_app(settings())) as c:  # the same data folder: a restarted server
        assert c.get("/api/viewer/state").json()["published"] == []
        assert c.post("/api/viewer/select", json={"graph": "mini"}).status_code == 204
        st = c.get("/api/viewer/state").json()
        assert st["loading"] is None or st["loading"]["run"] == newer["id"]
        deadline = time.time() + 60
        while (not st["nodes"] or st["loading"] is not None) and time.time() < deadline:
            time.sleep(0.1)
            st = c.get("/api/viewer/state").json()
        assert st["key"] == "mini" and st["run"] == newer["id"] and st["loading"] is None
        assert [n["id"] for n in st["nodes"]] == ["part", "layers", "mask"]
        assert st["layers"] == st0["layers"] == {"lo": 0, "hi": 2}
        assert st["bounds"] == st0["bounds"]
        # a graph that never ran: nothing to rebuild, the scene stays empty, no error
        assert c.post("/api/viewer/select", json={"graph": "bracket"}).status_code == 204
        st = c.get("/api/viewer/state").json()
        assert st["loading"] is None and st["rebuild_error"] is None and st["nodes"] == []


def test_rebuild_loading_state_and_failure(client):
    """While a run is rebuilt the state says which (the GUI shows "rebuilding the scene of run N…");
    a newer publish wins over a late rebuild; a failed rebuild is reported, not raised."""
    import threading
    import time

    viewer = client.app.state.services.viewer
    release = threading.Event()

    def loader(key):
        if key == "never-ran":
            return None

        def rebuild(cancel):
            assert release.wait(10)
            if key == "broken":
                raise FileNotFoundError("parts/gone.stl")
            return RECIPE, outputs(3)

        return f"run-of-{key}", rebuild

    viewer.loader = loader
    assert client.post("/api/viewer/select", json={"graph": "g"}).status_code == 204
    st = client.get("/api/viewer/state").json()
    assert st["loading"]["key"] == "g" and st["loading"]["run"] == "run-of-g" and st["nodes"] == []
    assert client.post("/api/viewer/select", json={"graph": "g"}).status_code == 204  # no second rebuild
    release.set()
    deadline = time.time() + 10
    while client.get("/api/viewer/state").json()["loading"] and time.time() < deadline:
        time.sleep(0.02)
    st = client.get("/api/viewer/state").json()
    assert st["run"] == "run-of-g" and st["layers"] == {"lo": 0, "hi": 2} and len(st["nodes"]) == 5

    release.clear()
    assert client.post("/api/viewer/select", json={"graph": "h"}).status_code == 204
    viewer.publish("h", RECIPE, outputs(4), run="fresh")  # a run of h ends while h is rebuilt
    release.set()
    time.sleep(0.3)
    st = client.get("/api/viewer/state").json()
    assert st["run"] == "fresh" and st["layers"] == {"lo": 0, "hi": 3}

    assert client.post("/api/viewer/select", json={"graph": "broken"}).status_code == 204
    deadline = time.time() + 10
    while client.get("/api/viewer/state").json()["loading"] and time.time() < deadline:
        time.sleep(0.02)
    st = client.get("/api/viewer/state").json()
    assert st["rebuild_error"] == {"run": "run-of-broken", "message": "parts/gone.stl"} and st["nodes"] == []
    assert client.post("/api/viewer/select", json={"graph": "never-ran"}).status_code == 204
    st = client.get("/api/viewer/state").json()
    assert st["loading"] is None and st["rebuild_error"] is None and st["key"] == "never-ran"
