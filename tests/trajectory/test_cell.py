"""Cell description files: shipped cells, frames from positioner angles, simulate-robot's `cell`."""

import json

import numpy as np
import pytest

from waamflow.core.errors import InputFileError
from waamflow.trajectory.cell import Cell, load_cell, shipped_cells
from waamflow.trajectory.kinematics import CellFrames, load_arm, solve_path

from .test_nodes import run

KR = load_cell("kr150_tilt_rotate")


def test_shipped_cell_at_home_matches_the_arm_only_setup():
    assert "kr150_tilt_rotate" in shipped_cells()
    f = KR.frames()
    assert f.base_xyz_mm == (-1500.0, 0.0, -600.0)
    assert f.work_xyz_mm == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)
    assert np.asarray(f.work_rot) == pytest.approx(np.eye(3), abs=1e-12)


def test_positioner_angles_turn_and_move_the_work_frame():
    """E1 tilt 90° about x at 0.8 m above the positioner base, table top 0.1 m above the axis:
    the part's z becomes world −y and its origin moves to (0, −100, −100) mm."""
    f = KR.frames([90.0, 0.0])
    R = np.asarray(f.work_rot)
    assert R @ [0, 0, 1] == pytest.approx([0, -1, 0], abs=1e-9)
    assert f.work_xyz_mm == pytest.approx((0.0, -100.0, -100.0), abs=1e-6)
    R2 = np.asarray(KR.frames([0.0, 90.0]).work_rot)  # E2 turns the table about z
    assert R2 @ [1, 0, 0] == pytest.approx([0, 1, 0], abs=1e-9)
    with pytest.raises(InputFileError, match="outside the axis limits"):
        KR.frames([170.0, 0.0])


def test_ik_in_a_tilted_frame_reaches_the_turned_points():
    """A 100 mm line on the table solved with the part tilted by 30°: IK residual < 0.01 mm and the
    same result as the equivalent points given directly in the world frame."""
    pts = np.array([[0.0, -50.0, 20.0], [0.0, 50.0, 20.0]])
    axis = np.tile([0.0, 0.0, -1.0], (2, 1))
    arm = load_arm(KR.robot_urdf, KR.tool.tcp_mm)
    f = KR.frames([30.0, 0.0])
    a = solve_path(arm, pts, axis, f, step_mm=10.0)
    R, t = np.asarray(f.work_rot), np.asarray(f.work_xyz_mm)
    b = solve_path(arm, pts @ R.T + t, axis @ R.T, CellFrames(base_xyz_mm=f.base_xyz_mm), step_mm=10.0)
    assert a.reach_err.max() < 0.01
    assert a.q == pytest.approx(b.q, abs=1e-9)


def test_bad_cells_name_the_field():
    with pytest.raises(InputFileError, match="not found"):
        load_cell("no_such_cell")
    data = json.loads(KR.model_dump_json())
    data["tool"]["tcp_mm"] = [0, 0]
    with pytest.raises(InputFileError, match="tool.tcp_mm"):
        load_cell("mine.json", text=json.dumps(data))
    data = json.loads(KR.model_dump_json())
    data["positioner"]["urdf"] = "nope.urdf"
    with pytest.raises(InputFileError, match="positioner description"):
        Cell.model_validate(data).frames()


def test_simulate_robot_with_a_cell_file(tmp_path):
    data = json.loads(KR.model_dump_json())
    data["positioner"]["fixed_deg"] = [0.0, 45.0]
    (tmp_path / "mycell.json").write_text(json.dumps(data))
    r = run(
        [{"id": "sim", "type": "simulate-robot", "params": {"cell": "mycell.json", "positioner_policy": "fixed"}}],
        [("strategy.toolpath", "sim.toolpath")],
        base_dir=str(tmp_path),
    )
    sim = json.loads(r.artifacts["sim.simulation.json"])
    assert sim["ik_max_position_error_mm"] < 0.01 and sim["unreachable_stretches"] == 0
    data["robot_base"]["xyz_mm"] = [-4000.0, 0.0, -600.0]  # out of reach: warns as before
    (tmp_path / "far.json").write_text(json.dumps(data))
    r = run(
        [{"id": "sim", "type": "simulate-robot", "params": {"cell": "far.json", "positioner_policy": "fixed"}}],
        [("strategy.toolpath", "sim.toolpath")],
        base_dir=str(tmp_path),
    )
    assert json.loads(r.artifacts["sim.simulation.json"])["unreachable_stretches"] >= 1


