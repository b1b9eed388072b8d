"""Every wall junction is in features.json as `corner` or `continuous` with its angle — also
where the sketch joined two walls end to end into one polyline (a sketch built here)."""

import json
import math
from collections import Counter

import pytest

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe


def _features(tmp_path, curves, join=True):
    (tmp_path / "s.json").write_text(json.dumps({"curves": curves}))
    recipe = {
        "format": "waamflow/1",
        "name": "j",
        "nodes": [
            {"id": "sketch", "type": "sketch", "params": {"path": "s.json", "height": 4.0, "join": join}},
            {"id": "layers", "type": "slice", "params": {"layer_height": 2.0}},
            {"id": "features", "type": "features", "params": {"corner_angle_deg": 30.0}},
        ],
        "edges": [{"from": "sketch.mesh", "to": "layers.mesh"}, {"from": "layers.layers", "to": "features.layers"}],
    }
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    return [f for f in json.loads(res.artifacts["features.features.json"])["features"] if f["layer"] == 0]


@pytest.mark.parametrize("join", [True, False])
def test_shallow_end_to_end_walls_give_a_continuous_junction(tmp_path, join):
    # wall A along +x, wall B turning 10° left at (60, 0), wall C turning 90° at its end
    turn = math.radians(10)
    b_end = (60 + 50 * math.cos(turn), 50 * math.sin(turn))
    c_end = (b_end[0] - 40 * math.sin(turn), b_end[1] + 40 * math.cos(turn))
    feats = _features(tmp_path, [[[0, 0], [60, 0]], [[60, 0], list(b_end)], [list(b_end), list(c_end)]], join)
    counts = Counter(f["kind"] for f in feats)
    assert counts == {"free_end": 2, "continuous": 1, "corner": 1}
    cont = next(f for f in feats if f["kind"] == "continuous")
    assert cont["point"] == pytest.approx([60, 0], abs=1e-6)
    assert cont["angle_deg"] == pytest.approx(170.0, abs=1e-3)  # angle between the walls
    corner = next(f for f in feats if f["kind"] == "corner")
    assert corner["point"] == pytest.approx(list(b_end), abs=1e-6)
    assert corner["angle_deg"] == pytest.approx(90.0, abs=1e-3)


def test_closed_loop_of_joined_walls_reports_every_junction(tmp_path):
    # a square drawn as four separate walls: joined into one closed curve, four 90° corners
    sq = [[[0, 0], [50, 0]], [[50, 0], [50, 50]], [[50, 50], [0, 50]], [[0, 50], [0, 0]]]
    feats = _features(tmp_path, sq)
    corners = [f for f in feats if f["kind"] == "corner"]
    assert len(corners) == 4 and all(f["angle_deg"] == pytest.approx(90.0) for f in corners)
    # a hexagon-ish loop of walls turning 20° each: 18 continuous junctions, no corners
    n, r = 18, 60.0
    pts = [[r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n)] for k in range(n)]
    feats = _features(tmp_path, [[pts[k], pts[(k + 1) % n]] for k in range(n)])
    counts = Counter(f["kind"] for f in feats)
    assert counts["continuous"] == n and counts["corner"] == 0
    assert all(f["angle_deg"] == pytest.approx(160.0, abs=1e-6) for f in feats if f["kind"] == "continuous")
