"""The viser scene built for hand-made outputs: handles, counts, incremental updates, GUI state."""

import numpy as np
import pytest

from waamflow.core.model import LayerPaths, Layered, SectionPath
from waamflow.viewer import colors as C
from waamflow.viewer import geometry as G

from viewer_fixtures import RECIPE, ZONE_COLORS, outputs


def handle(v, name):
    h = v.server.scene.get_handle_by_name(name)
    assert h is not None, name
    return h


def test_scene_tree_and_counts(viewer):
    out = outputs(8)
    stats = viewer.publish("viewer-test", RECIPE, out)
    names = viewer.scene_names()
    assert stats["removed"] == 0 and stats["skipped"] == 0
    assert "/graph/part/mesh/mesh" in names
    for port, node in (("layers", "layers"), ("toolpath", "zone"), ("sections", "mask")):
        layer_nodes = [n for n in names if n.startswith(f"/graph/{node}/{port}/L") and n.count("/") == 4]
        assert len(layer_nodes) == 8, port
    # sections: one fill per section per layer, plus the layer's guide batch
    assert sum(n.endswith("/bs1-A") for n in names) == 8
    assert sum(n.endswith("/guides") for n in names) == 8
    # toolpath: ONE line-segment batch per layer holding every move of the layer
    tp = out["zone"]["toolpath"]
    segs = handle(viewer, "/graph/zone/toolpath/L0003").points
    n_expected = sum(len(sp.points) - 1 for sp in tp[3].sections) + 1  # + the travel link
    assert segs.shape == (n_expected, 2, 3)
    assert np.allclose(segs[..., 2], tp[3].layer.z)
    # simulation: programmed and simulated per layer + torch marker
    assert len([n for n in names if n.endswith("/programmed")]) == 8
    assert len([n for n in names if n.endswith("/simulated")]) == 8
    assert "/graph/simulate/simulation/torch" in names


def test_zone_colours_match_the_toolpath(viewer):
    out = outputs(2)
    viewer.publish("k", RECIPE, out)
    disp = G.path_display(G.layer_polyline(out["zone"]["toolpath"][0]), 10_000)
    cols = handle(viewer, "/graph/zone/toolpath/L0000").colors
    for zone, hexcol in ZONE_COLORS.items():
        zi = disp.zone_ids.index(zone)
        m = (disp.zone == zi) & ~disp.travel
        assert m.sum() > 0
        assert (cols[m] == C.hex_to_rgb(hexcol)).all()
    assert (cols[disp.travel] == C.TRAVEL_RGB).all()


def test_republish_replaces_only_changed_layers(viewer):
    out = outputs(6)
    viewer.publish("k", RECIPE, out)
    names = viewer.scene_names()
    before = {i: handle(viewer, f"/graph/zone/toolpath/L{i:04d}") for i in range(6)}

    stats = viewer.publish("k", RECIPE, outputs(6))  # equal content, new objects
    assert stats["redrawn"] == 0 and stats["kept"] == 5
    assert viewer.scene_names() == names

    tp = out["zone"]["toolpath"]
    items = list(tp.items)
    sp = items[4].sections[1]
    slower = SectionPath(sp.key, sp.strategy, sp.points, sp.arc, sp.inside, sp.speed * 0.5, sp.zone, sp.zone_colors)
    items[4] = LayerPaths(items[4].layer, (items[4].sections[0], slower))
    changed = dict(out, zone={"toolpath": Layered(tuple(items))})
    stats = viewer.publish("k", RECIPE, changed)
    assert stats["redrawn"] == 1
    assert viewer.scene_names() == names  # replaced, not duplicated
    after = {i: handle(viewer, f"/graph/zone/toolpath/L{i:04d}") for i in range(6)}
    assert [after[i] is before[i] for i in range(6)] == [True, True, True, True, False, True]


def test_fewer_layers_and_removed_nodes_leave_no_residue(viewer):
    viewer.publish("k", RECIPE, outputs(8))
    small = outputs(3)
    del small["simulate"]
    viewer.publish("k", RECIPE, small)
    names = viewer.scene_names()
    assert not any(n.startswith("/graph/simulate") for n in names)
    assert len([n for n in names if n.startswith("/graph/zone/toolpath/L")]) == 3
    assert len([n for n in names if n.startswith("/graph/mask/sections/L") and n.count("/") == 4]) == 3
    assert set(viewer._node_boxes) == {"part", "layers", "mask", "zone"}


