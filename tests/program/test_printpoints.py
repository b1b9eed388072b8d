"""compas_slicer-style print points: one entry per toolpath sample with compas_slicer's keys,
layer heights per layer (planar and fan layers), frames orthonormal, speeds/dwells/blends from
the program plan."""

import json
import math

import numpy as np
import pytest
from conftest import build_toolpath

from waamflow.core.model import Layer, LayerPaths, Layered
from waamflow.core.moves import flatten
from waamflow.engine.node import load_nodes
from waamflow.program import PlanSettings, post_process

COMPAS_KEYS = [
    "point",
    "layer_height",
    "mesh_normal",
    "up_vector",
    "frame",
    "extruder_toggle",
    "velocity",
    "wait_time",
    "blend_radius",
    "closest_support_pt",
    "distance_to_support",
    "is_feasible",
    "attributes",
]


def _pp(toolpath, blend=1.0, travel=100.0):
    prog = post_process(toolpath, "printpoints", PlanSettings(travel_speed=travel), blend)
    return prog, json.loads(prog.files["printpoints.json"])


def test_one_entry_per_toolpath_sample_with_compas_slicer_keys():
    tp = build_toolpath(3)
    moves = flatten(tp)
    prog, pp = _pp(tp)
    assert len(pp) == len(moves.points) == prog.stats["points"] == 3 * (9 + 25 + 12 + 1)  # + bs1/B's approach point
    assert list(pp) == [str(i) for i in range(len(pp))]  # compas: flat, by count
    for v in pp.values():
        assert list(v)[: len(COMPAS_KEYS)] == COMPAS_KEYS and set(v["frame"]) == {"point", "xaxis", "yaxis"}
    pts = np.array([v["point"] for v in pp.values()])
    assert np.allclose(pts, moves.points, atol=1e-4)
    assert [v["layer"] for v in pp.values()].count(2) == 9 + 25 + 12 + 1  # layer 2's samples
    assert {v["section"] for v in pp.values()} == {"bs1/A", "bs1/B", "bs1/C"}


def printed_segments(pp: dict) -> list[bool]:
    """Segment i → i+1 printed or not, by compas_slicer's own rule (its Grasshopper
    `lightweight_path_visualization` and `render_path_visualization`: a pipe from point i to
    i+1 where `extruder_toggle[i]`; `set_extruder_toggle` gives a path's points True and its
    last one False; `set_wait_time` puts the wait where the toggle turns True)."""
    v = list(pp.values())
    return [bool(v[i]["extruder_toggle"]) for i in range(len(v) - 1)]


def test_the_extruder_toggle_is_the_motion_leaving_the_point_as_compas_slicer_reads_it():
    """A driver or viewer written for compas_slicer welds segment i → i+1 where point i's toggle is
    true. The toggle was the motion *arriving* at the point: read by compas_slicer's rule, every
    run lost its first segment and welded the travel after its last point (on this toolpath 29
    of its 140 segments: 15 first segments not welded, 14 travels welded)."""
    tp = build_toolpath(3)
    moves = flatten(tp)
    _, pp = _pp(tp)
    v = list(pp.values())
    assert printed_segments(pp) == moves.arc.tolist()
    assert v[-1]["extruder_toggle"] is False  # the program ends with the arc off
    starts = [i for i in range(len(v)) if v[i]["extruder_toggle"] and (i == 0 or not v[i - 1]["extruder_toggle"])]
    ends = [i for i in range(1, len(v)) if v[i - 1]["extruder_toggle"] and not v[i]["extruder_toggle"]]
    assert len(starts) == len(ends) == 3 * 5  # per layer: bs1/A, bs1/B, the three passes of bs1/C
    # a run's points: its start (toggle on, the arc ignites there) to its end (toggle off)
    for a, b in zip(starts, ends):
        assert all(v[k]["extruder_toggle"] for k in range(a, b)) and moves.arc[a:b].all()


