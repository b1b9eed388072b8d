"""A mesh whose surface passes through itself gives section loops that cross themselves. Planned on
as they came, GEOS stopped the strategy node ("TopologyException: side location conflict"; the
cow of alecjacobson/common-3d-test-models, layers 10 and 11 at 3 mm). The slicer now makes each
such section valid and the slice node warns where, with the areas before and after."""

import numpy as np
import shapely
import trimesh

from waamflow.core.model import MeshData
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.slicing.planar import Loops
from waamflow.slicing.rings import loops_to_regions, repair_regions
from waamflow.slicing.slicer import slice_part_scheduled

# a 20 × 20 mm square whose outline runs a 4 mm tongue through its own right side, out to x = 30
FOLD = [(0, 0), (20, 0), (20, 20), (0, 20), (0, 12), (30, 12), (30, 8), (0, 8)]


def _prism(ring, h: float) -> trimesh.Trimesh:
    n, xy = len(ring), np.asarray(ring, float)
    verts = np.vstack([np.c_[xy, np.zeros(n)], np.c_[xy, np.full(n, h)]])
    faces = []
    for i in range(n):
        j = (i + 1) % n
        faces += [[i, j, n + j], [i, n + j, n + i]]
    for i in range(1, n - 1):
        faces += [[0, i + 1, i], [n, n + i, n + i + 1]]
    return trimesh.Trimesh(verts, np.array(faces), process=False)


def test_a_section_crossing_itself_is_made_valid_and_reported():
    m = _prism(FOLD, 10.0)
    assert m.is_watertight and m.is_winding_consistent  # closed and consistently wound, yet folded
    repairs: list = []
    layers, _ = slice_part_scheduled(
        MeshData(vertices=m.vertices, faces=m.faces, name="fold"), layer_height=2.5, repairs=repairs
    )
    assert len(layers) == 4
    assert all(l.region.is_valid for l in layers)
    # square 400 − the tongue inside it 80 + the tongue outside 40 (the loops' structure: the
    # part of the tongue inside the square winds the other way)
    assert [round(l.region.area, 6) for l in layers] == [360.0] * 4
    assert [r[0] for r in repairs] == [0, 1, 2, 3]
    assert all(r[1] == "Self-intersection[20 12]" and r[2] == 280.0 and r[3] == 360.0 for r in repairs)


def test_valid_regions_pass_unchanged():
    a = shapely.MultiPolygon([shapely.box(0, 0, 10, 10)])
    out = repair_regions([a, shapely.MultiPolygon()], repairs=(got := []))
    assert out[0] is a and got == []


def test_the_slice_node_warns_each_repaired_layer(tmp_path):
    _prism(FOLD, 10.0).export(tmp_path / "fold.stl")
    recipe = {
        "format": "waamflow/1",
        "name": "fold",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "fold.stl"}},
            {"id": "layers", "type": "slice", "params": {"layer_height": 2.5}},
        ],
        "edges": [{"from": "part.mesh", "to": "layers.mesh"}],
    }
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    crossing = [w for w in res.warnings if w["node"] == "layers" and "crosses itself" in w["message"]]
    assert [w["layer"] for w in crossing] == [0, 1, 2, 3]
    assert "self-intersection at (20.00, 12.00) mm" in crossing[0]["message"]
    assert "280.0 → 360.0 mm²" in crossing[0]["message"]


def test_a_self_crossing_loop_of_one_body_crossed_by_another_body_is_united():
    """ros-industrial/abb's IRB 6640 piston.stl: two shells, one folded so its section loop crosses
    itself, the other crossing that loop. The bodies' polygons were united as they were and GEOS
    stopped the slice node with "TopologyException: side location conflict" (exit 3, GEOS's words
    as the message). The folded body's polygon is made valid first, and the repair reported."""
    folded = [(0, 0), (30, 0), (30, 20), (10, 20), (10, -5), (5, -5), (5, 10), (0, 10)]
    square = [(8, 2), (40, 2), (40, 30), (8, 30)]
    loops = Loops(
        coords=np.array(folded + square, dtype=float),
        offsets=np.array([0, len(folded), len(folded) + len(square)]),
        plane=np.array([0, 0]),
        body=np.array([0, 1]),
        void=np.array([False, False]),
    )
    repairs: list = []
    (region,) = loops_to_regions(loops, 1, repairs)
    assert region.is_valid
    assert region.bounds == (0.0, -5.0, 40.0, 30.0)
    assert region.area > 32 * 28  # the square and what the folded body adds
    assert [(r[0], r[1].split("[")[0]) for r in repairs] == [(0, "Self-intersection")]
