"""Coordinated positioner + arm: 1-axis positioners, axis limits and speed caps reported per layer,
orientation continuity (no wrist flips), cell shapes (mesh, pose, link) in the collision checks."""

import json
import math

import numpy as np
import pytest

from waamflow.core.moves import Moves
from waamflow.trajectory.cell import Cell, load_cell, plan_positioner, positioner_caps, to_world
from waamflow.trajectory.profile import load_profile
from waamflow.trajectory.run import KinematicsOptions, simulate_program, simulation_json
from waamflow.trajectory.simulate import SimOptions

PROFILE = load_profile("kuka_kr100ha_krc2")


def _normal(tilt_x_deg=0.0, tilt_y_deg=0.0):
    """Layer normal tilted by tilt_x about x then tilt_y about y (deg)."""
    a, b = np.radians(tilt_x_deg), np.radians(tilt_y_deg)
    n = np.array([0.0, -np.sin(a), np.cos(a)])
    return np.array([n[0] * np.cos(b) + n[2] * np.sin(b), n[1], -n[0] * np.sin(b) + n[2] * np.cos(b)])


def _moves(normals, length=100.0, per_layer=5):
    """Straight 100 mm lines, one layer per normal, arc ON, 10 mm/s, joined by 20 mm travels."""
    pts, axes, layer, arc = [], [], [], []
    for L, n in enumerate(normals):
        for k in range(per_layer):
            pts.append([-length / 2 + k * length / (per_layer - 1), 0.0, 10.0 + 5 * L])
            axes.append(-n)
        layer += [L] * (per_layer - 1) + ([L + 1] if L < len(normals) - 1 else [])
        arc += [True] * (per_layer - 1) + ([False] if L < len(normals) - 1 else [])
    n = len(pts)
    arc = np.array(arc[: n - 1])
    return Moves(
        points=np.array(pts, float),
        tool_axis=np.array(axes, float),
        kind=arc.astype(np.int8),
        arc=arc,
        inside=arc.copy(),
        speed=np.where(arc, 10.0, np.nan),
        layer=np.array(layer[: n - 1]),
        section=np.zeros(n - 1, int),
        zone=np.where(arc, 0, -1),
        dwell_before=np.zeros(n),
        section_keys=("A",),
        zone_ids=("body",),
        zone_params={},
        layer_z={},
    )


def test_one_axis_positioner_turns_what_it_can():
    """kr150_tilt (a 1-axis tilter about x): a layer leaning 40° about x is turned flat (E1 = ±40°,
    torch straight down); a layer leaning 40° about x and then 20° about y keeps the lean of its
    x component, asin(cos 40°·sin 20°) = 15.19° — one axis cannot remove it; the angles have one
    column (E1 only)."""
    cell = load_cell("kr150_tilt")
    assert cell.axes == 1 and cell.fixed_angles().tolist() == [0.0]
    mv = _moves([_normal(40.0), _normal(40.0, 20.0)])
    ang, clipped = plan_positioner(cell, mv, "gravity")
    assert ang.shape == (len(mv.points), 1) and not clipped.any()
    assert abs(ang[0, 0]) == pytest.approx(40.0, abs=1e-6)
    _, w = to_world(cell, mv.points, mv.tool_axis, ang)
    assert w[:5] == pytest.approx(np.tile([0.0, 0.0, -1.0], (5, 1)), abs=1e-9)
    lean = np.degrees(np.arccos(-w[5:, 2]))
    assert lean == pytest.approx(
        math.degrees(math.asin(math.cos(math.radians(40)) * math.sin(math.radians(20)))), abs=1e-6
    )
    assert lean == pytest.approx(15.189, abs=1e-3)