def test_colour_by_speed_mutates_existing_handles(viewer):
    out = outputs(2)
    viewer.publish("k", RECIPE, out)
    h = handle(viewer, "/graph/zone/toolpath/L0001")
    zone_cols = h.colors.copy()
    viewer._gui["path_color"].value = "speed"
    assert handle(viewer, "/graph/zone/toolpath/L0001") is h
    lo, hi = viewer.parts[("zone", "toolpath")].speed_range
    assert viewer.parts[("zone", "toolpath")].speed_full == (10.0, 20.0)
    assert 10.0 < lo < 10.5 and 19.5 < hi < 20.0  # 2nd–98th percentile of the speeds
    disp = G.path_display(G.layer_polyline(out["zone"]["toolpath"][1]), 10_000)
    fastest = np.nanargmax(np.where(disp.travel, np.nan, disp.speed))
    assert h.colors[fastest, 0].tolist() == C.colormap(np.array([disp.speed[fastest]]), lo, hi)[0].tolist()
    assert not np.array_equal(h.colors, zone_cols)
    viewer._gui["sim_color"].value = "speed"
    sim = handle(viewer, "/graph/simulate/simulation/L0000/simulated")
    assert sim.colors[0, 0].tolist() == C.colormap(np.array([5.0]), 5.0, 15.0)[0].tolist()


def test_layer_range_select_and_node_visibility(viewer):
    viewer.publish("k", RECIPE, outputs(8))
    assert viewer._gui["layers"].value == (0, 7)
    viewer._gui["layers"].value = (2, 4)
    vis = [handle(viewer, f"/graph/layers/layers/L{i:04d}").visible for i in range(8)]
    assert vis == [False, False, True, True, True, False, False, False]
    viewer.select("zone", 5)
    assert handle(viewer, "/graph/zone").visible is True
    assert handle(viewer, "/graph/layers").visible is False
    assert handle(viewer, "/graph/part").visible is True  # mesh stays as context
    assert [handle(viewer, f"/graph/zone/toolpath/L{i:04d}").visible for i in range(8)].count(True) == 1
    assert viewer._node_boxes["layers"].value is False
    viewer.select(None, None)
    assert handle(viewer, "/graph/layers").visible is True
    assert viewer._gui["layers"].value == (0, 7)
    viewer._node_boxes["mask"].value = False
    assert handle(viewer, "/graph/mask").visible is False


def test_pick_reads_layer_section_zone_and_both_speeds(viewer):
    out = outputs(4)
    viewer.publish("k", RECIPE, out)
    viewer.select(None, 1)
    sp = out["zone"]["toolpath"][1].sections[1]
    target = sp.points[3]
    info = viewer.pick(target + [0, 0, 50], np.array([0, 0, -1.0]))
    assert info["node"] == "zone" and info["layer"] == 1 and info["section"] == "bs1/B"
    assert info["zone"] == "start" and info["arc"] is True
    assert info["programmed_speed_mm_s"] == pytest.approx(sp.speed[3], abs=1e-3)
    assert info["actual_speed_mm_s"] is not None and info["deviation_mm"] == pytest.approx(0.3)
    # the simulated trace is offset 0.3 mm in y: picking there returns the trace sample and the
    # programmed speed of the nearest path point
    viewer._node_boxes["zone"].value = False
    info = viewer.pick(target + [0, 0.3, 50], np.array([0, 0, -1.0]))
    assert info["node"] == "simulate" and info["layer"] == 1
    assert info["programmed_speed_mm_s"] == pytest.approx(sp.speed[3], abs=1e-3)
    assert viewer.pick(np.array([500.0, 500, 50]), np.array([0, 0, -1.0])) is None


def test_playback_moves_the_torch(viewer):
    out = outputs(2)
    viewer.publish("k", RECIPE, out)
    sim = out["simulate"]["simulation"]
    assert viewer._gui["time"].max == pytest.approx(sim.trace["t"][-1])
    viewer._gui["time"].value = 0.5
    torch = handle(viewer, "/graph/simulate/simulation/torch")
    i = 5
    assert np.allclose(torch.position, [sim.trace["x"][i], sim.trace["y"][i], sim.trace["z"][i]], atol=1e-6)


def test_unknown_values_are_skipped(viewer):
    stats = viewer.publish("k", {"nodes": []}, {"post": {"program": "G1 X0"}, "x": {"y": 3}})
    assert stats == {"redrawn": 0, "kept": 0, "removed": 0, "skipped": 2}
    assert viewer.scene_names() == ["/graph"]


def test_features_as_points(viewer):
    class Feats:
        features = [{"kind": "free_end", "point": [0, 0]}, {"kind": "t_crossing", "point": [10, 5]}]

    viewer.publish("k", {"nodes": []}, {"feat": {"features": Feats()}})
    pc = handle(viewer, "/graph/feat/features/points")
    assert pc.points.shape == (2, 3)
    assert pc.colors[1].tolist() == list(C.FEATURE_RGB["t_crossing"])


def test_partial_run_keeps_layers_it_did_not_compute(viewer):
    out = outputs(5)
    viewer.publish("k", RECIPE, out)
    tp = out["zone"]["toolpath"]
    kept = viewer.server.scene.get_handle_by_name("/graph/zone/toolpath/L0001")
    partial = Layered(tuple(item if i == 3 else None for i, item in enumerate(tp.items)))
    stats = viewer.publish("k", RECIPE, dict(out, zone={"toolpath": partial}))
    assert stats["redrawn"] == 0
    assert len([n for n in viewer.scene_names() if n.startswith("/graph/zone/toolpath/L")]) == 5
    assert viewer.server.scene.get_handle_by_name("/graph/zone/toolpath/L0001") is kept


