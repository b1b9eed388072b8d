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
    s = Settings(data_dir=tmp_path / "data", graphs_dir=None, start_viewer=True, viewer_port=free_port(),
                 static_dir=None, workers=1)
    with TestClient(create_app(s)) as c:
        yield c


def test_select_view_state(client):
    viewer = client.app.state.services.viewer
    viewer.publish("mine", RECIPE, outputs(4))
    viewer.publish("other", RECIPE, outputs(2))          # ran last, but not the open recipe
    assert client.post("/api/viewer/select", json={"graph": "mine"}).status_code == 204
    st = client.get("/api/viewer/state").json()
    assert st["running"] and st["key"] == "mine" and st["layers"] == {"lo": 0, "hi": 3}
    assert [n["id"] for n in st["nodes"]] == ["part", "layers", "mask", "zone", "simulate"]
    r = client.post("/api/viewer/view", json={"hidden": ["part"], "layer_lo": 1, "layer_hi": 2, "sim_color": "speed", "fit": True})
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
