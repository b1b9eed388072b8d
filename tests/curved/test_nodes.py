"""fan-slice → wall-path → bead-model through the engine on the shipped curved-duct recipe."""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from waamflow.curved.bead import BeadModel
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def run(mutate=None):
    recipe = json.loads((GRAPHS / "curved-duct.json").read_text())
    if mutate:
        mutate(recipe)
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(GRAPHS))


@pytest.fixture(scope="module")
def duct():
    return run()


def test_fan_report(duct):
    fan = json.loads(duct.artifacts["fan.fan.json"])
    assert fan["layer_count"] == 58 and fan["dtheta_deg"] == pytest.approx(1.54)
    # the duct's 5 mm wall spans 82.5..117.5 mm about the bend axis (graphs/parts/duct.py)
    assert fan["csratio"] == pytest.approx(100 / 35, abs=2e-3) and fan["min_csratio"] == pytest.approx(2.7)
    assert fan["heights_fit"] is True
    dth = math.radians(1.54)
    for row in fan["layers"]:
        assert row["height_min_mm"] == pytest.approx(82.5 * dth, abs=2e-3)
        assert row["height_max_mm"] == pytest.approx(117.5 * dth, abs=2e-3)
    assert duct.warnings == []


def test_speeds_follow_the_local_height(duct):
    tp = duct.outputs["bead"]["toolpath"]
    model = BeadModel()
    dth = math.radians(1.54)
    for lp in list(tp)[::19]:
        sp = lp.sections[0]
        assert sp.tool_axis is not None and np.allclose(sp.tool_axis[0], -lp.layer.normal)
        d = sp.points - lp.layer.frame[:3, 3]
        r = d @ lp.layer.frame[:3, 0]
        h = (r[:-1] + r[1:]) / 2 * dth  # needed height r·Δθ at segment midpoints
        assert np.allclose(model.height(sp.speed * 60.0), h, atol=1e-9)
        assert np.all(np.abs(d @ lp.layer.frame[:3, 2]) < 1e-9)  # points on the layer's top plane
    bead = json.loads(duct.artifacts["bead.bead.json"])
    assert bead["clamped_segments"] == 0 and bead["min_csratio"] == pytest.approx(2.7525, abs=1e-4)
    rows = bead["layers"]
    # centre line at r = 85..115 mm: 2.28..3.09 mm → 1078..465 mm/min
    assert min(r["speed_min_mm_s"] for r in rows) == pytest.approx(465 / 60, abs=0.05)
    assert max(r["speed_max_mm_s"] for r in rows) == pytest.approx(1078 / 60, abs=0.1)


def test_perimeter_is_the_ring_centre_line(duct):
    tp = duct.outputs["perimeter"]["toolpath"]
    sp = tp[10].sections[0]
    lay = tp[10].layer
    d = sp.points - lay.frame[:3, 3]
    x, y = d @ lay.frame[:3, 0], d @ lay.frame[:3, 1]
    assert np.allclose(np.hypot(x - 100, y), 15.0, atol=0.05)  # mid radius of the 13.5..16.5 wall
    assert sp.length == pytest.approx(2 * math.pi * 15 + 5.0, abs=0.3)  # one lap + 5 mm overlap


def test_too_thick_layers_warn_and_clamp():
    def thick(recipe):
        recipe["inputs"]["dtheta_deg"] = 1.75
        next(n for n in recipe["nodes"] if n["id"] == "fan")["params"]["layer_count"] = 8

    res = run(thick)
    texts = [w if isinstance(w, str) else json.dumps(w) for w in res.warnings]
    assert any("bead range" in t for t in texts)  # fan-slice: CSratio / heights warning
    assert any("clamped" in t and "layer" in t for t in texts)
    bead = json.loads(res.artifacts["bead.bead.json"])
    assert bead["clamped_segments"] > 0


def test_radius_search_from_the_node():
    def search(recipe):
        recipe["inputs"]["radius_offset"] = None

    res = run(search)
    fan = json.loads(res.artifacts["fan.fan.json"])
    assert fan["search"]["best"]["offset_mm"] == 0.0 and fan["search"]["best"]["feasible"] is True