def test_axis_limits_are_clipped_and_reported_per_layer():
    """A layer leaning 120° about x on the ±90° tilter: E1 clipped to 90° (the layer stays 30° off
    flat), reported as an `axis_limit` stretch naming layer 1 and E1; the per-axis table lists
    A1..A6 and E1 with their limits and speeds."""
    cell = load_cell("kr150_tilt")
    mv = _moves([_normal(0.0), _normal(120.0)])
    ang, clipped = plan_positioner(cell, mv, "gravity")
    assert abs(ang[-1, 0]) == pytest.approx(90.0, abs=1e-3) and clipped[-1] and not clipped[0]
    r = simulate_program(
        mv,
        PROFILE,
        SimOptions(),
        KinematicsOptions(
            description=cell.robot_urdf, tcp_offset_mm=tuple(cell.tool.tcp_mm), cell=cell, positioner_policy="gravity"
        ),
    )
    out = simulation_json(r, SimOptions())
    assert out["axis_limit_stretches"] == 1
    lim = [i for i in out["kinematics_issues"] if i["kind"] == "axis_limit"]
    assert lim[0]["layer"] == 1 and lim[0]["axes"] == ["E1"] and lim[0]["section"] == "A"
    axes = {a["axis"]: a for a in out["axes"]}
    assert list(axes) == ["A1", "A2", "A3", "A4", "A5", "A6", "E1"]
    assert axes["E1"]["upper_deg"] == pytest.approx(90.0, abs=1e-3)
    assert axes["E1"]["speed_limit_deg_s"] == pytest.approx(60.0, abs=1e-3)
    assert axes["E1"]["max_deg"] - axes["E1"]["min_deg"] == pytest.approx(90.0, abs=1e-3)
    assert any(w["layer"] == 1 and "positioner axis limit" in w["message"] for w in out["warnings"])


def test_positioner_speed_caps_the_path_and_is_reported():
    """Two layers whose normals differ by 60° about x, joined by a 20 mm travel: E1 (90°/s on the
    tilt/rotate positioner) needs 60/90 s, so the travel is capped to 20·90/60 = 30 mm/s —
    reported as an `axis_speed` stretch on layer 1 naming E1; a turn on a zero-length move
    becomes a standstill of 60/90 s."""
    cell = load_cell("kr150_tilt_rotate")
    mv = _moves([_normal(0.0), _normal(60.0)])
    ang, _ = plan_positioner(cell, mv, "gravity")
    cap, need = positioner_caps(cell, mv.points, ang)
    travel = int(np.flatnonzero(~mv.arc)[0])
    L = float(np.linalg.norm(mv.points[travel + 1] - mv.points[travel]))
    assert need[travel] == pytest.approx(60.0 / 90.0, rel=1e-4)
    assert cap[travel] == pytest.approx(L * 90.0 / 60.0, rel=1e-4)
    assert np.isinf(np.delete(cap, travel)).all()
    opt = SimOptions(travel_speed=200.0)
    r = simulate_program(
        mv,
        PROFILE,
        opt,
        KinematicsOptions(
            description=cell.robot_urdf, tcp_offset_mm=tuple(cell.tool.tcp_mm), cell=cell, positioner_policy="gravity"
        ),
    )
    out = simulation_json(r, opt)
    assert out["positioner_min_speed_cap_mm_s"] == pytest.approx(L * 1.5, rel=1e-4)
    sp = [i for i in out["kinematics_issues"] if i["kind"] == "axis_speed"]
    assert len(sp) == 1 and sp[0]["layer"] == 1 and sp[0]["axes"] == ["E1"]
    assert next(a for a in out["axes"] if a["axis"] == "E1")["peak_speed_deg_s"] == pytest.approx(90.0, rel=1e-3)
    # the same turn in place (the travel shrunk to nothing): a standstill the positioner needs
    pts = mv.points.copy()
    pts[travel + 1 :] -= pts[travel + 1] - pts[travel]
    inplace = Moves(**{**mv.__dict__, "points": pts})
    r2 = simulate_program(
        inplace,
        PROFILE,
        opt,
        KinematicsOptions(
            description=cell.robot_urdf, tcp_offset_mm=tuple(cell.tool.tcp_mm), cell=cell, positioner_policy="gravity"
        ),
    )
    assert r2.metrics["positioner_turn_in_place_s"] == pytest.approx(60.0 / 90.0, rel=1e-4)


@pytest.fixture(scope="module")
def duct_moves():
    from pathlib import Path

    from waamflow.core.moves import flatten
    from waamflow.engine.executor import FileResolver, execute
    from waamflow.engine.graph import build_graph
    from waamflow.engine.recipe import parse_recipe

    graphs = Path(__file__).resolve().parents[2] / "graphs"
    recipe = json.loads((graphs / "curved-duct.json").read_text())
    recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] not in ("post", "sim")]
    recipe["edges"] = [e for e in recipe["edges"] if not e["to"].startswith(("post.", "sim."))]
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(graphs))
    return flatten(res.outputs["bead"]["toolpath"])


