"""One 3D scene per browser view (issue 25, fault 6): two browser clients, each with its own
`?view=` id, show two different recipes at once; each receives only its own scene, keeps its own
playback time and colours, and a third party's select does not touch them."""

import time

import pytest

from test_viewer_clients import scene_names_received
from viewer_fixtures import RECIPE, outputs


@pytest.fixture
def private_viewer():
    """The API's mode: no shared scene, every browser client gets its own."""
    from waamflow.viewer import ViewerService

    v = ViewerService(port=0, shared=False).start()
    yield v
    v.stop()


def connect(viewer, view_id: str | None):
    import viser
    from websockets.sync.client import connect as ws_connect

    import msgspec

    url = viewer.url.replace("http://", "ws://") + ("/" if view_id is None else f"/?view={view_id}")
    ws = ws_connect(url, max_size=None, subprotocols=[f"viser-v{viser.__version__}"])
    # viser counts a client as connected once it reports its camera (the browser does at once)
    ws.send(
        msgspec.msgpack.encode(
            {
                "type": "ViewerCameraMessage",
                "wxyz": [1.0, 0.0, 0.0, 0.0],
                "position": [0.0, -300.0, 200.0],
                "fov": 1.3,
                "near": 0.01,
                "far": 1000.0,
                "image_height": 600,
                "image_width": 800,
                "look_at": [0.0, 0.0, 0.0],
                "up_direction": [0.0, 0.0, 1.0],
            }
        )
    )
    return ws


def wait_for(pred, seconds: float = 5.0):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if pred():
            return True
        time.sleep(0.05)
    return False


def test_two_views_see_their_own_recipes(private_viewer):
    pytest.importorskip("zstandard")
    v = private_viewer
    v.publish("duct", RECIPE, outputs(3))
    v.publish("bracket", RECIPE, outputs(6))
    one, two = connect(v, "tab-one"), connect(v, "tab-two")
    try:
        assert wait_for(lambda: {"tab-one", "tab-two"} <= set(v.sessions))
        assert v.show("duct", view="tab-one") is True
        assert v.show("bracket", view="tab-two") is True
        a, b = v.state(view="tab-one"), v.state(view="tab-two")
        assert (a["key"], a["layers"]) == ("duct", {"lo": 0, "hi": 2})
        assert (b["key"], b["layers"]) == ("bracket", {"lo": 0, "hi": 5})
        got_one, got_two = scene_names_received(one), scene_names_received(two)

        def layers(names):
            return sorted(n for n in names if n.startswith("/graph/zone/toolpath/L"))

        assert layers(got_one) == [f"/graph/zone/toolpath/L{i:04d}" for i in range(3)]
        assert layers(got_two) == [f"/graph/zone/toolpath/L{i:04d}" for i in range(6)]
        # own playback time and colours: tab two's settings never reach tab one
        v.set_view(view="tab-two", time_s=2.0, sim_color="deposit", path_color="speed")
        a, b = v.state(view="tab-one"), v.state(view="tab-two")
        assert (a["view"]["time_s"], a["view"]["sim_color"], a["view"]["path_color"]) == (0.0, "deviation", "zone")
        assert (b["view"]["time_s"], b["view"]["sim_color"], b["view"]["path_color"]) == (2.0, "deposit", "speed")
        scene_names_received(two, seconds=1.0)  # drain tab two's recolouring
        # a script steering the server-wide default changes neither tab
        assert v.show("bracket") is True
        assert v.state(view="tab-one")["key"] == "duct" and v.state()["key"] == "bracket"
        # a new run of duct reaches tab one only
        stats = v.publish("duct", RECIPE, outputs(4))
        assert stats["sessions"] == 1
        assert v.state(view="tab-one")["layers"] == {"lo": 0, "hi": 3}
        assert v.state(view="tab-two")["layers"] == {"lo": 0, "hi": 5}
        assert "/graph/zone/toolpath/L0003" in scene_names_received(one)
        assert not any(n.startswith("/graph/zone/toolpath/L") for n in scene_names_received(two, seconds=1.0))
    finally:
        one.close()
        two.close()


def test_a_view_keeps_its_state_across_reconnects(private_viewer):
    """The GUI's 3D tab unmounts its iframe on a tab change: the next client with the same view id
    gets the same recipe, layer range and colours, redrawn."""
    pytest.importorskip("zstandard")
    v = private_viewer
    v.publish("duct", RECIPE, outputs(5))
    v.show("duct", view="tab")  # before any browser client: the view exists headless
    v.set_view(view="tab", layer_lo=1, layer_hi=3, sim_color="speed")
    ws = connect(v, "tab")
    try:
        names = scene_names_received(ws)
        assert "/graph/zone/toolpath/L0004" in names
        st = v.state(view="tab")
        assert st["key"] == "duct" and (st["view"]["layer_lo"], st["view"]["layer_hi"]) == (1, 3)
        assert st["view"]["sim_color"] == "speed"
    finally:
        ws.close()
    assert wait_for(lambda: v.sessions["tab"].client is None)
    ws = connect(v, "tab")
    try:
        assert "/graph/zone/toolpath/L0004" in scene_names_received(ws)
        assert v.state(view="tab")["view"]["layer_lo"] == 1
    finally:
        ws.close()


def test_a_client_without_a_view_id_follows_every_run(private_viewer):
    pytest.importorskip("zstandard")
    v = private_viewer
    ws = connect(v, None)
    try:
        assert wait_for(lambda: any(k.startswith("client-") for k in v.sessions))
        v.publish("any", RECIPE, outputs(2))
        assert "/graph/zone/toolpath/L0001" in scene_names_received(ws)
    finally:
        ws.close()
    assert wait_for(lambda: not any(k.startswith("client-") for k in v.sessions))


def test_views_are_bounded(private_viewer):
    from waamflow.viewer.service import MAX_VIEWS

    v = private_viewer
    for i in range(MAX_VIEWS + 5):
        v.show("x", view=f"v{i}")
    assert len([k for k in v.sessions if k]) <= MAX_VIEWS
    assert "v0" not in v.sessions and f"v{MAX_VIEWS + 4}" in v.sessions