def test_too_curved_part_reports_the_radius_search(tmp_path):
    import trimesh

    from waamflow.curved.shapes import bent_tube

    part = bent_tube(bend=60, mid=15, wall=3, n_phi=24, n_psi=16)
    trimesh.Trimesh(part.vertices, part.faces).export(tmp_path / "tight.stl")
    recipe = {
        "format": "waamflow/1",
        "name": "tight",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "tight.stl"}},
            {
                "id": "fan",
                "type": "fan-slice",
                "params": {
                    "axis_point": [-60, 0, 0],
                    "axis_direction": [0, -1, 0],
                    "dtheta_deg": 2.6,
                    "radius_offset": None,
                    "search_step": 10,
                    "search_max": 60,
                },
            },
        ],
        "edges": [{"from": "part.mesh", "to": "fan.mesh"}],
    }
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    texts = [json.dumps(w) if not isinstance(w, str) else w for w in res.warnings]
    assert any("mode = sections" in t for t in texts)
    assert any("bead range" in t for t in texts)  # sliced as one section: heights leave the range
    fan = json.loads(res.artifacts["fan.fan.json"])
    assert fan["csratio"] == pytest.approx(60 / 33, rel=2e-3) and fan["heights_fit"] is False
    assert fan["search"]["feasible"] is False and len(fan["search"]["candidates"]) == 7  # 0, 10, …, 60 mm


def test_sections_mode_closes_on_the_end_face_or_fails(tmp_path):
    """R 75 mm (CSratio 75/33 = 2.27 < 2.7, wall 91.5/58.5 = 1.56 times longer outside than inside,
    h_max/h_min = 1.45): no plan that ends on the end face keeps the heights in range. Before,
    3 greedy sections kept the first ones in range and the last ran past the end face (open
    layers, only a warning). Now the best closed plan (one fan about the bend axis, 44 layers)
    needs 2.09..3.26 mm, 0.11 mm outside: over the default height_tolerance 0.1 mm, a
    PlanningError at layer 39; with height_tolerance 0.12 mm it is built, warned."""
    import trimesh

    from waamflow.core.errors import PlanningError
    from waamflow.curved.shapes import bent_tube

    part = bent_tube(bend=75, mid=15, wall=3, n_phi=24, n_psi=16)
    trimesh.Trimesh(part.vertices, part.faces).export(tmp_path / "bend.stl")
    recipe = {
        "format": "waamflow/1",
        "name": "bend",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "bend.stl"}},
            {
                "id": "fan",
                "type": "fan-slice",
                "params": {
                    "axis_point": [-75, 0, 0],
                    "axis_direction": [0, -1, 0],
                    "mode": "sections",
                    "search_step": 20,
                    "search_max": 60,
                    "max_sections": 3,
                },
            },
        ],
        "edges": [{"from": "part.mesh", "to": "fan.mesh"}],
    }
    with pytest.raises(PlanningError, match=r"needs heights 2\.09\.\.3\.26 mm at layer 39") as err:
        execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    assert err.value.layer == 39 and "height_tolerance ≥ 0.12" in str(err.value)
    recipe["nodes"][1]["params"]["height_tolerance"] = 0.12
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    fan = json.loads(res.artifacts["fan.fan.json"])
    secs = fan["sections"]
    assert len(secs) == 1 and secs[0]["layers"] == fan["layer_count"] == 44
    assert np.allclose(secs[0]["axis_point"], [-75, 0, 0], atol=1e-6)
    assert secs[0]["dtheta_deg"] * 44 == pytest.approx(90.0, abs=1e-4)  # fan.json: 8 digits; ends on the end face
    texts = [w["message"] for w in res.warnings]
    assert len(texts) == 1 and "fan section 0" in texts[0] and "0.1" in texts[0]
    layers = res.outputs["fan"]["layers"]
    assert np.allclose(layers[-1].frame[:3, 2], [-1, 0, 0], atol=1e-9)  # the end face x = −75
    assert layers[-1].frame[:3, 3][0] == pytest.approx(-75.0, abs=1e-9)


