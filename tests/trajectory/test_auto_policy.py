"""Positioner policy `auto` (trajectory.cellplan): per-layer positioner angles and torch lean
verified with the arm's IK and the coal checks; failures name the layer, the best compromise and
cell changes that were verified to work."""

import json
from pathlib import Path

import numpy as np
import pytest

from waamflow.core.errors import PlanningError
from waamflow.core.moves import flatten
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.trajectory.cell import Cell, load_cell, plan_positioner
from waamflow.trajectory.cellplan import AutoLimits, modified_cell, plan_auto
from waamflow.trajectory.kinematics import load_arm
from waamflow.trajectory.profile import load_profile
from waamflow.trajectory.run import KinematicsOptions, simulate_program, simulation_json
from waamflow.trajectory.simulate import SimOptions

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"
PROFILE = load_profile("kuka_kr100ha_krc2")
TUBE_OUTER_MM = 15.0 + 2.5  # the duct recipe's tube: mid radius 15 mm, 5 mm wall


def _toolpath(part_dir=GRAPHS, mutate=None):
    """The curved-duct recipe's toolpath (fan-slice → wall-path → bead-model), without its
    post-process and simulation."""
    recipe = json.loads((GRAPHS / "curved-duct.json").read_text())
    recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] not in ("post", "sim")]
    recipe["edges"] = [e for e in recipe["edges"] if not ({e["from"][:4], e["to"][:4]} & {"post", "sim."})]
    if mutate:
        mutate(recipe)
    r = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(part_dir))
    return flatten(r.outputs["bead"]["toolpath"])


def _bend(tmp_path, sweep, dtheta):
    """A bend of `sweep` deg at bend radius 1.2 × the tube's outer radius, built with the duct
    recipe's curved-part inputs (the fan about the bend axis; the bead range is opened: such a
    tight bend needs heights far outside the 316L model, which is not what is tested here)."""
    import trimesh

    from waamflow.curved.shapes import bent_tube

    bend = 1.2 * TUBE_OUTER_MM
    part = bent_tube(bend=bend, mid=15.0, wall=5.0, sweep_deg=sweep, n_phi=int(sweep / 2), n_psi=24)
    (tmp_path / "parts").mkdir(exist_ok=True)
    trimesh.Trimesh(part.vertices, part.faces, process=True).export(tmp_path / "parts" / "duct.stl")

    def mutate(recipe):
        recipe["inputs"]["dtheta_deg"] = dtheta
        fan = next(n for n in recipe["nodes"] if n["id"] == "fan")["params"]
        fan.update({"axis_point": [-bend, 0, 0], "h_min": 0.1, "h_max": 8.0})

    return _toolpath(tmp_path, mutate)


def _sim(cell, moves, policy="auto", **kw):
    kin = KinematicsOptions(
        description=cell.robot_urdf, tcp_offset_mm=tuple(cell.tool.tcp_mm), cell=cell, positioner_policy=policy, **kw
    )
    return simulation_json(simulate_program(moves, PROFILE, SimOptions(), kin), SimOptions())


def _arm(cell):
    return load_arm(cell.robot_urdf, tuple(cell.tool.tcp_mm), home_deg=cell.robot_home_deg)


@pytest.fixture(scope="module")
def duct():
    return _toolpath()


def test_auto_takes_the_gravity_angles_where_they_work(duct):
    """The shipped duct on kr150_tilt_rotate: every layer passes with its gravity angles (58 rows,
    stage gravity, tilt 0), the angles equal the gravity policy's, the torch axes are untouched,
    and the simulation reports the plan and stays clean."""
    cell = load_cell("kr150_tilt_rotate")
    ang, clipped = plan_positioner(cell, duct, "auto")
    grav, _ = plan_positioner(cell, duct, "gravity")
    assert not clipped.any()
    assert np.abs(ang - grav).max() < 1e-6
    sim = _sim(cell, duct)
    plan = sim["positioner_plan"]
    assert plan["ok"] is True and len(plan["layers"]) == 58
    assert {r["stage"] for r in plan["layers"]} == {"gravity"}
    assert max(r["tilt_deg"] for r in plan["layers"]) < 1e-3
    assert plan["layers"][57]["e_deg"][0] == pytest.approx(58 * 1.54, abs=0.01)
    assert sim["collision_count"] == 0 and sim["unreachable_stretches"] == 0
    assert sim["joint_limit_stretches"] == 0 and sim["near_singular_stretches"] == 0


