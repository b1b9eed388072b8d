"""Layers of the toolpath that the parameter file has no values for are warned by the zone node:
mpp-cross at 1.2 mm layers (10 layers; its params.xml sets layers 0-7) welded layers 8 and 9 with
no current or wire feed commanded, on whatever the machine held from layer 7's end zone (0.56x
the metal of their slabs against 1.23x for the others), with 0 warnings (the docs' own example)."""

from __future__ import annotations

from pathlib import Path

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def _run(sets: list[str]):
    g = build_graph(apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set(sets)))
    return execute(g, resolver=FileResolver(GRAPHS), workers=1)


def _zone_warnings(res) -> list:
    return [w for w in res.warnings if w["node"] == "zone"]


def test_layers_missing_from_the_parameter_file_are_warned():
    res = _run(["layers.layer_height=1.2", "layers.layer_count=null"])
    (w,) = [w for w in _zone_warnings(res) if "no values for layers" in w["message"]]
    assert "layers 8-9" in w["message"] and "mpp-cross.params.xml" in w["message"] and w["layer"] == 8
    # the preflight sees what they weld: a layer's metal off the program's typical layer's
    checks = {(p["check"], p["severity"]) for p in res.preflight["problems"]}
    assert ("layer_volume_ratio", "fail") in checks


def test_the_shipped_layers_are_all_in_the_file():
    res = _run([])
    assert not [w for w in _zone_warnings(res) if "no values for layers" in w["message"]]
    assert res.preflight["verdict"] == "ok"