def test_duct_on_the_positioner_cell_is_reachable(duct):
    """The shipped recipe simulates on kr150_tilt_rotate with the `gravity` policy: every layer is
    turned flat (E1 tilt follows the fan: Δθ .. 58·Δθ over the quarter bend) and the arm reaches
    every sample; with the positioner held at 0° (`fixed`) the arm alone fails from layer ~26 on."""
    sim = json.loads(duct.artifacts["sim.simulation.json"])
    assert sim["unreachable_stretches"] == 0 and sim["joint_limit_stretches"] == 0
    assert sim["near_singular_stretches"] == 0 and sim["ik_max_position_error_mm"] < 0.01
    assert sim["collision_count"] == 0
    assert sim["max_wrist_step_deg"] < 2.0  # A4..A6 per IK sample: no wrist flip / roll
    assert sim["positioner_e1_min_deg"] == pytest.approx(1.54, abs=0.01)  # layer i's top at (i+1)·Δθ
    assert sim["positioner_e1_max_deg"] == pytest.approx(58 * 1.54, abs=0.01)
    assert sim["positioner_max_step_deg"] == pytest.approx(1.54, abs=0.05)

    def fixed(recipe):  # on both: the simulation plans as the program it is fed was written
        for n in recipe["nodes"]:
            if n["id"] in ("sim", "post"):
                n["params"]["positioner_policy"] = "fixed"

    bad = json.loads(run(fixed).artifacts["sim.simulation.json"])
    assert bad["unreachable_stretches"] >= 5
    assert bad["positioner_e1_max_deg"] == 0.0


def test_duct_krl_carries_the_positioner_angles(duct):
    """post.dat: every E6POS target carries E1 (tilt) = its layer's gravity angle, 58 distinct
    values Δθ..58·Δθ, and one E2 (the bend turns about one axis); E3..E6 stay 0."""
    import re

    dat = duct.artifacts["post.dat"]
    dat = dat.decode() if isinstance(dat, bytes) else dat
    rows = re.findall(
        r"DECL E6POS P\d+=\{X [^}]*,E1 ([-\d.]+),E2 ([-\d.]+),E3 ([-\d.]+),E4 ([-\d.]+),"
        r"E5 ([-\d.]+),E6 ([-\d.]+)\}",
        dat,
    )
    assert len(rows) == dat.count("DECL E6POS")
    e = np.array(rows, float)
    e1 = np.unique(np.round(e[:, 0], 2))
    assert len(e1) == 58 and e1.min() == pytest.approx(1.54, abs=0.01) and e1.max() == pytest.approx(89.32, abs=0.01)
    assert len(np.unique(np.round(e[:, 1], 2))) == 1 and np.all(e[:, 2:] == 0)