def test_speeds_waits_and_blends_follow_the_plan():
    tp = build_toolpath(2, dwell=20.0)
    prog, pp = _pp(tp, blend=2.5, travel=80.0)
    v = list(pp.values())
    moves = flatten(tp)
    on = [x["extruder_toggle"] for x in v]
    # velocity: of the motion arriving at the point (a robot target's speed, compas_rrc's MoveToFrame)
    weld = [x["velocity"] for x, seg_arc in zip(v[1:], moves.arc) if seg_arc]
    assert set(weld) == {5.0, 6.0, 7.0}  # the zones' speeds
    travel = [x["velocity"] for x, seg_kind in zip(v[1:], moves.kind) if seg_kind == 0]
    assert travel and set(travel) == {80.0}
    assert sum(x["wait_time"] for x in v) == pytest.approx(prog.stats["dwell_total_s"])
    # each wait where the arc is as the plan has it: an ignition dwell (0.8 s at `start`) at the run's
    # first point, toggle on; the interlayer dwell (20 s, arc off) at the point before, toggle off
    # (one wait of 20.8 s at the run's start had the torch stand 20.8 s with the arc on)
    waits = {i: x["wait_time"] for i, x in enumerate(v) if x["wait_time"] > 0}
    long = [i for i, w in waits.items() if w == pytest.approx(20.0)]
    assert len(long) == 1 and on[long[0]] is False and on[long[0] + 1] is True
    assert waits[long[0] + 1] == pytest.approx(0.8)
    for i, w in waits.items():
        assert on[i] is (w != pytest.approx(20.0)), (i, w)  # every other wait is an arc-on dwell
    blends = [x["blend_radius"] for x in v]
    assert set(blends) == {0.0, 2.5} and blends[-1] == 0.0
    # exact stop where the arc switches and wherever the torch waits
    switches = [i for i in range(1, len(v)) if on[i] != on[i - 1]]
    assert len(switches) >= 8 and all(v[k]["blend_radius"] == 0.0 for k in switches)
    assert all(v[k]["blend_radius"] == 0.0 for k in waits)


def test_frames_are_orthonormal_and_up_is_the_reversed_tool_axis():
    tp = build_toolpath(1)
    _, pp = _pp(tp)
    moves = flatten(tp)
    for i, x in enumerate(pp.values()):
        up, n = np.array(x["up_vector"]), np.array(x["mesh_normal"])
        xa, ya = np.array(x["frame"]["xaxis"]), np.array(x["frame"]["yaxis"])
        t = np.array(x["attributes"]["tangent"])
        assert np.allclose(up, -moves.tool_axis[i], atol=1e-4)
        for a in (up, n, xa, t):
            assert np.linalg.norm(a) == pytest.approx(1.0, abs=1e-3)
        assert abs(up @ n) < 1e-3 and abs(t @ n) < 1e-3 and abs(t @ up) < 1e-3
        assert np.allclose(ya, n) and np.allclose(xa, np.cross(up, n), atol=1e-3)
    # on the straight wall along +x the tangent is +x and the normal (up × tangent) is +y
    first_wall = pp["1"]
    assert np.allclose(first_wall["attributes"]["tangent"], [1, 0, 0]) and np.allclose(
        first_wall["mesh_normal"], [0, 1, 0]
    )


def test_layer_heights_per_layer_planar():
    tp = build_toolpath(3)
    thick = (2.0, 1.5, 1.2)
    items = tuple(
        LayerPaths(Layer(lp.index, lp.layer.z, thick[lp.index]), lp.sections, lp.dwell_after_s) for lp in tp.items
    )
    _, pp = _pp(Layered(items))
    by_layer = {}
    for x in pp.values():
        by_layer.setdefault(x["layer"], set()).add(x["layer_height"])
    assert by_layer == {0: {2.0}, 1: {1.5}, 2: {1.2}}


def test_layer_heights_on_fan_layers_are_r_dtheta():
    dth = math.radians(1.5)
    layers = []
    for k in range(2):
        th = dth * (k + 1)
        # layer-local x = radius from the bend axis (y = 0 at the axis), frame rotates about world y
        frame = np.eye(4)
        frame[:3, :3] = [[math.cos(th), 0, 0], [0, 1, 0], [math.sin(th), 0, 0]]
        frame[:3, 0] = [math.cos(th), 0, math.sin(th)]
        frame[:3, 1] = [0, 1, 0]
        frame[:3, 2] = [-math.sin(th), 0, math.cos(th)]
        from shapely.geometry import box

        region = box(80.0, -10.0, 120.0, 10.0)
        layer = Layer(k, 100.0 * th, 100.0 * dth, region=region, frame=frame)
        xy = np.array([[85.0, 0.0], [100.0, 0.0], [115.0, 0.0]])
        pts = layer.to_world(xy)
        from waamflow.core.model import SectionPath

        sp = SectionPath("ring", "test", pts, np.ones(2, bool), np.ones(2, bool), np.full(2, 10.0), zone=("z1", "z1"))
        layers.append(LayerPaths(layer, (sp,)))
    _, pp = _pp(Layered(tuple(layers)))
    heights = [x["layer_height"] for x in pp.values()]
    assert heights[:3] == pytest.approx([85 * dth, 100 * dth, 115 * dth], abs=1e-4)
    assert heights[-1] == pytest.approx(115 * dth, abs=1e-4)


