"""fan-slice mode = sections builds every layer up to the part's end face, or fails loudly
(issue #22, item 2: layers 131..147 of curved-bracket and 40..47 of a tube bent at R 80 mm were
open rings that wall-path skipped with a warning)."""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh

from waamflow.core.errors import PlanningError
from waamflow.curved.fan import FanAxis, height_range
from waamflow.curved.sections import _closing, topology
from waamflow.curved.shapes import bent_tube
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def tube_recipe(tmp_path, bend, fan_params, wall_path=True):
    part = bent_tube(bend=bend, mid=15, wall=3, sweep_deg=90, n_phi=72, n_psi=40)
    trimesh.Trimesh(part.vertices, part.faces).export(tmp_path / "tube.stl")
    nodes = [
        {"id": "part", "type": "mesh", "params": {"path": "tube.stl"}},
        {
            "id": "fan",
            "type": "fan-slice",
            "params": {"axis_point": [-bend, 0, 0], "axis_direction": [0, -1, 0], **fan_params},
        },
    ]
    edges = [{"from": "part.mesh", "to": "fan.mesh"}]
    if wall_path:
        nodes.append({"id": "perimeter", "type": "wall-path", "params": {"speed": 14.0, "overlap": 5.0}})
        edges.append({"from": "fan.layers", "to": "perimeter.layers"})
    recipe = {"format": "waamflow/1", "name": "tube", "nodes": nodes, "edges": edges}
    return lambda: execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))


def assert_closed_to_the_end(layers, end_normal, end_point, vertices, tol=1e-6):
    """Every layer a closed ring; the last layer's top plane is the part's end face (within `tol`
    mm: a float32 STL's vertices are rounded by up to ~1e-5 mm)."""
    assert all(topology(l.region) == (1,) for l in layers)
    top = layers[-1].frame
    assert np.degrees(np.arccos(np.clip(top[:3, 2] @ end_normal, -1, 1))) < 1e-4  # same plane normal
    assert abs((top[:3, 3] - end_point) @ end_normal) < tol  # through the end face
    beyond = (np.asarray(vertices) - top[:3, 3]) @ top[:3, 2]
    assert beyond.max() < 1e-3  # nothing of the part is left above the last layer


def test_tube_bent_at_r80_builds_every_layer(tmp_path):
    """R 80 mm, wall 13.5..16.5 mm from the tube centre line: the wall is 96.5/63.5 = 1.52 times
    longer outside than inside, more than h_max/h_min = 3.2/2.2 = 1.45, so no plan that ends on
    the end face keeps every height in range. Before: 3 greedy sections reached 61° of the 90°,
    the 4th (offset 35 mm) ran on past the end face and layers 40..47 were open (skipped by
    wall-path). Now: every one of 47 layers is a closed ring, the last tops at the end face x = −80,
    and the excess (0.078 mm, under height_tolerance 0.1 mm) is warned."""
    res = tube_recipe(tmp_path, 80, {"mode": "sections"})()
    layers = res.outputs["fan"]["layers"]
    tp = res.outputs["perimeter"]["toolpath"]
    assert len(layers) == 47
    assert sum(1 for lp in tp if lp is not None and lp.sections) == len(layers)  # every layer laid
    part = bent_tube(bend=80, mid=15, wall=3, sweep_deg=90, n_phi=72, n_psi=40)
    assert_closed_to_the_end(layers, np.array([-1.0, 0, 0]), np.array([-80.0, 0, 40]), part.vertices)
    fan = json.loads(res.artifacts["fan.fan.json"])
    # Δθ over the sections adds up to the bend: 90°
    assert sum(s["dtheta_deg"] * s["layers"] for s in fan["sections"]) == pytest.approx(90.0, abs=1e-4)  # 8 digits
    worst = max(max(2.2 - row["height_min_mm"], row["height_max_mm"] - 3.2) for row in fan["layers"])
    assert worst == pytest.approx(0.078, abs=0.002)
    texts = [w["message"] for w in res.warnings if w["node"] == "fan"]
    assert len(texts) == 1 and "0.078 mm" in texts[0] and "height_tolerance" in texts[0]
    assert not any("no hole" in w["message"] for w in res.warnings)


