"""The cell in 3D: arm, torch, positioner, table and fixtures replayed from a cell simulation,
the part frame following the positioner, unreachable stretches and collisions flagged."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "trajectory"))

from test_coordinated import PROFILE, _moves, _normal  # noqa: E402

from waamflow.trajectory.cell import Cell, load_cell  # noqa: E402
from waamflow.trajectory.run import KinematicsOptions, simulate_program  # noqa: E402
from waamflow.trajectory.simulate import SimOptions  # noqa: E402

RECIPE = {"format": "waamflow/1", "name": "cell-view", "nodes": [{"id": "sim", "type": "simulate-robot"}]}


def _simulate(cell):
    mv = _moves([_normal(0.0), _normal(60.0)])
    return simulate_program(
        mv,
        PROFILE,
        SimOptions(),
        KinematicsOptions(
            description=cell.robot_urdf, tcp_offset_mm=tuple(cell.tool.tcp_mm), cell=cell, positioner_policy="gravity"
        ),
    )


def _quat_angle(q1, q2) -> float:
    return float(np.degrees(2 * np.arccos(min(1.0, abs(float(np.dot(q1, q2)))))))


def test_the_cell_is_drawn_and_replayed(viewer):
    """Every cell body is drawn (torch on the flange, table and tilt frame turning, fixtures); at
    the end of the program the positioner stands at E1 = 60°: the table's and the part frame's
    (/graph) rotations are 60° about x, and the drawn TCP sits on the trace point carried into
    the world by that frame (< 0.5 mm) — the part follows the positioner during playback."""
    from waamflow.viewer.robot import CellMotion, wxyz

    cell = load_cell("kr150_tilt_rotate")
    res = _simulate(cell)
    viewer.publish("cell-view", RECIPE, {"sim": {"simulation": res}})
    part = viewer.parts[("sim", "simulation")]
    assert isinstance(part.robot, CellMotion) and part.robot_note == ""
    assert {
        "torch/torch_neck",
        "torch/torch_nozzle",
        "positioner/table",
        "positioner/tilt_cradle",
        "fixtures/clamp_1",
        "fixtures/positioner_pedestal_left",
    } <= set(part.cell_handles)
    m = part.robot
    for frac in (0.05, 1.0):
        t = frac * part.duration()
        viewer.set_view(time_s=t)
        i = m.index(t)
        e1 = float(m.angles[i, 0])
        R, tw = cell.work_pose(m.angles[i])
        assert _quat_angle(np.asarray(part.graph_frame.wxyz), wxyz(R)) < 1e-3
        assert part.graph_frame.position == pytest.approx(tuple(tw), abs=1e-6)
        table = part.cell_handles["positioner/table"][0]
        assert _quat_angle(np.asarray(table.wxyz), wxyz(cell.link_pose(m.angles[i])[0])) < 1e-3
        k = int(np.argmin(np.abs(res.trace["t"] - m.t[i])))
        p = np.array([res.trace[c][k] for c in "xyz"])
        assert np.linalg.norm(m.chain[i][-1] - (R @ p + tw)) < 0.5
        if frac == 1.0:
            assert abs(e1) == pytest.approx(60.0, abs=1e-6)
    assert viewer.state()["legend"][0]["robot"] == "kr150_tilt_rotate"
    viewer.publish("cell-view", RECIPE, {})  # gone: cell removed, part frame reset
    assert tuple(viewer._graph_frame.wxyz) == pytest.approx((1.0, 0.0, 0.0, 0.0))


def test_collisions_and_unreachable_stretches_are_flagged(viewer):
    """A block fixed to the table on the torch's path: the collision points are drawn on the
    part (in the part frame, where the simulation found them); the robot moved out of reach:
    the unreachable stretches are drawn in red over the programmed path."""
    data = json.loads(load_cell("kr150_tilt_rotate").model_dump_json())
    data["fixtures"].append(
        {"name": "block", "kind": "box", "size_mm": [40, 40, 40], "xyz_mm": [0, 0, 60], "link": "table_top"}
    )
    res = _simulate(Cell.model_validate(data))
    assert res.metrics["collision_count"] > 0
    viewer.publish("cell-view", RECIPE, {"sim": {"simulation": res}})
    part = viewer.parts[("sim", "simulation")]
    assert "collisions" in part.robot_handles
    pts = np.asarray(part.robot_handles["collisions"].points)
    assert len(pts) == len(res.collisions)
    assert np.abs(pts[:, :2]).max() < 80 and pts[:, 2].max() < 120  # on the block, above the table
    data = json.loads(load_cell("kr150_tilt_rotate").model_dump_json())
    data["robot_base"]["xyz_mm"] = [-3300.0, 0.0, -600.0]
    far = _simulate(Cell.model_validate(data))
    assert far.metrics["unreachable_stretches"] >= 1
    viewer.publish("cell-view", RECIPE, {"sim": {"simulation": far}})
    part = viewer.parts[("sim", "simulation")]
    segs = np.asarray(part.robot_handles["unreachable"].points)
    assert len(segs) >= 1 and segs.shape[1:] == (2, 3)


def test_fit_frames_the_part_where_the_positioner_holds_it(viewer):
    """Issue 25, fault 9: at 75 % playback the positioner has tilted the part; "fit part" looks
    at the part's centre in the world at that time (not at its centre in the part frame), from the
    side away from the robot (the torch stands behind the part, not in front of it); "fit cell"
    frames part + arm + positioner from farther away."""
    cell = load_cell("kr150_tilt_rotate")
    res = _simulate(cell)
    viewer.publish("cell-view", RECIPE, {"sim": {"simulation": res}})
    part = viewer.parts[("sim", "simulation")]
    t = 0.75 * part.duration()
    viewer.set_view(time_s=t, fit="part")
    R, tw = part.work_pose(t)
    b = viewer.part_bounds()
    corners = np.array([[x, y, z] for x in b[:, 0] for y in b[:, 1] for z in b[:, 2]]) @ R.T + tw
    world_center = (corners.min(axis=0) + corners.max(axis=0)) / 2
    cam = viewer.server.initial_camera
    look, eye = np.asarray(cam.look_at), np.asarray(cam.position)
    assert np.linalg.norm(look - world_center) < 1.0
    assert np.linalg.norm(world_center - (b[0] + b[1]) / 2) > 50.0  # the tilt moved the part
    radius = np.linalg.norm(corners.max(axis=0) - corners.min(axis=0)) / 2
    part_dist = float(np.linalg.norm(eye - look))
    assert 1.5 * radius < part_dist < 3.0 * radius  # the part fills the view
    base = part.robot_base()
    assert np.dot((eye - look)[:2], (look - base)[:2]) > 0  # looking from beyond the part
    # above the part's (tilted) table plane, never looking at the part through the table
    assert np.dot(eye - look, R[:, 2]) > 0.5 * part_dist
    viewer.set_view(time_s=part.duration(), fit="part")
    R1 = part.work_pose(part.duration())[0]
    assert np.dot(np.asarray(cam.position) - np.asarray(cam.look_at), R1[:, 2]) > 0.5 * np.linalg.norm(
        np.asarray(cam.position) - np.asarray(cam.look_at)
    )
    viewer.set_view(time_s=t)
    viewer.set_view(fit="cell")
    cell_dist = float(np.linalg.norm(np.asarray(cam.position) - np.asarray(cam.look_at)))
    pts = np.vstack(part.cell_points(t))
    assert cell_dist > 2 * part_dist
    assert np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)) / 2 < cell_dist  # the arm is in view
