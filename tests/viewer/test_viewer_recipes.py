"""Scenes of the shipped example recipes (run headless through the engine, then published)."""

from pathlib import Path

import numpy as np
import pytest

from waamflow.viewer import geometry as G

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def run_recipe(name: str, artifacts: bool = False):
    from waamflow.engine import executor
    from waamflow.engine.graph import build_graph
    from waamflow.engine.recipe import load_recipe

    path = GRAPHS / f"{name}.json"
    recipe = load_recipe(path)
    result = executor.execute(build_graph(recipe), resolver=executor.FileResolver(path.parent), artifacts=artifacts)
    return (recipe.to_json(), result.outputs) + ((result.artifacts,) if artifacts else ())


def layer_nodes(names, node, port):
    return [n for n in names if n.startswith(f"/graph/{node}/{port}/L") and n.count("/") == 4]


def test_mpp_cross_scene(viewer):
    recipe, out = run_recipe("mpp-cross")
    viewer.publish("mpp-cross", recipe, out)
    names = viewer.scene_names()
    assert len(layer_nodes(names, "layers", "layers")) == 8  # contract: 8 layers
    for node, ports in out.items():
        for port, value in ports.items():
            if port in ("layers", "sections", "toolpath"):
                assert len(layer_nodes(names, node, port)) == sum(x is not None for x in value.items)
    # three sections per layer, each drawn as one fill
    sec_node = next(n for n, p in out.items() if "sections" in p)
    fills = [n for n in names if n.startswith(f"/graph/{sec_node}/sections/L0003/") and not n.endswith("/guides")]
    assert len(fills) == 3
    # toolpaths: one batch per layer with every move (no decimation at this size), zone colours
    tp_node = next(n for n in ("sequence", "zone") if n in out)
    tp = out[tp_node]["toolpath"]
    for i in (0, 7):
        h = viewer.server.scene.get_handle_by_name(f"/graph/{tp_node}/toolpath/L{i:04d}")
        poly = G.layer_polyline(tp[i])
        assert h.points.shape == (len(poly.points) - 1, 2, 3)
        assert np.allclose(h.points[:, 0], poly.points[:-1], atol=1e-4)
    assert viewer.publish("mpp-cross", recipe, out)["redrawn"] == 0


def test_rectangle_study_scene(viewer):
    recipe, out = run_recipe("rectangle-study")
    viewer.publish("rectangle-study", recipe, out)
    names = viewer.scene_names()
    sim = out["simulate"]["simulation"]
    layers = np.unique(np.asarray(sim.trace["layer"]))
    assert len(layer_nodes(names, "simulate", "simulation")) == len(layers)
    assert all(f"/graph/simulate/simulation/L{i:04d}/simulated" in names for i in layers)
    assert all(f"/graph/simulate/simulation/L{i:04d}/programmed" in names for i in layers)
    # the drawn simulated path spans the trace (display may decimate, never extend it)
    drawn = sum(
        viewer.server.scene.get_handle_by_name(f"/graph/simulate/simulation/L{i:04d}/simulated").points.shape[0]
        for i in layers
    )
    assert 0 < drawn <= len(sim.trace["t"]) - 1
    # the time slider spans the simulated cycle time and moves the torch onto the trace
    assert viewer._gui["time"].max == pytest.approx(float(sim.trace["t"][-1]))
    t_mid = float(sim.trace["t"][-1]) / 2
    viewer._gui["time"].value = round(t_mid, 2)
    torch = np.asarray(viewer.server.scene.get_handle_by_name("/graph/simulate/simulation/torch").position)
    pts = G.trace_points(sim.trace)
    assert np.linalg.norm(pts - torch, axis=1).min() < 1.0
    # colour by deviation spans the measured deviation's 2nd–98th percentile; the legend keeps the maximum
    part = viewer.parts[("simulate", "simulation")]
    lo, hi = part.ranges["deviation"]
    assert hi == pytest.approx(float(np.percentile(sim.trace["deviation"], 98)))
    assert part.full_ranges["deviation"][1] == pytest.approx(float(np.max(sim.trace["deviation"])))


def test_robot_follows_the_trace(viewer):
    recipe, out = run_recipe("rectangle-study")
    viewer.publish("rectangle-study", recipe, out)
    part = viewer.parts[("simulate", "simulation")]
    assert part.robot is not None, part.robot_note
    sim = out["simulate"]["simulation"]
    links = viewer.server.scene.get_handle_by_name("/graph/simulate/simulation/robot/links")
    n_links = links.points.shape[0]
    assert n_links >= 6  # a 6-axis arm: base → … → flange → TCP
    assert part.robot.reach_err.max() < 0.5  # TCP on the trace (REACH_TOL_MM)
    for frac in (0.25, 0.75):
        t = float(part.robot.t[int(frac * (len(part.robot.t) - 1))])
        viewer._gui["time"].value = t
        tcp = links.points[-1, 1]
        i = int(np.searchsorted(sim.trace["t"], t))
        want = [sim.trace[k][i] for k in ("x", "y", "z")]
        assert np.allclose(tcp, want, atol=0.05)  # float32 display, mm
        base = links.points[0, 0]
        assert np.allclose(base, part.robot.joints[0, 0], atol=1e-3)
        # the link geometry moves with the arm: the torch tube's far ring is centred on the TCP
        body = viewer.server.scene.get_handle_by_name("/graph/simulate/simulation/robot/body")
        assert body.vertices.shape == (2 * 12 * n_links, 3)
        assert np.allclose(body.vertices[-12:].mean(axis=0), tcp, atol=0.05)
    viewer._gui["robot"].value = False
    assert links.visible is False and body.visible is False


def test_zone_colours_match_the_parameter_xml(viewer):
    import defusedxml.ElementTree as ET

    from waamflow.viewer import colors as C

    recipe, out, files = run_recipe("mpp-cross", artifacts=True)
    xml = ET.fromstring(files["zone.params.xml"])
    viewer.publish("mpp-cross", recipe, out)
    tp = out["zone"]["toolpath"]
    checked = 0
    for layer_el in xml.iter("layer"):
        i = int(layer_el.get("index"))
        poly = G.layer_polyline(tp[i])
        disp = G.path_display(poly, 1 << 30)
        colors = viewer.server.scene.get_handle_by_name(f"/graph/zone/toolpath/L{i:04d}").colors[:, 0]
        for sec_el in layer_el.iter("section"):
            s_idx = disp.section_keys.index(sec_el.get("id"))
            for zone_el in sec_el.iter("zone"):
                m = (disp.section == s_idx) & (disp.zone == disp.zone_ids.index(zone_el.get("id"))) & ~disp.travel
                assert m.any()
                assert (colors[m] == C.hex_to_rgb(zone_el.get("color"))).all(), (i, sec_el.get("id"), zone_el.get("id"))
                checked += 1
    assert checked >= 8 * 3 * 2  # 8 layers × 3 sections × at least start/end