WRIST_STEP_BOUND_DEG = 2.0  # per IK sample (samples ≤ 5 mm of path and ≤ 1° of positioner / torch turn)


@pytest.mark.parametrize("cell_name,policy", [("kr150_tilt_rotate", "min-motion"), ("irb4600_tilt_rotate", "gravity")])
def test_no_wrist_flip_on_the_duct(duct_moves, cell_name, policy):
    """Orientation continuity on curved-duct: A4, A5, A6 never move more than 2° between two
    consecutive IK samples, also across the arc-OFF travels where min-motion turns the part by
    up to ~50° (before coordinated sampling: 37° wrist steps there); still 0 unreachable and
    0 collisions."""
    cell = load_cell(cell_name)
    r = simulate_program(
        duct_moves,
        PROFILE,
        SimOptions(),
        KinematicsOptions(
            description=cell.robot_urdf, tcp_offset_mm=tuple(cell.tool.tcp_mm), cell=cell, positioner_policy=policy
        ),
    )
    q = r.kinematics["motion"]["q"]
    steps = np.degrees(np.abs(np.diff(q, axis=0)))
    assert steps[:, 3].max() < WRIST_STEP_BOUND_DEG and steps[:, 5].max() < WRIST_STEP_BOUND_DEG
    assert r.metrics["max_wrist_step_deg"] == pytest.approx(steps[:, 3:].max(), abs=1e-9)
    assert r.metrics["unreachable_stretches"] == 0 and r.metrics["collision_count"] == 0
    assert r.kinematics["motion"]["positioner_deg"].shape == (len(q), 2)
    if policy == "min-motion":  # the positioner really turns on short travels
        assert r.metrics["positioner_max_step_deg"] > 25 and r.metrics["axis_speed_stretches"] >= 1


def test_cell_shapes_mesh_pose_and_link(tmp_path):
    """Fixtures from the cell file: a mesh (STL beside the cell), a rotated box (rpy) and a
    clamp fixed to the positioner flange. A 40 mm cube mesh placed on the torch's path collides
    and is named; yawed 45° a long thin box clears the torch where unrotated it would not."""
    import trimesh

    from waamflow.trajectory.collide import cell_statics

    trimesh.creation.box(extents=(40.0, 40.0, 40.0)).export(tmp_path / "block.stl")
    data = json.loads(load_cell("kr150_tilt_rotate").model_dump_json())
    data["fixtures"].append(
        {
            "name": "block",
            "kind": "mesh",
            "mesh": "block.stl",
            "size_mm": [1, 1, 1],
            "xyz_mm": [0.0, 0.0, 60.0],
            "link": "table_top",
        }
    )
    cell = Cell.model_validate(data)
    cell.load_meshes(lambda name: (tmp_path / name).read_bytes())
    bodies = {b[0]: b[2] for b in cell_statics(cell)([30.0, 0.0])}
    assert {"positioner:table", "fixture:clamp_1", "fixture:block", "fixture:floor"} <= set(bodies)
    # the block turns with the flange: 60 mm above the table top, tilted 30° about x
    R, t = cell.link_pose([30.0, 0.0], "table_top")
    assert bodies["fixture:block"].getTranslation() * 1000 == pytest.approx(R @ [0, 0, 60.0] + t, abs=1e-6)
    assert bodies["fixture:floor"].getTranslation() * 1000 == pytest.approx([0, 0, -1720.0])
    mv = _moves([_normal(0.0)])
    r = simulate_program(
        mv,
        PROFILE,
        SimOptions(),
        KinematicsOptions(
            description=cell.robot_urdf, tcp_offset_mm=tuple(cell.tool.tcp_mm), cell=cell, positioner_policy="fixed"
        ),
    )
    hits = {tuple(c.bodies) for c in r.collisions}
    assert any(b[1] == "fixture:block" and b[0].startswith("torch:") for b in hits)
    # a 300 × 20 mm bar across the path at x = 0: unrotated (along y) it is hit, yawed 90° it lies along the path…
    bar = {"name": "bar", "kind": "box", "size_mm": [20.0, 300.0, 20.0], "xyz_mm": [0.0, 120.0, 20.0]}
    data["fixtures"][-1] = bar
    hit = simulate_program(
        mv,
        PROFILE,
        SimOptions(),
        KinematicsOptions(
            description=cell.robot_urdf,
            tcp_offset_mm=tuple(cell.tool.tcp_mm),
            cell=Cell.model_validate(data),
            positioner_policy="fixed",
        ),
    )
    assert any(c.bodies[1] == "fixture:bar" for c in hit.collisions)
    data["fixtures"][-1] = {**bar, "rpy_deg": [0.0, 0.0, 90.0], "xyz_mm": [0.0, 120.0, 20.0]}
    clear = simulate_program(
        mv,
        PROFILE,
        SimOptions(),
        KinematicsOptions(
            description=cell.robot_urdf,
            tcp_offset_mm=tuple(cell.tool.tcp_mm),
            cell=Cell.model_validate(data),
            positioner_policy="fixed",
        ),
    )
    assert not any(c.bodies[1] == "fixture:bar" for c in clear.collisions)
    bad = dict(data)
    bad["fixtures"] = [{"name": "x", "kind": "box", "size_mm": [1, 1, 1], "link": "no_such_link"}]
    with pytest.raises(Exception, match="no_such_link"):
        Cell.model_validate(bad)