@pytest.mark.parametrize("bend,sweep,dtheta", [(60.0, 90.0, 2.6), (100.0, 135.0, 3.0)])
def test_other_bends_are_reachable_with_the_gravity_policy(tmp_path, bend, sweep, dtheta):
    """A tighter bend (R 60 mm) and a sweep past 90° (135°): 0 unreachable / limit / singular
    stretches on the positioner cell, E1 up to the last layer's tilt (> 90° for the 135° sweep)."""
    import trimesh

    from waamflow.curved.shapes import bent_tube

    part = bent_tube(bend=bend, mid=15.0, wall=3.0, sweep_deg=sweep, n_phi=int(sweep / 2), n_psi=24)
    (tmp_path / "parts").mkdir()
    trimesh.Trimesh(part.vertices, part.faces, process=True).export(tmp_path / "parts" / "duct.stl")
    recipe = json.loads((GRAPHS / "curved-duct.json").read_text())
    recipe["inputs"]["dtheta_deg"] = dtheta
    fan = next(n for n in recipe["nodes"] if n["id"] == "fan")["params"]
    fan.update({"axis_point": [-bend, 0, 0], "h_min": 1.0, "h_max": 8.0})
    r = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    sim = json.loads(r.artifacts["sim.simulation.json"])
    layers = json.loads(r.artifacts["fan.fan.json"])["layer_count"]
    assert layers == pytest.approx(sweep / dtheta, abs=1)
    assert sim["unreachable_stretches"] == 0 and sim["joint_limit_stretches"] == 0
    assert sim["near_singular_stretches"] == 0 and sim["ik_max_position_error_mm"] < 0.01
    assert sim["positioner_e1_max_deg"] == pytest.approx(layers * dtheta, abs=0.01)
    assert sim["max_wrist_step_deg"] < 2.0  # A4..A6 per IK sample: no wrist flip
    if sweep <= 90:
        assert sim["collision_count"] == 0 and sim["collision_samples_checked"] >= layers
        return
    # past 90° the table turns over the part: the torch neck meets the 300 mm table disc only on
    # layers tilted beyond 90° — a real cell lifts such a part on a riser (work frame +150 mm)
    assert sim["collision_count"] > 0
    assert all(
        c["bodies"] == ["torch:torch_neck", "positioner:table"] and (c["layer"] + 1) * dtheta > 90
        for c in sim["collisions"]
    )
    from waamflow.trajectory.cell import load_cell

    cell = json.loads(load_cell("kr150_tilt_rotate").model_dump_json())
    cell["work_frame"]["xyz_mm"] = [0.0, 0.0, 150.0]
    (tmp_path / "riser.json").write_text(json.dumps(cell))
    next(n for n in recipe["nodes"] if n["id"] == "sim")["params"]["cell"] = "riser.json"
    recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] != "post"]
    # the simulation then runs without the program (the post also fed it the program as written)
    recipe["edges"] = [e for e in recipe["edges"] if "post." not in (e["to"][:5], e["from"][:5])]
    sim = json.loads(
        execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path)).artifacts["sim.simulation.json"]
    )
    assert sim["collision_count"] == 0 and sim["unreachable_stretches"] == 0
    assert sim["joint_limit_stretches"] == 0 and sim["near_singular_stretches"] == 0


def test_duct_rapid_robtargets_carry_extax():
    """The same recipe in RAPID: every robtarget's extax = [E1, E2, 9E9 × 4] with the layer tilts."""
    import re

    def rapid(recipe):
        next(n for n in recipe["nodes"] if n["id"] == "post")["params"]["format"] = "rapid"
        recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] != "sim"]
        recipe["edges"] = [e for e in recipe["edges"] if not e["to"].startswith("sim.")]

    mod = b"".join(
        v for k, v in sorted(run(rapid).artifacts.items()) if re.fullmatch(r"post(_M\d+)?\.mod", k)
    )  # main + part modules
    mod = mod.decode() if isinstance(mod, bytes) else mod
    ext = re.findall(r"CONST robtarget p\d+ := \[\[[^\]]*\],\[[^\]]*\],\[[^\]]*\],\[([^\]]*)\]\];", mod)
    assert len(ext) == mod.count("CONST robtarget") > 58
    e = [x.split(",") for x in ext]
    assert all(row[2:] == ["9E9"] * 4 for row in e)
    e1 = sorted({round(float(row[0]), 2) for row in e})
    assert len(e1) == 58 and e1[0] == pytest.approx(1.54) and e1[-1] == pytest.approx(89.32)


