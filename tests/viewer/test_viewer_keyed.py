"""Scenes keyed by recipe: the GUI's open recipe is shown, not whatever ran last; view settings
and legend data through the service (what /api/viewer/view and /state expose)."""

import numpy as np
import pytest

from viewer_fixtures import RECIPE, outputs


def test_show_keeps_the_open_recipes_scene(viewer):
    viewer.publish("a", RECIPE, outputs(3))
    assert viewer.show("a") is True
    assert viewer.state()["layers"] == {"lo": 0, "hi": 2}
    # another recipe runs on the server: deferred, the shown scene stays
    stats = viewer.publish("b", RECIPE, outputs(5))
    assert stats["deferred"] == 1
    st = viewer.state()
    assert st["key"] == "a" and st["layers"] == {"lo": 0, "hi": 2} and st["published"] == ["a", "b"]
    # the GUI opens b: its run is drawn, the camera fits its bounds
    assert viewer.show("b") is True
    st = viewer.state()
    assert st["key"] == "b" and st["layers"] == {"lo": 0, "hi": 4}
    assert np.allclose(viewer.server.initial_camera.look_at, viewer.part_bounds().mean(axis=0), atol=1e-3)
    # a recipe never run in this session: empty scene, nothing of b left
    assert viewer.show("never-run") is False
    assert viewer.state()["nodes"] == [] and viewer.scene_names() == ["/graph"]


def test_view_settings_and_legend(viewer):
    viewer.publish("a", RECIPE, outputs(6))
    viewer.show("a")
    viewer.set_view(
        hidden={"layers"},
        layer_lo=2,
        layer_hi=3,
        path_color="speed",
        sim_color="deposit",
        show_programmed=False,
        time_s=0.5,
    )
    st = viewer.state()
    assert st["view"]["hidden"] == ["layers"] and (st["view"]["layer_lo"], st["view"]["layer_hi"]) == (2, 3)
    vis = {n["id"]: n["visible"] for n in st["nodes"]}
    assert vis["layers"] is False and vis["zone"] is True
    assert viewer.server.scene.get_handle_by_name("/graph/layers").visible is False
    assert viewer.server.scene.get_handle_by_name("/graph/zone/toolpath/L0001").visible is False
    assert viewer.server.scene.get_handle_by_name("/graph/zone/toolpath/L0002").visible is True
    assert viewer.server.scene.get_handle_by_name("/graph/simulate/simulation/L0002/programmed").visible is False
    assert viewer._gui["sim_color"].value == "deposit" and viewer._gui["path_color"].value == "speed"
    tp = next(x for x in st["legend"] if x["kind"] == "toolpath")
    assert tp["mode"] == "speed" and tp["ranges"]["speed"]["unit"] == "mm/s"
    assert tp["ranges"]["speed"]["lo"] <= tp["ranges"]["speed"]["hi"]
    assert len(st["colormap"]) == 9 and st["colormap"][0] == "#440154"
    with pytest.raises(ValueError, match="path_color"):
        viewer.set_view(path_color="rainbow")
    with pytest.raises(ValueError, match="unknown"):
        viewer.set_view(colour="zone")


def test_deposit_colour_maps_each_sample_to_its_programmed_segment(viewer):
    from waamflow.viewer import colors as C

    out = outputs(2)
    sim = out["simulate"]["simulation"]
    n = len(sim.programmed)
    dep = np.linspace(1.0, 3.0, n - 1)  # mm³/mm rising along the path
    object.__setattr__(sim, "deposit", {"actual_mm3_per_mm": dep, "arc": np.ones(n - 1, bool)})
    viewer.publish("a", RECIPE, out)
    viewer.set_view(sim_color="deposit")
    part = next(p for p in viewer.parts.values() if p.kind == "simulation")
    assert part.ranges["deposit"] == pytest.approx((1.04, 2.96), abs=0.01)  # 2nd–98th percentile
    lo, hi = part.ranges["deposit"]
    per = part.deposit_per_sample()
    # sample i sits 0.3 mm beside programmed point i: its segment is i-1 or i (nearest midpoint)
    i = np.arange(1, n - 1)
    assert np.all((np.isclose(per[i], dep[i - 1])) | np.isclose(per[i], dep[i]))
    h = viewer.server.scene.get_handle_by_name("/graph/simulate/simulation/L0000/simulated")
    first = part.entries[0]["first"]
    assert (h.colors[:, 0] == C.colormap(per[first], lo, hi)).all()
    legend = next(x for x in viewer.state()["legend"] if x["kind"] == "simulation")
    assert legend["mode"] == "deposit" and legend["ranges"]["deposit"]["unit"] == "mm³/mm"


def test_switching_recipe_resets_hidden_nodes(viewer):
    viewer.publish("a", RECIPE, outputs(2))
    viewer.publish("b", RECIPE, outputs(2))
    viewer.show("a")
    viewer.set_view(hidden={"mask"})
    viewer.show("b")
    assert viewer.state()["view"]["hidden"] == []
    assert viewer.server.scene.get_handle_by_name("/graph/mask").visible is True