def test_one_axis_cell_names_the_lean_it_cannot_remove(duct):
    """kr150_tilt tilts about x only; the duct bends about y: `auto` fails on layer 3 (the first
    past the 5° flat tolerance) naming layers 3..57 and the 89.3° lean left on layer 57, and the
    verified ways out: the part turned 90° on the table, or the shipped 2-axis cell. Under
    `gravity` the simulation warns with the same lean. The 2-axis suggestion really works."""
    cell = load_cell("kr150_tilt")
    with pytest.raises(PlanningError) as e:
        _sim(cell, duct)
    err = e.value
    assert err.exit_code == 3 and err.layer == 3
    assert "cannot turn layers 3..57 within 5° of flat" in err.message and "89.3°" in err.message
    assert "kr150_tilt_rotate" in err.message and "turn the part +90°" in err.message
    plan = plan_auto(cell, duct, _arm(cell))
    assert plan.failed["lean_deg"] == pytest.approx(58 * 1.54, abs=0.01) and plan.failed["worst_layer"] == 57
    assert [s["change"] for s in plan.suggestions] == ["turn the part on the table", "2-axis positioner"]
    sim = _sim(cell, duct, "gravity")
    lean = [w for w in sim["warnings"] if "off flat" in w["message"]]
    assert len(lean) == 1 and "layers 3..57 up to 89.3° off flat" in lean[0]["message"]
    turned = Cell.model_validate(modified_cell(json.loads(cell.model_dump_json()), plan.suggestions[0], duct))
    assert plan_auto(turned, duct, _arm(turned), suggest=False).ok


def test_positioner_too_close_fails_naming_the_layer_and_a_verified_change(duct, tmp_path):
    """The robot base 350 mm from the positioner centre (instead of 1500): from layer 0 the arm
    cannot reach the part without running into its joint limits; the node error (exit 3) names
    layer 0, the best compromise and the base moved 200 mm further away, which re-planned passes
    every layer and simulates clean."""
    data = json.loads(load_cell("kr150_tilt_rotate").model_dump_json())
    data["robot_base"]["xyz_mm"] = [-350.0, 0.0, -600.0]
    (tmp_path / "close.json").write_text(json.dumps(data))
    cell = Cell.model_validate(data)
    plan = plan_auto(cell, duct, _arm(cell))
    assert not plan.ok and plan.failed["layer"] == 0 and plan.failed["best"]["unreachable"] >= 1
    base = [s for s in plan.suggestions if s["change"] == "robot base moved"]
    assert len(base) == 1 and base[0]["shift_mm"] == 200.0 and base[0]["verified"]
    moved = Cell.model_validate(modified_cell(data, base[0], duct))
    assert moved.robot_base.xyz_mm == (-550.0, 0.0, -600.0)
    sim = _sim(moved, duct)
    assert sim["positioner_plan"]["ok"] and sim["collision_count"] == 0 and sim["unreachable_stretches"] == 0
    # through the engine: a node error at layer 0 (the CLI's exit 3)
    recipe = json.loads((GRAPHS / "curved-duct.json").read_text())
    recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] != "post"]
    recipe["edges"] = [e for e in recipe["edges"] if "post." not in (e["from"][:5], e["to"][:5])]
    next(n for n in recipe["nodes"] if n["id"] == "sim")["params"] = {"cell": "close.json"}
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "duct.stl").write_bytes((GRAPHS / "parts" / "duct.stl").read_bytes())
    with pytest.raises(PlanningError) as e:
        execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    assert e.value.exit_code == 3 and e.value.node == "sim" and e.value.layer == 0
    assert "best compromise" in e.value.message and "robot base 200 mm further" in e.value.message