def _krl_structure(src: str, dat: str) -> dict[str, list[float]]:
    """A structural KRL checker: DEF name( ) … END in the .src, DEFDAT name … ENDDAT in the .dat,
    every DECL E6POS with exactly X Y Z A B C E1..E6 numeric fields, every LIN/PTP target declared
    once. Returns the E6POS fields by name."""
    num = r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?"
    body = [ln.split(";")[0].strip() for ln in src.splitlines()]
    body = [ln for ln in body if ln and not ln.startswith("&")]
    head = re.fullmatch(r"DEF (\w+)\( \)", body[0])
    assert head and body[-1] == "END" and sum(ln.startswith("DEF ") for ln in body) == 1
    name = head.group(1)
    dlines = [ln.split(";")[0].strip() for ln in dat.splitlines()]
    dlines = [ln for ln in dlines if ln and not ln.startswith("&")]
    assert re.fullmatch(rf"DEFDAT {name}(?: PUBLIC)?", dlines[0]) and dlines[-1] == "ENDDAT"
    fields = ["X", "Y", "Z", "A", "B", "C", "E1", "E2", "E3", "E4", "E5", "E6"]
    decl = {}
    for ln in dlines[1:-1]:
        if not ln.startswith("DECL E6POS"):
            continue
        m = re.fullmatch(r"DECL E6POS (\w+)=\{(.*)\}", ln)
        assert m, ln
        pairs = [p.strip().split(" ") for p in m.group(2).split(",")]
        assert [p[0] for p in pairs] == fields and all(re.fullmatch(num, p[1]) for p in pairs), ln
        assert m.group(1) not in decl
        decl[m.group(1)] = [float(p[1]) for p in pairs]
    targets = [re.match(r"(?:LIN|PTP) (\w+)", ln).group(1) for ln in body if re.match(r"(?:LIN|PTP) P\d+", ln)]
    assert targets and set(targets) <= set(decl)
    return {f: [v[i] for v in decl.values()] for i, f in enumerate(fields)}


def test_duct_krl_is_structurally_valid_with_moving_external_axes(duct):
    src, dat = (duct.artifacts[k] for k in ("post.src", "post.dat"))
    src, dat = (x.decode() if isinstance(x, bytes) else x for x in (src, dat))
    e = _krl_structure(src, dat)
    assert len(e["X"]) == 6787  # the 5 mm wall's centre-line laps (3 mm: 6438)
    assert len(set(np.round(e["E1"], 2))) == 58 and max(e["E1"]) - min(e["E1"]) > 85  # E1 moves
    assert len(set(np.round(e["E2"], 2))) == 1


def _lap_starts(res):
    """(n, 2) local start (x, y) of each layer's lap, its layer, and the lap direction (+1 CCW)."""
    out = []
    for lp in res.outputs["perimeter"]["toolpath"]:
        sp = lp.sections[0]
        d = sp.points - lp.layer.frame[:3, 3]
        x, y = d @ lp.layer.frame[:3, 0], d @ lp.layer.frame[:3, 1]
        turn = np.sign(np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]))
        out.append((x[0], y[0], turn))
    return np.array(out)


def test_ring_seams_aligned_or_scattered(duct):
    # aligned (the recipe's default tubular = helical, which tilted layers cannot take): each lap
    # starts at the seam below, or — where the greedy order reverses the lap — at its stop, one
    # overlap (5 mm) further along the 15 mm mid circle
    starts = _lap_starts(duct)
    ang = np.arctan2(starts[:, 1], starts[:, 0] - 100.0)
    step = np.abs(np.angle(np.exp(1j * np.diff(ang))))  # rad between consecutive starts
    assert np.all(step * 15.0 <= 5.0 + 1.0)
    assert np.ptp(ang[::2]) * 15.0 < 1.5  # every other layer: the same seam (± sampling)

    def scattered(recipe):
        next(n for n in recipe["nodes"] if n["id"] == "perimeter")["params"]["tubular"] = "scattered"

    sc = _lap_starts(run(scattered))
    ang = np.arctan2(sc[:, 1], sc[:, 0] - 100.0)
    # the golden-ratio sequence: starts spread round the lap, no two consecutive ones together
    hist = np.histogram(np.mod(ang, 2 * np.pi), bins=8, range=(0, 2 * np.pi))[0]
    assert hist.min() >= 4 and hist.max() <= 11  # 58 laps over 8 sectors
    assert np.min(np.abs(np.angle(np.exp(1j * np.diff(ang)))) * 15.0) > 6.0
