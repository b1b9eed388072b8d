"""features and wall-path nodes through the engine on the shipped stiffened-panel recipe."""

import json
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


@pytest.fixture(scope="module")
def panel():
    recipe = json.loads((GRAPHS / "thin-wall-panel.json").read_text())
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(GRAPHS))


def test_features_json_as_contract(panel):
    doc = json.loads(panel.artifacts["features.features.json"])
    assert set(doc) == {"features"}
    counts = Counter(f["kind"] for f in doc["features"])
    assert counts == {
        "t_crossing": 9,
        "corner": 4,
        "direct_crossing": 2,
        "four_direct_crossing": 1,
        "free_end": 1,
        "tubular": 1,
    }
    assert all(len(f["point"]) == 2 for f in doc["features"])
    assert [f["isolated"] for f in doc["features"] if f["kind"] == "tubular"] == [True]


def test_wall_path_toolpath(panel):
    doc = json.loads(panel.artifacts["walls.toolpath.json"])
    layers = doc["layers"]
    assert len(layers) == 15 and [l["z"] for l in layers[:2]] == [2.0, 4.0]
    # the isolated tube is one helix in layer 0: 15 laps, pitch = layer height 2 mm
    tube = [s for l in layers for s in l["sections"] if s["key"] == "tube0"]
    assert len(tube) == 1 and tube[0]["strategy"] == "helical"
    pts = np.array(tube[0]["points"])
    assert pts[0, 2] == 2.0 and pts[-1, 2] == 30.0
    assert tube[0]["length_mm"] == pytest.approx(15 * 2 * 48 * 8 * np.sin(np.pi / 48) + 0.0, rel=2e-3)
    # every other layer: the same 20 wall entities, 5 mm/s, arc on everywhere
    walls = [s for s in layers[3]["sections"]]
    assert len(walls) == 20 and all(s["key"].startswith("wall") for s in walls)
    assert all(v == 5.0 for s in walls for v in s["speed"]) and all(all(s["arc"]) for s in walls)
    # the stub's free end is extended 5 mm beyond y = 100 (arc start/stop outside the wall)
    ends = [p for s in walls for p in (s["points"][0], s["points"][-1])]
    assert any(abs(p[0] - 175) < 1e-6 and abs(p[1] - 105) < 1e-6 for p in ends)


def test_gcode_dwells_after_ignition(panel):
    gcode = panel.artifacts["post.gcode"]
    gcode = (gcode.decode() if isinstance(gcode, bytes) else gcode).splitlines()
    ons = [i for i, line in enumerate(gcode) if line.split(";")[0].strip() == "M3"]
    assert len(ons) == 1 + 20 * 15  # helix once, then every wall every layer
    assert all(gcode[i + 1].startswith("G4 P0.5") for i in ons)


def test_dxf_panel_gives_the_same_features(tmp_path):
    import ezdxf

    doc = ezdxf.new(units=4)
    msp = doc.modelspace()
    for a, b in [
        ((0, 0), (200, 0)),
        ((200, 0), (200, 120)),
        ((200, 120), (0, 120)),
        ((0, 120), (0, 0)),  # skin
        ((0, 60), (100, 60)),
        ((100, 60), (200, 60)),
        ((50, 0), (50, 120)),
        ((100, 0), (100, 60)),
        ((100, 60), (100, 120)),
        ((150, 0), (150, 120)),
        ((175, 60), (175, 100)),
    ]:
        msp.add_line(a, b)
    msp.add_circle((125, 90), 8)
    doc.saveas(tmp_path / "panel.dxf")
    recipe = json.loads((GRAPHS / "thin-wall-panel.json").read_text())
    recipe["nodes"][0]["params"]["path"] = "panel.dxf"
    recipe["nodes"] = [n for n in recipe["nodes"] if n["id"] in ("sketch", "layers", "features")]
    recipe["edges"] = [e for e in recipe["edges"] if e["to"] in ("layers.mesh", "features.layers")]
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    counts = Counter(f["kind"] for f in json.loads(res.artifacts["features.features.json"])["features"])
    assert counts == {
        "t_crossing": 9,
        "corner": 4,
        "direct_crossing": 2,
        "four_direct_crossing": 1,
        "free_end": 1,
        "tubular": 1,
    }


def test_helix_per_run_of_layers():
    from shapely.geometry import LineString

    from waamflow.core.model import Layer, Layered
    from waamflow.engine.node import REGISTRY, load_nodes

    load_nodes()
    t = np.linspace(0, 2 * np.pi, 37)
    tube = LineString(np.column_stack([8 * np.cos(t), 8 * np.sin(t)]))
    tube = LineString(list(tube.coords)[:-1] + [tube.coords[0]])
    wall = LineString([(40, 0), (80, 0)])
    # the tube exists on layers 0-2 and 5-6, the wall on every layer
    layers = Layered(
        tuple(Layer(i, 2.0 * (i + 1), 2.0, curves=(wall, tube) if i in (0, 1, 2, 5, 6) else (wall,)) for i in range(7))
    )

    class Ctx:
        def warn(self, *a, **k):
            pass

        def check_cancelled(self):
            pass

    node = REGISTRY["wall-path"]()
    out = node.run(Ctx(), node.Params(), {"layers": layers})["toolpath"]
    helices = [(lp.index, sp) for lp in out for sp in lp.sections if sp.strategy == "helical"]
    assert [i for i, _ in helices] == [0, 5]
    z0 = helices[0][1].points[:, 2]
    z5 = helices[1][1].points[:, 2]
    assert (z0.min(), z0.max()) == (2.0, 6.0) and (z5.min(), z5.max()) == (12.0, 14.0)


def test_the_same_warning_at_many_crossings_is_said_once_with_a_count(tmp_path):
    """pythonocc-demos' Ventilator.stp through wall-path: 51 warnings, 17 of them "direct_crossing
    at [x, y]: influence_radius 10 mm is below 20.1 mm …" (one per blade crossing, the numbers
    differing) and 17 "wall piece at [x, y] lies inside the cutting circle: dropped". Notes that
    differ only in their numbers are said once, with how many more and on which layers."""
    skew = [[[0.0, y], [120.0, y + 60.0]] for y in (0.0, 30.0, 60.0)]  # three parallel walls
    cross = [[[x, -10.0], [x, 140.0]] for x in (30.0, 60.0, 90.0)]  # three walls across them at 63°
    (tmp_path / "grid.json").write_text(json.dumps({"curves": skew + cross, "height": 6.0}))
    recipe = {
        "format": "waamflow/1",
        "name": "grid",
        "nodes": [
            {"id": "sketch", "type": "sketch", "params": {"path": "grid.json"}},
            {"id": "layers", "type": "slice", "params": {"layer_height": 2.0}},
            {"id": "features", "type": "features", "params": {}},
            {"id": "walls", "type": "wall-path", "params": {"bead_width": 5.0, "influence_radius": 3.0}},
        ],
        "edges": [
            {"from": "sketch.mesh", "to": "layers.mesh"},
            {"from": "layers.layers", "to": "features.layers"},
            {"from": "layers.layers", "to": "walls.layers"},
            {"from": "features.features", "to": "walls.features"},
        ],
    }
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    crossing = [w["message"] for w in res.warnings if w["node"] == "walls" and "influence_radius" in w["message"]]
    assert len(crossing) == 1, crossing
    assert crossing[0].endswith("(and 8 more like it, on layer 0)")