@pytest.fixture(scope="module", params=[110.0, 135.0])
def tight_bend(request, tmp_path_factory):
    return request.param, _bend(tmp_path_factory.mktemp("bend"), request.param, 5.0)


@pytest.mark.parametrize("cell_name", ["kr150_tilt_rotate", "irb4600_tilt_rotate"])
def test_tight_bends_build_clean_under_auto(tight_bend, cell_name):
    """Bends of 110° and 135° at R = 1.2 × the tube's outer radius (21 mm): the tube's inner wall
    runs 6 mm from the bend axis, which lies in the table plane, so from ~50° of tilt on the torch
    nozzle closes on the table: under the gravity rule the torch meets the table (collisions).
    `auto` leans the torch away as far as it may (15°), and where that is not enough it fails
    naming the layer and the best compromise (a torch/table contact), with the riser it verified;
    on that riser the simulation under `auto` has 0 collisions, 0 unreachable, 0 limit and 0
    singular stretches, and the table tilts to the last layer's angle (within the flat tolerance)."""
    sweep, moves = tight_bend
    cell = load_cell(cell_name)
    assert _sim(cell, moves, "gravity")["collision_count"] > 0
    plan = plan_auto(cell, moves, _arm(cell))
    if not plan.ok:
        best = plan.failed["best"]
        assert best["collisions"] > 0 and "positioner:table" in best["collision"]
        assert abs(best["e_deg"][0]) >= 45.0 and best["lean_deg"] <= 15.0
        riser = [s for s in plan.suggestions if s["change"] == "riser"]
        assert len(riser) == 1 and riser[0]["verified"] and 50.0 <= riser[0]["riser_mm"] <= 400.0
        cell = Cell.model_validate(modified_cell(json.loads(cell.model_dump_json()), riser[0], moves))
    sim = _sim(cell, moves)
    assert sim["positioner_plan"]["ok"] is True
    assert sim["collision_count"] == 0 and sim["unreachable_stretches"] == 0
    assert sim["joint_limit_stretches"] == 0 and sim["near_singular_stretches"] == 0
    rows = sim["positioner_plan"]["layers"]
    assert max(r["lean_deg"] for r in rows) <= 15.0 and max(r["tilt_deg"] for r in rows) <= 5.0 + 1e-6
    e1 = max(abs(r["e_deg"][0]) for r in rows)
    assert e1 > sweep - 5.0 - sim["positioner_plan"]["flat_tol_deg"] - 1e-6


def test_node_params_default_to_auto_with_the_process_limits():
    """simulate-robot's positioner_policy defaults to auto; a lean above 15° is refused by the
    node's schema; the default limits are 15° of lean and 5° off flat."""
    from waamflow.engine.node import load_nodes

    schema = load_nodes()["simulate-robot"].Params.model_json_schema()["properties"]
    assert schema["max_lean_deg"]["maximum"] == 15 and schema["positioner_policy"]["default"] == "auto"
    assert AutoLimits().max_lean_deg == 15.0 and AutoLimits().flat_tol_deg == 5.0


