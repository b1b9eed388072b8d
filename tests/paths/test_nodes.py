"""The `strategy` and `rectangle` nodes: thin adapters, checked through the engine and by hand."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from shapely.geometry import LineString, MultiPolygon, Polygon, box

from waamflow.core.errors import PlanningError, RecipeError
from waamflow.core.model import Layer, LayerSections, Section
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.node import load_nodes
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_recipe

from . import helpers as h

ROOT = Path(__file__).resolve().parents[2]
REGISTRY = load_nodes()
Strategy = REGISTRY["strategy"]


def run(nodes, edges, inputs=None):
    data = {
        "format": "waamflow/1",
        "name": "t",
        "inputs": inputs or {},
        "nodes": nodes,
        "edges": [{"from": a, "to": b} for a, b in edges],
    }
    return execute(build_graph(parse_recipe(data)), resolver=FileResolver("."))


def study_graph(strategy_params, width=21.5, length=43, layers=1):
    return run(
        [
            {
                "id": "or",
                "type": "rectangle",
                "params": {"length": length, "width": width, "layer_count": layers, "layer_height": 2.0},
            },
            {"id": "mask", "type": "mask", "params": {"masks": []}},
            {"id": "strategy", "type": "strategy", "params": strategy_params},
        ],
        [("or.layers", "mask.layers"), ("mask.sections", "strategy.sections")],
    )


def test_rectangle_layers():
    res = study_graph({"default": {"pattern": "raster"}}, layers=3)
    layers = res.outputs["or"]["layers"]
    assert len(layers) == 3
    assert [l.z for l in layers] == [2.0, 4.0, 6.0]
    assert all(l.area == pytest.approx(43 * 21.5) for l in layers)


@pytest.mark.parametrize(
    "pattern, expected",
    [("raster", h.raster(43, 21.5)), ("spiral", h.spiral(43, 21.5)), ("rectangular", h.rectangular(43, 21.5))],
)
def test_study_graph_toolpath_and_artifacts(pattern, expected):
    res = study_graph({"default": {"pattern": pattern, "speed": 20}, "compare": ["raster", "triangular:60"]}, layers=2)
    tp = res.outputs["strategy"]["toolpath"]
    assert len(tp) == 2
    for lp in tp:
        (sp,) = lp.sections
        assert sp.strategy == pattern
        assert sp.length == pytest.approx(expected, abs=1e-4)
        assert np.all(sp.points[:, 2] == lp.layer.z)
        assert np.all(sp.speed == 20)
        assert sp.zone == ()
    doc = json.loads(res.artifacts["strategy.toolpath.json"])
    assert doc["layers"][1]["sections"][0]["length_mm"] == pytest.approx(expected, abs=1e-3)
    summary = json.loads(res.artifacts["strategy.paths.json"])
    assert summary["total"]["programmed_length_mm"] == pytest.approx(2 * expected, abs=1e-2)
    assert summary["total"]["time_s"] == pytest.approx(2 * expected / 20, abs=1e-2)
    comp = json.loads(res.artifacts["strategy.comparison.json"])
    rows = {r["label"]: r for r in comp["patterns"]}
    assert rows["raster"]["programmed_length_mm"] == pytest.approx(2 * 387.910, abs=1e-2)
    assert rows["raster"]["arc_switches"] == 20
    assert rows["triangular:60"]["programmed_length_mm"] == pytest.approx(2 * h.triangular(43, 21.5, 60), abs=1e-2)
    assert rows["triangular:60"]["outside_share"] == pytest.approx(35.44 / h.triangular(43, 21.5, 60), abs=1e-4)
    assert comp["lowest"]["programmed_length_mm"] == ["triangular:60"]
    svg = res.artifacts["strategy.comparison.svg"].decode()
    assert svg.startswith("<svg") and svg.count("<rect") == 1 + 6 * 2
    # the pattern in use is drawn darker, in each of the six panels
    assert svg.count('fill="#b85c00"') == (6 if pattern == "raster" else 0)


def test_no_comparison_by_default():
    res = study_graph({"default": {"pattern": "raster"}})
    assert "strategy.comparison.json" not in res.artifacts
    assert "strategy.toolpath.json" in res.artifacts


def _layer_sections():
    layer = Layer(index=4, z=7.5, thickness=1.5, region=MultiPolygon([box(0, 0, 100, 30)]))
    a = Section(
        "bs1/A",
        box(0, 0, 43, 21.5),
        order=0,
        guide=LineString([(0, 10.75), (43, 10.75)]),
        start=(0, 10.75),
        stop=(43, 10.75),
    )
    b = Section("bs1/B", box(50, 0, 100, 30), order=1)  # no guide: long axis of its rectangle
    return LayerSections(layer, (a, b))


def test_overrides_and_section_order():
    node = Strategy()
    params = Strategy.Params.model_validate(
        {
            "default": {"pattern": "oscillate", "speed": 8, "bead_width": 6, "step": 3},
            "sections": {
                "bs1/A": {"pattern": "triangular", "angle_deg": 60, "arc_outside": "off"},
                "bs9/Z": {"speed": 3},
            },
        }
    )
    out = node.run_layer(None, params, 4, {"sections": _layer_sections()})["toolpath"]
    a, b = out.sections
    assert (a.key, a.strategy, b.key, b.strategy) == ("bs1/A", "triangular", "bs1/B", "oscillate")
    assert a.length == pytest.approx(h.triangular(43, 21.5, 60), abs=1e-6)
    assert a.arc.sum() < len(a.arc) and np.all(a.arc <= a.inside)  # arc off on the outside links
    assert np.all(a.speed == 8) and np.all(b.speed == 8)
    assert np.all(a.points[:, 2] == 7.5)
    # B oscillates along its long (x) axis: 50 mm in ≤ 3 mm steps → 17 strokes
    assert len(b.points) - 1 == math.ceil(50 / 3)
    assert b.points[:, 1].min() == pytest.approx(3.0) and b.points[:, 1].max() == pytest.approx(27.0)


def test_layer_params_only_sections_present():
    params = Strategy.Params.model_validate(
        {"default": {"pattern": "parallel"}, "sections": {"bs1/A": {"step": 2}, "bs2/A": {"step": 5}}}
    )
    lp = Strategy().layer_params(params, 4, {"sections": _layer_sections()})
    assert lp["sections"] == {"bs1/A": {"step": 2.0}}
    assert lp["default"]["pattern"] == "parallel"


@pytest.mark.parametrize(
    "params",
    [
        {"default": {"pattern": "zigzag"}},
        {"default": {"pattern": "raster", "colour": 1}},
        {"sections": {"bs1/A": {"pattern": "nope"}}},
        {"sections": {"bs1/A": {"spacing": -1}}},
        {"default": {"angle_deg": 180}},
        {"compare": ["raster", "helix"]},
        {"compare": ["triangular:200"]},
    ],
)
def test_bad_params_are_recipe_errors(params):
    with pytest.raises(RecipeError):
        study_graph(params)


def test_section_too_small_is_a_planning_error_naming_layer_and_section():
    node = Strategy()
    params = Strategy.Params.model_validate({"default": {"pattern": "spiral", "spacing": 4.43}})
    layer = Layer(index=2, z=3.0, thickness=1.5, region=MultiPolygon([box(0, 0, 40, 1)]))
    flat = Polygon([(0, 0), (20, 0), (40, 0)])  # zero area: nothing to fill
    ls = LayerSections(layer, (Section("bs1/A", flat),))
    with pytest.raises(PlanningError) as e:
        node.run_layer(None, params, 2, {"sections": ls})
    assert e.value.layer == 2 and e.value.section == "bs1/A"


def test_rectangle_study_recipe_inputs_match_the_contract():
    data = json.loads((ROOT / "graphs" / "rectangle-study.json").read_text())
    assert data["format"] == "waamflow/1"
    assert data["inputs"] == {
        "length": 43,
        "width": 21.5,
        "spacing": 4.43,
        "pattern": "raster",
        "angle_deg": 45,
        "arc_outside": "on",
        "speed": 10,
        "cdis": 5,
        "wire_feed_mm3_s": 94.25,
        "compensate": "off",
    }  # v2 (issue 16): wire-feed compensation off | on
    sim = [n for n in data["nodes"] if n["id"] == "simulate"]
    assert sim and sim[0]["type"] == "simulate-robot"
    assert sim[0]["params"]["cdis"] == "$cdis" and sim[0]["params"]["wire_feed_mm3_s"] == "$wire_feed_mm3_s"


@pytest.mark.parametrize(
    "pattern, arc_outside, expected, switches",
    [
        ("raster", "on", h.raster(43, 21.5), 10),
        ("semicircular", "off", 242.603, 10),
        ("triangular", "on", h.triangular(43, 21.5, 45), 2),
        ("spiral", "on", h.spiral(43, 21.5), 2),
        ("swiping", "on", 464.246, 2),
    ],
)
def test_rectangle_study_recipe_runs_end_to_end(pattern, arc_outside, expected, switches):
    path = ROOT / "graphs" / "rectangle-study.json"
    recipe = apply_overrides(load_recipe(path), [("pattern", pattern), ("arc_outside", arc_outside)])
    res = execute(build_graph(recipe), resolver=FileResolver(path.parent))
    sim = json.loads(res.artifacts["simulate.simulation.json"])
    assert sim["programmed_length_mm"] == pytest.approx(expected, rel=0.01)
    paths = json.loads(res.artifacts["strategy.paths.json"])
    assert paths["total"]["arc_switches"] == switches
    comp = json.loads(res.artifacts["strategy.comparison.json"])
    assert len(comp["patterns"]) == 11


def test_comparison_is_memoised_on_section_signatures(monkeypatch):
    from waamflow.engine.cache import MemoryCache
    from waamflow.nodes import strategy as mod

    calls = []
    real = mod._compare_sections
    monkeypatch.setattr(mod, "_compare_sections", lambda s, p: calls.append(1) or real(s, p))
    data = {
        "format": "waamflow/1",
        "name": "t",
        "inputs": {},
        "edges": [{"from": "or.layers", "to": "mask.layers"}, {"from": "mask.sections", "to": "strategy.sections"}],
        "nodes": [
            {"id": "or", "type": "rectangle", "params": {}},
            {"id": "mask", "type": "mask", "params": {"masks": []}},
            {"id": "strategy", "type": "strategy", "params": {"compare": ["raster", "spiral"]}},
        ],
    }
    cache = MemoryCache()
    first = execute(build_graph(parse_recipe(data)), resolver=FileResolver("."), cache=cache)
    second = execute(build_graph(parse_recipe(data)), resolver=FileResolver("."), cache=cache)
    assert len(calls) == 1
    assert first.artifacts["strategy.comparison.json"] == second.artifacts["strategy.comparison.json"]
    data["nodes"][0]["params"] = {"width": 43, "length": 86}  # other sections → recomputed
    third = execute(build_graph(parse_recipe(data)), resolver=FileResolver("."), cache=cache)
    assert len(calls) == 2
    rows = json.loads(third.artifacts["strategy.comparison.json"])["patterns"]
    assert rows[0]["programmed_length_mm"] == pytest.approx(h.raster(86, 43), abs=1e-2)