def test_too_tight_a_bend_is_a_planning_error_naming_the_layer(tmp_path):
    """R 60 mm (76.5/43.5 = 1.76 ≫ 1.45): the best closed plan (one fan about the bend axis, 35
    layers) needs 1.95..3.43 mm where the bead makes 2.2..3.2: 0.25 mm, over the 0.1 mm tolerance.
    The error names the layer, the heights it needs and the two settings that would fix it."""
    with pytest.raises(PlanningError) as err:
        tube_recipe(tmp_path, 60, {"mode": "sections"}, wall_path=False)()
    e = err.value
    assert e.node == "fan" and e.layer is not None and 0 <= e.layer < 60
    msg = str(e)
    m = re.search(r"needs heights (\d+\.\d+)\.\.(\d+\.\d+) mm at layer (\d+)", msg)
    assert m and int(m.group(3)) == e.layer
    lo, hi = float(m.group(1)), float(m.group(2))
    assert hi / lo == pytest.approx(76.5 / 43.5, rel=0.01)  # the wall's own outer/inner ratio
    assert (lo, hi) == pytest.approx((1.95, 3.43), abs=0.006)
    assert "height_tolerance ≥ 0.25" in msg and f"spanning {lo:.2f}..{hi:.2f} mm" in msg


def test_an_axis_off_the_bend_is_found_by_the_offset_search():
    """The axis given 10 mm off the bend axis within the start plane: the closing fan's axis is
    where the start plane meets the end face x = −100, i.e. the bend axis (10 mm out), and one fan
    of 58 layers of 90/58 = 1.552° builds it with every height in range."""
    from waamflow.curved.sections import plan_sections

    part = bent_tube(bend=100, mid=15, wall=3, sweep_deg=90, n_phi=72, n_psi=40)
    secs, layers = plan_sections(
        part, (-90, 0, 0), (0, -1, 0), 2.2, 3.2, max_overhang=1.5, step=10, max_offset=20, max_sections=4
    )
    assert len(secs) == 1 and secs[0].offset == pytest.approx(10.0) and secs[0].fits and secs[0].excess == 0
    assert np.allclose(secs[0].axis.point, [-100, 0, 0], atol=1e-9) and len(layers) == 58
    assert math.degrees(secs[0].dtheta) == pytest.approx(90 / 58)
    assert_closed_to_the_end(layers, np.array([-1.0, 0, 0]), np.array([-100.0, 0, 50]), part.vertices)


def test_an_oblique_end_face_about_the_axis_is_closed_exactly(tmp_path):
    """A tube whose end is cut 10° off the radial plane, about a line parallel to the axis: the
    end face is still a plane parallel to the axis, and the closing fan ends on it — every layer
    closed, the last one's top plane is the cut."""
    tube = trimesh.Trimesh(
        *(lambda m: (m.vertices, m.faces))(bent_tube(bend=100, mid=15, wall=3, sweep_deg=100, n_phi=80, n_psi=40))
    )
    tilt = math.radians(10)
    normal = np.array([math.cos(tilt), 0, -math.sin(tilt)])
    cut = tube.slice_plane([-100.0, 0, 100.0], normal, cap=True)
    assert cut.is_watertight
    cut.export(tmp_path / "tube.stl")
    recipe = {
        "format": "waamflow/1",
        "name": "tube",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "tube.stl"}},
            {
                "id": "fan",
                "type": "fan-slice",
                "params": {
                    "axis_point": [-100, 0, 0],
                    "axis_direction": [0, -1, 0],
                    "mode": "sections",
                    "search_step": 20,
                    "search_max": 40,
                },
            },
        ],
        "edges": [{"from": "part.mesh", "to": "fan.mesh"}],
    }
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    layers = res.outputs["fan"]["layers"]
    assert_closed_to_the_end(layers, -normal, np.array([-100.0, 0, 100.0]), cut.vertices, tol=1e-4)


