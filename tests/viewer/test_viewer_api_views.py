"""/api/viewer with `view`: two GUI tabs steer their own 3D views through one server (issue 25,
fault 6); the embedded page hands its view id to viser's websocket."""

import socket

import pytest
from fastapi.testclient import TestClient

from viewer_fixtures import RECIPE, outputs


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture()
def client(tmp_path):
    from waamflow.api.app import create_app
    from waamflow.settings import Settings

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


def test_two_tabs_two_views(client):
    viewer = client.app.state.services.viewer
    viewer.publish("duct", RECIPE, outputs(3))
    viewer.publish("bracket", RECIPE, outputs(6))
    assert client.post("/api/viewer/select", json={"graph": "duct", "view": "tab-1"}).status_code == 204
    assert client.post("/api/viewer/select", json={"graph": "bracket", "view": "tab-2"}).status_code == 204
    r = client.post("/api/viewer/view", json={"view": "tab-2", "time_s": 1.5, "sim_color": "deposit", "fit": "cell"})
    assert r.status_code == 204
    one = client.get("/api/viewer/state", params={"view": "tab-1"}).json()
    two = client.get("/api/viewer/state", params={"view": "tab-2"}).json()
    assert (one["key"], one["layers"], one["view"]["time_s"], one["view"]["sim_color"]) == (
        "duct",
        {"lo": 0, "hi": 2},
        0.0,
        "deviation",
    )
    assert (two["key"], two["layers"], two["view"]["time_s"], two["view"]["sim_color"]) == (
        "bracket",
        {"lo": 0, "hi": 5},
        1.5,
        "deposit",
    )
    assert one["view_id"] == "tab-1" and two["view_id"] == "tab-2"
    # no view: the default view, untouched by the tabs
    assert client.get("/api/viewer/state").json()["view_id"] == ""
    # bad view ids and fit values are 422, never 500
    assert client.post("/api/viewer/select", json={"graph": "duct", "view": "../x"}).status_code == 422
    assert client.get("/api/viewer/state", params={"view": "a b"}).status_code == 422
    assert client.post("/api/viewer/view", json={"view": "tab-1", "fit": "robot"}).status_code == 422


def test_embedded_page_passes_the_view_to_the_websocket(client):
    import urllib.request

    viewer = client.app.state.services.viewer
    html = urllib.request.urlopen(f"{viewer.url}/?embedded&view=tab-1", timeout=5).read().decode()
    assert "websocket" in html and "view" in html and "replaceState" in html