def test_old_cells_get_the_table_they_had():
    """A cell written before the positioner carried shapes is migrated to the 300 mm table disc
    that collide.py used to hard-code; the catalog's cell schema has the new fields."""
    from waamflow.engine.node import load_nodes

    data = json.loads(load_cell("kr150_tilt_rotate").model_dump_json())
    del data["positioner"]["shapes"]
    cell = Cell.model_validate(data)
    assert [(s.name, s.kind, s.size_mm) for s in cell.positioner.shapes] == [
        ("table", "cylinder", (300.0, 300.0, 40.0))
    ]
    cs = load_nodes()["simulate-robot"].Params.model_json_schema()["properties"]["cell"]["x-cell-schema"]
    shape = cs["properties"]["fixtures"]["items"]["properties"]
    assert {"kind", "size_mm", "xyz_mm", "rpy_deg", "link", "mesh"} <= set(shape)
    assert set(shape["kind"]["enum"]) == {"box", "cylinder", "mesh"}
    assert "shapes" in cs["properties"]["positioner"]["anyOf"][0]["properties"]


def test_a_users_cell_file_and_its_meshes_are_in_the_cache_key(tmp_path):
    """simulate-robot reads a user's cell file and the meshes it names: `read_files` lists them
    (next to the cell file) so an edited fixture mesh recomputes the simulation."""
    from waamflow.engine.node import REGISTRY, load_nodes

    load_nodes()

    data = json.loads(load_cell("kr150_tilt_rotate").model_dump_json())
    data["fixtures"] += [
        {"name": "block", "kind": "mesh", "mesh": "block.stl", "size_mm": [1, 1, 1]},
        {"name": "jig", "kind": "mesh", "mesh": "jig.obj", "size_mm": [1, 1, 1]},
        {"name": "again", "kind": "mesh", "mesh": "block.stl", "size_mm": [2, 2, 2]},
    ]
    (tmp_path / "cells").mkdir()
    (tmp_path / "cells" / "mine.json").write_text(json.dumps(data))
    node = REGISTRY["simulate-robot"]()
    read = lambda p: (tmp_path / p).read_bytes() if (tmp_path / p).is_file() else None  # noqa: E731
    P = node.Params
    assert node.read_files(P(cell="cells/mine.json"), read) == ["cells/mine.json", "cells/block.stl", "cells/jig.obj"]
    assert node.read_files(P(cell="kr150_tilt_rotate"), read) == []  # shipped: in the code version
    assert node.read_files(P(cell="cells/mine.json", kinematics=False), read) == []
    assert node.read_files(P(cell="cells/missing.json"), read) == ["cells/missing.json"]
    (tmp_path / "cells" / "bad.json").write_text("{not json")
    assert node.read_files(P(cell="cells/bad.json"), read) == ["cells/bad.json"]