def test_an_end_face_not_parallel_to_the_axis_is_a_planning_error(tmp_path):
    """The end cut 10° about the radial direction z instead: no fan about an axis along −y can
    end on it; refused before slicing, saying by how much and what to set."""
    tube = trimesh.Trimesh(
        *(lambda m: (m.vertices, m.faces))(bent_tube(bend=100, mid=15, wall=3, sweep_deg=100, n_phi=80, n_psi=40))
    )
    tilt = math.radians(10)
    cut = tube.slice_plane([-100.0, 0, 100.0], [math.cos(tilt), math.sin(tilt), 0], cap=True)
    cut.export(tmp_path / "tube.stl")
    recipe = {
        "format": "waamflow/1",
        "name": "tube",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "tube.stl"}},
            {
                "id": "fan",
                "type": "fan-slice",
                "params": {"axis_point": [-100, 0, 0], "axis_direction": [0, -1, 0], "mode": "sections"},
            },
        ],
        "edges": [{"from": "part.mesh", "to": "fan.mesh"}],
    }
    with pytest.raises(PlanningError, match=r"end face is 10\.00° off parallel .*set axis_direction"):
        execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))


def test_single_fan_with_a_moved_axis_refuses_open_layers(tmp_path):
    """Single fan, axis moved 20 mm out within the start plane: its planes turn less than the part
    (90° of part in 116.5/136.5·… ), so the layers past the end face are open: refused, naming
    the first one and the settings that close the part."""
    with pytest.raises(PlanningError, match="open") as err:
        tube_recipe(tmp_path, 100, {"mode": "single", "radius_offset": 20.0, "dtheta_deg": 1.5}, wall_path=False)()
    msg = str(err.value)
    assert "radius_offset 0" in msg and "mode = sections" in msg and err.value.layer > 0


def test_failed_radius_search_does_not_tell_to_leave_radius_offset_empty(tmp_path):
    """radius_offset empty (search) and nothing up to search_max fits: the error names what was
    searched and the real next steps, not 'leave radius_offset empty' (it was)."""
    with pytest.raises(PlanningError) as err:
        tube_recipe(
            tmp_path,
            60,
            {"mode": "single", "radius_offset": None, "dtheta_deg": None, "search_step": 20, "search_max": 40},
            wall_path=False,
        )()
    msg = str(err.value)
    assert "leave radius_offset empty" not in msg
    assert "search_max = 40 mm" in msg and "mode = sections" in msg and "dtheta_deg" in msg


def test_closing_axis_is_where_the_start_plane_meets_the_end_face():
    """From the part's start plane (z = 0 about (−100, 0, 0) along −y) onto the end face x = −100:
    the planes meet on the bend axis; from a plane at 30° through (−120, 0, 0) they meet where that
    plane crosses x = −100, 20·tan 30° = 11.55 mm up, and the wedge left is 60°."""
    part = bent_tube(bend=100, mid=15, wall=3, sweep_deg=90, n_phi=36, n_psi=16)
    end = FanAxis(np.array([-100.0, 0, 0]), np.array([0, -1.0, 0]), np.array([1.0, 0, 0]))
    ax, alpha, r_min, r_max = _closing(end, 0.0, end, math.pi / 2, part.vertices)
    assert np.allclose(ax.point, [-100, 0, 0]) and alpha == pytest.approx(math.pi / 2)
    assert (r_min, r_max) == pytest.approx((83.5, 116.5), abs=1e-6)
    moved = FanAxis(np.array([-120.0, 0, 0]), np.array([0, -1.0, 0]), np.array([1.0, 0, 0]))
    ax, alpha, _r0, _r1 = _closing(moved, math.radians(30), end, math.pi / 2, part.vertices)
    assert np.allclose(ax.point, [-100, 0, 20 * math.tan(math.radians(30))], atol=1e-9)
    assert math.degrees(alpha) == pytest.approx(60.0)
    # from the end face itself nothing is left to build
    assert _closing(end, math.pi / 2, end, math.pi / 2, part.vertices)[0] is None


