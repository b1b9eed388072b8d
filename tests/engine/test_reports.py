"""Node reports: a node states a small structured result with `ctx.report(...)`; the engine keeps
it with the cache entry and writes it into summary.json under the node id, cached re-runs included."""

import json

import pytest
from pydantic import Field

import toy_nodes as toy
from waamflow.core.errors import PlanningError
from waamflow.engine.artifacts import write_run_dir
from waamflow.engine.cache import MemoryCache
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.node import LayerNode, Node, NodeParams, Port, register
from waamflow.engine.recipe import parse_recipe


@register
class ToyReport(Node):
    """Reports the layer count and area of its input (a plain node)."""

    type = "toy-report"
    category = "test"
    inputs = (Port("layers", "layers"),)
    outputs = (Port("toolpath", "toolpath"),)

    class Params(NodeParams):
        payload: int = Field(0, ge=0, description="Extra bytes to report (size limit test)")
        nan: bool = False

    def run(self, ctx, params, inputs):
        toy.CALLS["toy-report"] += 1
        areas = [round(l.area, 3) for l in inputs["layers"] if l is not None]
        ctx.report({"layers": len(areas)})
        ctx.report({"area_mm2": areas, "total_mm2": round(sum(areas), 3)})  # keys merge
        if params.payload:
            ctx.report({"blob": "x" * params.payload})
        if params.nan:
            ctx.report({"bad": float("nan")})
        return {"toolpath": sum(areas)}


@register
class ToyLayerReport(LayerNode):
    """Passes layers through; reports from combine how many it saw."""

    type = "toy-layer-report"
    category = "test"
    inputs = (Port("layers", "layers"),)
    outputs = (Port("layers", "layers"),)

    def run_layer(self, ctx, params, index, items):
        return {"layers": items["layers"]}

    def combine(self, ctx, params, outputs, inputs):
        out = super().combine(ctx, params, outputs, inputs)
        ctx.report({"layers_seen": sum(1 for l in out["layers"] if l is not None)})
        return out


def graph(report=None):
    return build_graph(
        parse_recipe(
            toy.recipe(
                [
                    ("stack", "toy-stack", {"size": 10, "count": 3}),
                    ("pass", "toy-layer-report", {}),
                    ("rep", "toy-report", report or {}),
                ],
                [("stack.layers", "pass.layers"), ("pass.layers", "rep.layers")],
            )
        )
    )


def test_report_in_summary_and_from_the_cache(tmp_path):
    cache = MemoryCache()
    res = execute(graph(), resolver=FileResolver("."), cache=cache)
    s = res.summary("toy")
    assert s["nodes"]["rep"]["report"] == {"layers": 3, "area_mm2": [100.0, 100.0, 100.0], "total_mm2": 300.0}
    assert s["nodes"]["pass"]["report"] == {"layers_seen": 3}
    assert "report" not in s["nodes"]["stack"]  # nodes without a report say nothing
    toy.CALLS.clear()
    again = execute(graph(), resolver=FileResolver("."), cache=cache)
    s2 = again.summary("toy")
    assert toy.CALLS["toy-report"] == 0 and s2["nodes"]["rep"]["cached"]
    assert s2["nodes"]["rep"]["report"] == s["nodes"]["rep"]["report"]
    assert s2["nodes"]["pass"]["report"] == {"layers_seen": 3}
    write_run_dir(tmp_path / "run", again.artifacts, s2)
    on_disk = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert on_disk["nodes"]["rep"]["report"]["total_mm2"] == 300.0


def test_reports_must_be_small_finite_json():
    with pytest.raises(PlanningError, match="over 262144"):
        execute(graph({"payload": 300_000}), resolver=FileResolver("."))
    with pytest.raises(PlanningError, match="finite JSON"):
        execute(graph({"nan": True}), resolver=FileResolver("."))
