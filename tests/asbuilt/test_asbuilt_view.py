"""The as-built surface in the 3D view (#29 item 2): a build with 2 scanned layers draws one point
cloud per layer under /asbuilt, one point per sample the scan saw, coloured blue → white → red over
±max |deviation|."""

from pathlib import Path

import numpy as np
import pytest

from waamflow.asbuilt import BuildSession, Disturbance, synth_scan
from waamflow.asbuilt.run import plan_for_build
from waamflow.engine.executor import FileResolver
from waamflow.engine.recipe import load_recipe
from waamflow.viewer.asbuilt import STOPS, AsBuiltOverlay, diverging

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The cross with layer 0 scanned 0.3 mm low and layer 1 0.2 mm high, the second half of its
    samples ramping to +0.5 mm (max)."""
    tp, post, _ = plan_for_build(load_recipe(ROOT / "graphs" / "mpp-cross.json"), FileResolver(ROOT / "graphs"))
    s = BuildSession.create(tmp_path_factory.mktemp("b") / "b", tp, {"id": "abcdef012345", "layers": 8}, post=post)
    rng = np.random.default_rng(3)
    d = Disturbance(scan_noise_mm=0.0)
    s.next_program()
    tr0, tr1 = s.tracks[0], s.tracks[1]
    s.add_scan(synth_scan(tr0, tr0.planned_height() - 0.3, d, rng))
    s.next_program()
    extra = np.where(np.arange(tr1.n) < tr1.n // 2, 0.2, np.linspace(0.2, 0.5, tr1.n))
    s.add_scan(synth_scan(tr1, tr1.planned_height() + extra, d, rng))
    return s


def test_overlay_points_and_colour_range(built):
    surf = built.surface()
    assert [r["layer"] for r in surf] == [0, 1]
    n0, n1 = built.tracks[0].n, built.tracks[1].n
    assert (n0, n1) == (510, 510)
    o = AsBuiltOverlay("abcdef012345", surf)
    seen = [int(np.isfinite(r["deviation"]).sum()) for r in surf]
    assert o.points == sum(seen) and seen[0] > 0.95 * n0 and seen[1] > 0.95 * n1
    assert o.min == pytest.approx(-0.3, abs=0.03) and o.max == pytest.approx(0.5, abs=0.03)
    lg = o.legend
    assert lg["range"]["hi"] == -lg["range"]["lo"] == pytest.approx(o.max, abs=1e-4)
    assert lg["layers"] == [0, 1] and lg["stops"] == ["#2166ac", "#f7f7f7", "#b2182b"]
    # the as-built points sit where the scan put the crests: 0.3 mm under the planned ones on layer 0
    p0 = built.tracks[0].points[np.isfinite(surf[0]["deviation"])]
    assert np.mean(o.layers[0][1][:, 2] - p0[:, 2]) == pytest.approx(-0.3, abs=0.03)
    # colours: the highest sample is the red end, −0.3 of ±0.5 is 60 % of the way to blue
    c1 = o.colors(1)
    assert tuple(c1[np.argmax(o.layers[1][2])]) == tuple(STOPS[2].astype(np.uint8))
    c0 = o.colors(0).astype(float)
    want = STOPS[1] + (STOPS[0] - STOPS[1]) * 0.3 / o.limit
    assert np.abs(c0.mean(axis=0) - want).max() < 8


def test_diverging_map_ends_and_middle():
    c = diverging(np.array([-2.0, -1.0, 0.0, 1.0, 2.0]), 1.0)
    assert c.tolist() == [[33, 102, 172], [33, 102, 172], [247, 247, 247], [178, 24, 43], [178, 24, 43]]


def test_viewer_draws_the_as_built_surface(built):
    from waamflow.viewer import ViewerService

    v = ViewerService(port=0, shared=True).start()
    try:
        lg = v.show_asbuilt("abcdef012345", built.surface())
        handles = v.server.scene._handle_from_node_name
        names = sorted(n for n in handles if n.startswith("/asbuilt/"))
        assert names == ["/asbuilt/layer_0000", "/asbuilt/layer_0001"]
        sizes = [len(handles[n].points) for n in names]
        assert sum(sizes) == lg["points"] and all(x > 480 for x in sizes)
        cols = np.vstack([handles[n].colors for n in names])
        assert cols.shape == (lg["points"], 3)
        red = (cols == STOPS[2].astype(np.uint8)).all(axis=1)
        assert red.sum() >= 1 and (cols[:, 0] >= 33).all() and (cols[:, 2] >= 43).all()
        # the view's state carries the legend (range ±0.5 mm, the 3 stops) beside the run's
        st = v.state()
        assert st["asbuilt"]["range"]["hi"] == pytest.approx(0.5, abs=0.03) and len(st["asbuilt"]["stops"]) == 3
        # showing none removes it from the shared scene and the state
        assert v.show_asbuilt(None) is None
        assert "asbuilt" not in v.state()
        assert not [n for n in v.server.scene._handle_from_node_name if n.startswith("/asbuilt/")]
    finally:
        v.stop()


def test_the_surface_follows_its_view_to_the_browser(built, monkeypatch):
    """Shown before the 3D tab's browser connects (a headless view): drawn again on its scene."""
    from waamflow.viewer import ViewerService
    from waamflow.viewer.session import NullScene, Target

    v = ViewerService(port=0).start()
    try:
        lg = v.show_asbuilt("abcdef012345", built.surface(), view="tab-1")
        assert lg["points"] > 960
        scene = NullScene()

        class Client:
            client_id = 99

        monkeypatch.setattr(v, "_view_of_client", lambda c: "tab-1")
        monkeypatch.setattr(v, "_client_target", lambda c: Target(scene, client=c))
        v._on_connect(Client())
        names = sorted(n for n in scene._handle_from_node_name if n.startswith("/asbuilt/"))
        assert names == ["/asbuilt/layer_0000", "/asbuilt/layer_0001"]
    finally:
        v.stop()