def test_broad_phase_box_bound_is_the_exact_distance():
    """The collision broad phase keeps a pair when a body's bounding sphere reaches the other's
    oriented box: `_box_gap2` is the exact squared distance point → box (coal's distance from a
    0.1 µm sphere, over 200 random boxes and points, within 1e-6 mm; 0 inside), so no pair that can
    touch is dropped."""
    import coal

    from waamflow.trajectory.collide import _box_gap2, _tf
    from waamflow.trajectory.cell import rpy_matrix

    rng = np.random.default_rng(7)
    pts = rng.uniform(-400, 400, (200, 3))
    R = np.array([rpy_matrix(rng.uniform(-180, 180, 3)) for _ in range(200)])
    c = rng.uniform(-200, 200, (200, 3))
    half = rng.uniform(5, 150, (200, 3))
    gap = np.sqrt(_box_gap2(pts, R, c, half)).diagonal()
    req, dot = coal.DistanceRequest(), coal.Sphere(1e-10)
    ref = []
    for i in range(200):
        res = coal.DistanceResult()
        d = coal.distance(dot, _tf(np.eye(3), pts[i]), coal.Box(*(2 * half[i] / 1000.0)), _tf(R[i], c[i]), req, res)
        ref.append(max(d * 1000.0, 0.0))
    assert np.count_nonzero(gap == 0) == np.count_nonzero(np.array(ref) <= 1e-6) > 0
    assert gap == pytest.approx(np.array(ref), abs=1e-6)


def test_the_program_carries_the_lean_the_plan_chose(tmp_path, monkeypatch):
    """135° bend on kr150_tilt_rotate with the riser `auto` verified: the plan leans the torch on
    its last layers, and post-process writes those leaned axes, not the toolpath's (a program with
    the un-leaned torch would weld where the plan found the torch nozzle on the table). Torch axes
    from `positioner_and_torch` are the toolpath's turned by exactly each layer's lean (arc-ON
    points), untouched on layers without one; the KRL the node writes changes when the un-leaned
    axes are put in their place."""
    import waamflow.nodes.post as post_node
    from waamflow.trajectory.cell import positioner_and_torch

    bend = 1.2 * TUBE_OUTER_MM
    moves = _bend(tmp_path, 135.0, 5.0)
    cell = load_cell("kr150_tilt_rotate")
    riser = next(s for s in plan_auto(cell, moves, _arm(cell)).suggestions if s["change"] == "riser")
    data = modified_cell(json.loads(cell.model_dump_json()), riser, moves)
    (tmp_path / "riser.json").write_text(json.dumps(data))
    riser_cell = Cell.model_validate(data)
    plan = plan_auto(riser_cell, moves, _arm(riser_cell))
    lean = {r["layer"]: r["lean_deg"] for r in plan.layers}
    assert plan.ok and max(lean.values()) >= 10.0

    angles, torch = positioner_and_torch(riser_cell, moves, "auto")
    np.testing.assert_allclose(angles, plan.angles)
    a = np.asarray(moves.tool_axis, float)
    turned = np.degrees(
        np.arccos(
            np.clip(np.sum(a * torch, axis=1) / np.linalg.norm(a, axis=1) / np.linalg.norm(torch, axis=1), -1.0, 1.0)
        )
    )
    point_layer = np.concatenate([np.asarray(moves.layer)[:1], np.asarray(moves.layer)])
    arc_end = np.concatenate([[False], np.asarray(moves.arc, bool)])
    for L, deg in lean.items():
        on = arc_end & (point_layer == L)
        assert on.any()
        np.testing.assert_allclose(turned[on], deg, atol=1e-6)

    recipe = json.loads((GRAPHS / "curved-duct.json").read_text())
    recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] != "sim"]
    recipe["edges"] = [e for e in recipe["edges"] if "sim." not in (e["from"][:4], e["to"][:4])]
    recipe["inputs"]["dtheta_deg"] = 5.0
    next(n for n in recipe["nodes"] if n["id"] == "fan")["params"].update(
        {"axis_point": [-bend, 0, 0], "h_min": 0.1, "h_max": 8.0}
    )
    next(n for n in recipe["nodes"] if n["id"] == "post")["params"].update(
        {"cell": "riser.json", "positioner_policy": "auto"}
    )

    def dat():
        r = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
        return r.outputs["post"]["program"].files["dat"]

    leaned = dat()
    real = post_node.positioner_and_torch
    monkeypatch.setattr(
        post_node, "positioner_and_torch", lambda c, m, *a: (real(c, m, *a)[0], np.asarray(m.tool_axis, float))
    )
    assert dat() != leaned