def test_gravity_policy_turns_each_layer_flat():
    """Two layers with torch axes tilted 40° towards −x and 70° towards +y (in the part frame):
    after the gravity angles every axis points straight down in the world; the positioner only
    moves on the travel between the layers."""
    from types import SimpleNamespace

    from waamflow.trajectory.cell import positioner_angles, to_world

    def axis(tilt, az):  # torch → part: −(layer normal tilted by `tilt` towards azimuth `az`)
        t, a = np.radians(tilt), np.radians(az)
        return -np.array([np.sin(t) * np.cos(a), np.sin(t) * np.sin(a), np.cos(t)])

    pts = np.array([[0, 0, 0], [10, 0, 0], [20, 0, 0], [20, 10, 5], [30, 10, 5], [40, 10, 5]], float)
    axes = np.array([axis(40, 180)] * 3 + [axis(70, 90)] * 3)
    mv = SimpleNamespace(
        points=pts, tool_axis=axes, layer=np.array([0, 0, 1, 1, 1]), arc=np.array([True, True, False, True, True])
    )
    ang = positioner_angles(KR, mv, "gravity")
    assert ang[:3, 0] == pytest.approx(40.0) and ang[3:, 0] == pytest.approx(70.0)
    assert np.abs(np.diff(ang[:3], axis=0)).max() == 0 and np.abs(np.diff(ang[3:], axis=0)).max() == 0
    _, w = to_world(KR, pts, axes, ang)
    assert w == pytest.approx(np.tile([0, 0, -1.0], (6, 1)), abs=1e-9)
    assert positioner_angles(KR, mv, "fixed") == pytest.approx(np.zeros((6, 2)))
    with pytest.raises(InputFileError, match="positioner policy"):
        positioner_angles(KR, mv, "wobble")


def test_abb_cell_builds_the_duct_with_the_gravity_policy():
    """The ABB IRB 4600-class cell (numbers from ABB's product specification, cited in the cell and
    URDF): curved-duct is fully reachable with `gravity`, not with the positioner held at 0°."""
    from pathlib import Path

    from waamflow.engine.executor import FileResolver, execute
    from waamflow.engine.graph import build_graph
    from waamflow.engine.recipe import parse_recipe

    graphs = Path(__file__).resolve().parents[2] / "graphs"

    def run_recipe(mutate):
        recipe = json.loads((graphs / "curved-duct.json").read_text())
        mutate(recipe)
        return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(graphs))

    abb = load_cell("irb4600_tilt_rotate")
    assert "3HAC032885" in abb.source and abb.robot_home_deg == [0.0, 0.0, 0.0, 0.0, 90.0, 0.0]

    def on_abb(policy):
        def mutate(recipe):
            recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] != "post"]
            recipe["edges"] = [
                e for e in recipe["edges"] if not (e["to"].startswith("post.") or e["from"].startswith("post."))
            ]
            sim = next(n for n in recipe["nodes"] if n["id"] == "sim")["params"]
            sim.update({"cell": "irb4600_tilt_rotate", "positioner_policy": policy})

        return json.loads(run_recipe(mutate).artifacts["sim.simulation.json"])

    good = on_abb("gravity")
    assert good["unreachable_stretches"] == 0 and good["joint_limit_stretches"] == 0
    assert good["near_singular_stretches"] == 0 and good["ik_max_position_error_mm"] < 0.01
    assert good["positioner_e1_max_deg"] == pytest.approx(89.32, abs=0.01)
    assert on_abb("fixed")["unreachable_stretches"] >= 1