def test_url_reports_the_bound_port_and_stop_is_clean():
    from waamflow.viewer import ViewerService

    v = ViewerService(port=0)
    assert v.url is None
    v.start()
    try:
        assert v.bound_port > 0 and v.url == f"http://127.0.0.1:{v.bound_port}"
        import urllib.request

        with urllib.request.urlopen(v.url, timeout=10) as r:  # the bundled web client
            page = r.read()
        assert r.status == 200 and b"<html" in page.lower()[:2000]
    finally:
        v.stop()
    assert v.url is None and v.server is None


def test_corners_drawn_per_layer_and_picked(viewer):
    from dataclasses import replace

    out = outputs(3)
    sim = out["simulate"]["simulation"]
    prog = sim.programmed
    lay = sim.trace["layer"]
    vertex = np.array([9, 19, int(np.flatnonzero(lay == 2)[9])])  # pass ends: raster corners
    corners = {
        "vertex": vertex,
        "interior_deg": np.full(3, 90.0),
        "error_mm": np.array([0.1, 0.2, 0.4]),
        "min_speed_mm_s": np.array([3.0, 2.5, 2.0]),
    }
    out["simulate"]["simulation"] = replace(sim, corners=corners)
    viewer.publish("k", RECIPE, out)
    c0 = viewer.server.scene.get_handle_by_name("/graph/simulate/simulation/L0000/corners")
    c2 = viewer.server.scene.get_handle_by_name("/graph/simulate/simulation/L0002/corners")
    assert c0.points.shape == (2, 3) and c2.points.shape == (1, 3)
    assert viewer.server.scene.get_handle_by_name("/graph/simulate/simulation/L0001/corners") is None
    viewer._node_boxes["zone"].value = False
    info = viewer.pick(prog[vertex[2]] + [0, 0, 50], np.array([0, 0, -1.0]))
    assert info["corner"] is True and info["layer"] == 2
    assert info["corner_error_mm"] == pytest.approx(0.4) and info["corner_min_speed_mm_s"] == pytest.approx(2.0)


def test_layer_range_survives_a_rerun(viewer):
    viewer.publish("k", RECIPE, outputs(6))
    assert viewer._gui["layers"].value == (0, 5)
    viewer.publish("k", RECIPE, outputs(8))  # full range follows the part
    assert viewer._gui["layers"].value == (0, 7)
    viewer._gui["layers"].value = (2, 6)
    viewer.publish("k", RECIPE, outputs(5))  # a narrowed range is kept, clipped
    assert viewer._gui["layers"].value == (2, 4)
    assert [viewer.server.scene.get_handle_by_name(f"/graph/zone/toolpath/L{i:04d}").visible for i in range(5)] == [
        False,
        False,
        True,
        True,
        True,
    ]


def test_legend_lists_zone_colours_and_ranges(viewer):
    viewer.publish("k", RECIPE, outputs(2))
    html = viewer._gui["legend"].content
    for zone, hexcol in ZONE_COLORS.items():
        assert f"background:{hexcol}" in html and zone in html
    assert "speed 10.2–19.8 mm/s" in html and "deviation 0.3–0.3 mm" in html


def test_simulated_path_offset_side_by_side(viewer):
    out = outputs(2)
    viewer.publish("k", RECIPE, out)
    viewer._gui["offset"].value = 5.0
    sim = viewer.server.scene.get_handle_by_name("/graph/simulate/simulation/L0001/simulated")
    prog = viewer.server.scene.get_handle_by_name("/graph/simulate/simulation/L0001/programmed")
    # the thinner lines sit a display hair (1e-3 of the part's size) above the toolpath, in order
    lift = viewer.parts[("simulate", "simulation")].lift
    assert 0 < lift < 1e-3 * np.linalg.norm(viewer.bounds()[1] - viewer.bounds()[0]) + 1e-9
    assert np.allclose(sim.position, [0, 0, 5 + lift]) and np.allclose(prog.position, [0, 0, 2 * lift])
    torch = viewer.server.scene.get_handle_by_name("/graph/simulate/simulation/torch")
    s = out["simulate"]["simulation"].trace
    assert torch.position[2] == pytest.approx(s["z"][0] + 5.0)
    viewer._node_boxes["zone"].value = False
    j = int(np.flatnonzero(s["layer"] == 1)[30])  # top layer: nearest from above
    p = np.array([s["x"][j], s["y"][j], s["z"][j] + 5.0])
    info = viewer.pick(p + [0, 0, 50], np.array([0, 0, -1.0]))
    assert info["node"] == "simulate" and info["point"][2] == pytest.approx(p[2], abs=1e-3)