# ---- along-layer angles (follow-normal, follow-turn) ------------------------------------------
RING_MM = 1200.0  # kr150_tilt_rotate reaches a ring of 900 mm around from one side, not 1200
RING_POINTS = 120  # 3° of azimuth per segment


def _moves_of(layers, speed=10.0):
    """Moves of layers given as (points (k, 3), tool axes (k, 3)) part frame: one lap each, arc ON,
    joined by an arc-OFF travel (what `flatten` makes of one section a layer)."""
    from waamflow.core.moves import Moves

    pts, axes, arc, lay = [], [], [], []
    for L, (P, A) in enumerate(layers):
        if pts:
            arc.append(False)
            lay.append(L)
        pts.extend(P)
        axes.extend(A)
        arc.extend([True] * (len(P) - 1))
        lay.extend([L] * (len(P) - 1))
    arc = np.array(arc)
    return Moves(
        points=np.array(pts, float),
        tool_axis=np.array(axes, float),
        kind=arc.astype(np.int8),
        arc=arc,
        inside=arc.copy(),
        speed=np.where(arc, speed, np.nan),
        layer=np.array(lay, np.int32),
        section=np.array(lay, np.int32),
        zone=np.where(arc, 0, -1).astype(np.int32),
        dwell_before=np.zeros(len(pts)),
        section_keys=tuple(f"L{L}" for L in range(len(layers))),
        zone_ids=("",),
        zone_params={(L, 0): {} for L in range(len(layers))},
        layer_z={L: 2.5 * (L + 1) for L in range(len(layers))},
    )


def _ring(radius=RING_MM, n=RING_POINTS, layers=2, alternate=True):
    """A thin-walled ring of `radius` about the turntable axis, one closed lap a layer starting on
    the robot's side (−x), the torch straight down; the laps alternate CCW / CW from above (else
    all CCW)."""
    t = np.linspace(np.pi, 3 * np.pi, n + 1)
    return _moves_of(
        [
            (
                np.c_[radius * np.cos(u), radius * np.sin(u), np.full(n + 1, 2.5 * (L + 1))],
                np.tile([0, 0, -1.0], (n + 1, 1)),
            )
            for L in range(layers)
            for u in [t[::-1] if alternate and L % 2 else t]
        ]
    )


def _point_tilt(cell, moves, angles):
    """Per arc-ON point, how far its own layer normal (−tool axis) is from world vertical (deg)."""
    from waamflow.trajectory.cell import to_world

    _, w = to_world(cell, moves.points, moves.tool_axis, angles)
    tilt = np.degrees(np.arccos(np.clip(-w[:, 2] / np.linalg.norm(w, axis=1), -1.0, 1.0)))
    on = np.zeros(len(moves.points), bool)
    on[:-1] |= moves.arc
    on[1:] |= moves.arc
    return tilt[on]


@pytest.fixture(scope="module")
def ring():
    return _ring()