def test_collisions_duct_clear_and_a_sunk_part_collides():
    """coal checks along the solved path: curved-duct on the KUKA cell (gravity) has none; the same
    part with its work frame sunk 30 mm into the positioner table collides, and the report names
    the layer, the section and the bodies (torch vs table)."""
    from pathlib import Path

    from waamflow.core.moves import flatten
    from waamflow.engine.executor import FileResolver, execute
    from waamflow.engine.graph import build_graph
    from waamflow.engine.recipe import parse_recipe
    from waamflow.trajectory.profile import load_profile
    from waamflow.trajectory.run import KinematicsOptions, simulate_program, simulation_json
    from waamflow.trajectory.simulate import SimOptions

    graphs = Path(__file__).resolve().parents[2] / "graphs"
    recipe = json.loads((graphs / "curved-duct.json").read_text())
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(graphs))
    sim = json.loads(res.artifacts["sim.simulation.json"])
    assert sim["collision_count"] == 0 and sim["collisions"] == []
    assert sim["collision_samples_checked"] > 58  # at least one per layer
    mv = flatten(res.outputs["bead"]["toolpath"])
    data = json.loads(KR.model_dump_json())
    data["work_frame"]["xyz_mm"] = [0.0, 0.0, -30.0]
    sunk = Cell.model_validate(data)
    prof = load_profile("kuka_kr100ha_krc2")
    r = simulate_program(
        mv,
        prof,
        SimOptions(),
        KinematicsOptions(
            description=sunk.robot_urdf, tcp_offset_mm=tuple(sunk.tool.tcp_mm), cell=sunk, positioner_policy="gravity"
        ),
    )
    out = simulation_json(r, SimOptions())
    assert out["collision_count"] > 0
    first = out["collisions"][0]
    assert first["layer"] == 0 and first["section"] == mv.section_keys[0]
    assert first["bodies"][0].startswith("torch:") and first["bodies"][1] == "positioner:table"
    assert any("collision torch:" in w["message"] and w["layer"] == 0 for w in out["warnings"])


def test_min_motion_holds_the_positioner_while_the_torch_may_lean():
    """Layers whose normals lean 20°, 50°, 70° towards −x: with a 30° tolerance the first layer is
    welded at home (20° lean), the second turns to its gravity angles (50°), the third keeps them
    (20° lean again); `gravity` moves on every layer."""
    from types import SimpleNamespace

    from waamflow.trajectory.cell import positioner_angles

    def axis(tilt):
        t = np.radians(tilt)
        return -np.array([-np.sin(t), 0.0, np.cos(t)])

    pts = np.array([[i * 10.0, 0, 0] for i in range(9)])
    axes = np.array([axis(20)] * 3 + [axis(50)] * 3 + [axis(70)] * 3)
    mv = SimpleNamespace(
        points=pts,
        tool_axis=axes,
        layer=np.repeat([0, 1, 2], [3, 3, 2]),
        arc=np.array([True, True, False, True, True, False, True, True]),
    )
    mm = positioner_angles(KR, mv, "min-motion", 30.0)
    assert mm[:3] == pytest.approx(np.zeros((3, 2)))
    assert mm[3:, 0] == pytest.approx(50.0) and mm[6:, 0] == pytest.approx(50.0)
    g = positioner_angles(KR, mv, "gravity")
    assert g[6:, 0] == pytest.approx(70.0) and g[:3, 0] == pytest.approx(20.0)
    wide = positioner_angles(KR, mv, "min-motion", 60.0)  # 20°, 50° tolerated; 70° not
    assert wide[:6] == pytest.approx(np.zeros((6, 2))) and wide[6:, 0] == pytest.approx(70.0)


def test_the_catalog_shows_the_cell_schema():
    from waamflow.engine.node import REGISTRY

    schema = REGISTRY["simulate-robot"].Params.model_json_schema()
    cs = schema["properties"]["cell"]["x-cell-schema"]
    assert {"robot_urdf", "robot_base", "tool", "positioner", "work_frame", "fixtures"} <= set(cs["properties"])
    assert "$ref" not in json.dumps(cs)