def test_post_process_node_writes_printpoints_artifact():
    node_cls = load_nodes()["post-process"]
    p = node_cls.Params(format="printpoints", blend_distance=0.0)

    class Ctx:
        warnings: list = []

        def warn(self, m):
            self.warnings.append(m)

    node = node_cls()
    out = node.run(Ctx(), p, {"toolpath": build_toolpath(2)})
    files = node.artifacts(Ctx(), p, out)
    assert list(files) == ["printpoints.json"] and out["program"].main_suffix == "printpoints.json"
    pp = json.loads(files["printpoints.json"])
    assert len(pp) == out["program"].stats["points"] and {x["blend_radius"] for x in pp.values()} == {0.0}


def test_mpp_cross_print_points_with_vertical_retracts():
    """The shipped cross (retract moves straight up and down): one entry per sample, unit frames
    everywhere, 1.5 mm on every layer, arc-on velocities = the XML's zone speeds."""
    from pathlib import Path

    from waamflow.engine.executor import FileResolver, execute
    from waamflow.engine.graph import build_graph
    from waamflow.engine.recipe import parse_recipe

    graphs = Path(__file__).resolve().parents[2] / "graphs"
    recipe = json.loads((graphs / "mpp-cross.json").read_text())
    next(n for n in recipe["nodes"] if n["id"] == "post")["params"]["format"] = "printpoints"
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(graphs))
    pp = json.loads(res.artifacts["post.printpoints.json"])
    moves = flatten(res.outputs["sequence"]["toolpath"])
    assert len(pp) == len(moves.points) == res.summary("mpp-cross")["programs"]["post"]["points"]
    vertical = np.flatnonzero(np.linalg.norm(np.diff(moves.points, axis=0)[:, :2], axis=1) < 1e-9) + 1
    assert len(vertical) >= 20  # retracts up and approaches down
    for x in pp.values():
        up, n, t = (np.array(v) for v in (x["up_vector"], x["mesh_normal"], x["attributes"]["tangent"]))
        assert np.linalg.norm(n) == pytest.approx(1, abs=1e-3) and np.linalg.norm(t) == pytest.approx(1, abs=1e-3)
        assert abs(n @ up) < 1e-3 and abs(t @ up) < 1e-3
    assert {x["layer_height"] for x in pp.values()} == {1.5}
    v = list(pp.values())
    assert {v[i + 1]["velocity"] for i in range(len(v) - 1) if v[i]["extruder_toggle"]} == {6.0, 8.0, 4.0}


def test_a_wait_print_points_cannot_place_fails_loudly():
    """An arc-off dwell at the program's first point where the arc ignites: no point before it
    has the arc off to wait at, and waiting there would stand with the arc on."""
    import dataclasses

    from waamflow.core.errors import PlanningError
    from waamflow.program.plan import Dwell, plan_program
    from waamflow.program.printpoints import print_points

    plan = plan_program(flatten(build_toolpath(1)))
    first_on = int(np.flatnonzero(plan.moves.arc)[0])
    assert first_on == 0  # the wall ignites at the first point
    bad = dataclasses.replace(plan, steps=(Dwell(0, 30.0, "interlayer"),) + tuple(plan.steps))
    with pytest.raises(PlanningError, match=r"interlayer dwell of 30 s at point 0 \(arc off\)"):
        print_points(bad, np.full(len(plan.moves.points), 1.5), 100.0, 1.0)
    assert print_points(plan, np.full(len(plan.moves.points), 1.5), 100.0, 1.0)["0"]["extruder_toggle"] is True