def test_follow_turn_welds_a_ring_the_arm_cannot_reach_around(ring, monkeypatch):
    """A 1200 mm ring on kr150_tilt_rotate: at any fixed E2 its far side is 2700 mm from the
    robot's base, out of reach, so every per-layer choice fails on layer 0 (the plan without the
    along-layer stages names it); `follow-turn` turns the turntable along each lap so each point
    is welded 30° off the robot's side: every layer plans, E1 stays 0, E2 spans 360° in a layer,
    turns 3° (360°/120) between consecutive points at 0.48°/s (10 mm/s on R 1200 mm; the
    turntable's 180°/s), each lap starts where the last ended (the laps alternate CCW / CW), and
    the simulation has 0 unreachable, 0 collisions, 0 limit and 0 singular stretches. Laps all
    CCW would need the turntable to unwind 360° on the travel (limits ±360°) with the torch
    following the part round: the plan fails on layer 1 and says so."""
    from waamflow.trajectory import cellfollow

    cell = load_cell("kr150_tilt_rotate")
    with monkeypatch.context() as mp:
        mp.setattr(cellfollow, "FOLLOW_STAGES", ())
        per_layer = plan_auto(cell.load_meshes(), ring, _arm(cell), suggest=False)
    assert not per_layer.ok and per_layer.failed["layer"] == 0 and per_layer.failed["best"]["unreachable"] >= 1
    plan = plan_auto(cell, ring, _arm(cell), suggest=False)
    assert plan.ok and [r["stage"] for r in plan.layers] == ["follow-turn", "follow-turn"]
    assert np.abs(plan.angles[:, 0]).max() < 1e-9
    lay = np.concatenate([ring.layer[:1], ring.layer])
    for L in (0, 1):
        e2 = plan.angles[lay == L, 1]
        assert e2.max() - e2.min() == pytest.approx(360.0, abs=1e-6)
        assert np.abs(np.diff(e2)).max() == pytest.approx(360.0 / RING_POINTS, abs=1e-6)
        assert plan.layers[L]["e_span_deg"] == [0.0, pytest.approx(360.0, abs=1e-3)]
        assert plan.layers[L]["axis_speed_deg_s"] == pytest.approx(10.0 / RING_MM * 180 / np.pi, rel=1e-3)
        assert plan.layers[L]["axis_speed_limit_deg_s"] == pytest.approx(180.0, abs=0.01)
    assert plan.angles[RING_POINTS + 1, 1] == pytest.approx(plan.angles[RING_POINTS, 1], abs=1e-9)
    assert -360.0 <= plan.angles[:, 1].min() and plan.angles[:, 1].max() <= 360.0
    sim = _sim(cell, ring)
    assert [r["stage"] for r in sim["positioner_plan"]["layers"]] == ["follow-turn", "follow-turn"]
    assert sim["unreachable_stretches"] == 0 and sim["collision_count"] == 0
    assert sim["joint_limit_stretches"] == 0 and sim["near_singular_stretches"] == 0
    assert sim["axis_speed_stretches"] == 0 and sim["axis_limit_stretches"] == 0
    one_way = plan_auto(cell, _ring(alternate=False), _arm(cell), suggest=False)
    assert not one_way.ok and one_way.failed["layer"] == 1
    assert (
        "along the layer: follow-turn" in one_way.failed["message"] and "on the travel in" in one_way.failed["message"]
    )
    assert "alternating directions" in one_way.failed["message"]


def test_follow_normal_brings_every_point_of_a_spread_layer_flat():
    """A 300 mm straight layer whose tool axis turns from 25° to −25° about x along it (two such
    layers): no single set of angles keeps all its points within 5° of flat (the mean normal's
    gravity angles leave the ends 25° off). `follow-normal` turns the table along the layer, each
    point at its own normal's gravity angles: every arc point within 1e-6° of flat (≤ flat_tol),
    E1 spanning 50° along a layer, and the simulation clean (0 unreachable, 0 collisions)."""
    moves = _moves_of(_spread_layers())
    cell = load_cell("kr150_tilt_rotate")
    plan = plan_auto(cell, moves, _arm(cell), suggest=False)
    assert plan.ok and [r["stage"] for r in plan.layers] == ["follow-normal", "follow-normal"]
    tilt = _point_tilt(cell, moves, plan.angles)
    assert tilt.max() <= 1e-6 <= AutoLimits().flat_tol_deg
    assert max(r["tilt_deg"] for r in plan.layers) <= 1e-6
    e = plan.angles[:31]
    assert e.max(axis=0)[0] - e.min(axis=0)[0] == pytest.approx(50.0, abs=1e-6)
    sim = _sim(cell, moves)
    assert sim["unreachable_stretches"] == 0 and sim["collision_count"] == 0
    assert sim["joint_limit_stretches"] == 0 and sim["near_singular_stretches"] == 0