@pytest.mark.slow
def test_curved_bracket_builds_every_layer_to_its_end_face():
    """The shipped recipe, all layers, without the simulation: every layer sliced is a closed ring,
    laid by wall-path and written to the RAPID program (before: 148 sliced, 131 in post.mod, the
    last ~8° of the bend never built); the last layer's top plane is the end face (φ = 90° about
    the bend axis through (−216.5, −125, 0) turned 30° from −y)."""
    recipe = json.loads((GRAPHS / "curved-bracket.json").read_text())
    recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] != "sim"]
    recipe["edges"] = [e for e in recipe["edges"] if not e["to"].startswith("sim.")]
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(GRAPHS))
    layers = res.outputs["fan"]["layers"]
    tp = res.outputs["perimeter"]["toolpath"]
    assert len(layers) == 146
    assert sum(1 for lp in tp if lp is not None and lp.sections) == len(layers)
    mod = b"".join(
        v for k, v in sorted(res.artifacts.items()) if re.fullmatch(r"post(_M\d+)?\.mod", k)
    )  # main + part modules
    mod = mod.decode() if isinstance(mod, bytes) else mod
    assert re.search(r"! layers (\d+),", mod).group(1) == "146"
    assert len(re.findall(r"^\s*! layer \d+ ", mod, re.M)) == 146
    yaw = math.radians(30)
    radial = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    mesh = trimesh.load(GRAPHS / "parts" / "curved_bracket.stl")
    assert_closed_to_the_end(layers, -radial, -250.0 * radial, mesh.vertices, tol=1e-3)
    # heights: 0.064 mm at most outside [2.2, 3.2] (warned), nowhere beyond height_tolerance
    worst = max(max(2.2 - lo, hi - 3.2) for lo, hi in map(height_range, layers))
    assert worst == pytest.approx(0.0752, abs=0.002)  # 5 mm wall: 197.5..302.5 mm (3 mm wall: 0.064)
    assert not any("no hole" in w["message"] for w in res.warnings)


def test_a_plane_through_a_ring_of_float32_vertices_cuts_the_whole_ring(tmp_path):
    """A tube read back from an STL (float32): the vertex ring at φ = 45° lies 1e-14..7e-7 mm off
    the 45° half-plane. Snapped at 1e-9 mm only half of it was on the plane and the section lost
    20 mm² of its 282 mm² (x reached 91.7 instead of 96.5 mm); snapped at 1e-5 mm it is whole."""
    from waamflow.core.model import MeshData
    from waamflow.curved.fan import FanSections

    part = bent_tube(bend=80, mid=15, wall=3, sweep_deg=90, n_phi=72, n_psi=40)
    trimesh.Trimesh(part.vertices, part.faces).export(tmp_path / "t.stl")
    m = trimesh.load(tmp_path / "t.stl")
    mesh = MeshData(np.asarray(m.vertices, float), np.asarray(m.faces), name="t")
    section = FanSections(mesh)
    axis = FanAxis(np.array([-80.0, 0, 0]), np.array([0, -1.0, 0]), np.array([1.0, 0, 0]))  # θ = φ
    on_ring, between = section(axis, math.radians(45.0)), section(axis, math.radians(45.6))
    assert on_ring.area == pytest.approx(between.area, rel=1e-3)
    assert on_ring.bounds[2] == pytest.approx(96.5, abs=1e-3) and topology(on_ring) == (1,)


@pytest.mark.parametrize(
    "axis",
    [{"axis_point": [0, 0, 0], "axis_direction": [0, -1, 0]}, {"axis_point": [-80, 0, 0], "axis_direction": [0, 0, 1]}],
)
def test_an_axis_through_the_part_is_a_planning_error_that_says_so(tmp_path, axis):
    """An axis that touches the part (a vertex on it: radius 0) left the layer thickness at that
    point 0 and failed as `ZeroDivisionError: float division by zero` (curved-duct with axis_point
    [0, 0, 0], or a vertical axis_direction: found by an API fuzz). It is a planning error that
    names the axis, the nearest radius and what to change."""
    run = tube_recipe(tmp_path, 80, {"dtheta_deg": 1.5, "radius_offset": 0.0, **axis}, wall_path=False)
    with pytest.raises(PlanningError, match=r"axis .*through the part.* 0\.000 mm .*axis_point") as err:
        run()
    assert err.value.node == "fan"


def test_an_axis_the_part_surrounds_is_a_planning_error_with_the_offset_search_too(tmp_path):
    """The offset search (radius_offset empty) refused an axis the part surrounds with the kernel's
    ValueError, reported as `ValueError: the part surrounds ...`: a planning error, as without the search."""
    run = tube_recipe(
        tmp_path,
        80,
        {"dtheta_deg": 1.5, "radius_offset": None, "axis_point": [0, 0, 0], "axis_direction": [0, 0, 1]},
        False,
    )
    with pytest.raises(PlanningError, match=r"the part surrounds the slicing axis") as err:
        run()
    assert err.value.node == "fan" and "ValueError" not in str(err.value)