def test_follow_turn_angles_reach_the_krl_program(ring):
    """The program carries the plan's per-point E2: KRL E6POS targets in program order have E2
    varying along each lap (120 distinct values a layer) equal to the plan's within 1e-3°."""
    import re

    from waamflow.program import post_process
    from waamflow.program.krl import KrlSettings
    from waamflow.program.plan import PlanSettings
    from waamflow.trajectory.cell import positioner_and_torch

    cell = load_cell("kr150_tilt_rotate")
    angles, torch = positioner_and_torch(cell, ring, "auto")
    prog = post_process(ring, "krl", PlanSettings(arc_tolerance=0.0), KrlSettings(external_axes=angles))
    dat = prog.files["dat"]
    decl = dict(re.findall(r"DECL E6POS (P\d+)=\{[^}]*,E2 ([-\d.]+),", dat))
    order = re.findall(r"^\s*(?:LIN|PTP) (P\d+)", prog.files["src"], re.M)
    e2 = np.array([float(decl[p]) for p in order])
    assert len(e2) == len(ring.points)
    np.testing.assert_allclose(e2, angles[:, 1], atol=1e-3)
    assert len(np.unique(np.round(e2[: RING_POINTS + 1], 3))) == RING_POINTS + 1


def _spread_layers(n_layers=2):
    """Straight 300 mm layers (31 points along y) whose tool axis turns from 25° to −25° about x."""
    th = np.radians(np.linspace(25.0, -25.0, 31))
    y = np.linspace(-150.0, 150.0, 31)
    return [
        (np.c_[np.zeros(31), y, np.full(31, 2.5 * (L + 1))], -np.c_[np.zeros(31), np.sin(th), np.cos(th)])
        for L in range(n_layers)
    ]


def test_follow_reports_an_axis_rate_the_positioner_lacks():
    """The spread layer welded at 1000 mm/s: E1 turns 50°/30 = 1.667° per 10 mm segment, 166.7°/s,
    above the tilt axis's 90°/s (URDF): the plan's row says so (rate and limit), and the
    simulation caps the path speed there (axis_speed stretches)."""
    moves = _moves_of(_spread_layers(1), speed=1000.0)
    cell = load_cell("kr150_tilt_rotate")
    plan = plan_auto(cell, moves, _arm(cell), suggest=False)
    row = plan.layers[0]
    assert plan.ok and row["stage"] == "follow-normal"
    assert row["axis_speed_deg_s"] == pytest.approx(50.0 / 30 * 100, rel=1e-6)
    assert row["axis_speed_limit_deg_s"] == pytest.approx(90.0, abs=0.01)
    assert "would turn 166.7°/s, above its 90°/s" in row["why"]
    sim = _sim(cell, moves)
    assert sim["axis_speed_stretches"] >= 1 and sim["unreachable_stretches"] == 0


def test_curved_bracket_plans_as_before_on_its_planar_layers():
    """The shipped curved-bracket (first 6 layers) on its ABB cell under `auto`: its fan layers
    are planar (every point's tool axis the layer's, spread 0°), so every layer passes at its
    gravity angles (no follow-* stage) and the plan's angles equal the gravity policy's exactly,
    as before the along-layer stages (the duct: test_auto_takes_the_gravity_angles_where_they_work)."""
    recipe = json.loads((GRAPHS / "curved-bracket.json").read_text())
    recipe["inputs"]["layer_count"] = 6
    recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] not in ("post", "sim")]
    recipe["edges"] = [e for e in recipe["edges"] if not ({e["from"][:4], e["to"][:4]} & {"post", "sim."})]
    moves = flatten(
        execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(GRAPHS)).outputs["bead"]["toolpath"]
    )
    cell = load_cell("irb4600_tilt_rotate")
    plan = plan_auto(cell.load_meshes(), moves, _arm(cell))
    assert plan.ok and [r["stage"] for r in plan.layers] == ["gravity"] * 6
    assert "e_span_deg" not in plan.layers[0] and max(r["tilt_deg"] for r in plan.layers) < 1e-3
    assert np.array_equal(plan.angles, plan_positioner(cell, moves, "gravity")[0])
    assert np.array_equal(plan.tool_axis, np.asarray(moves.tool_axis, float))
