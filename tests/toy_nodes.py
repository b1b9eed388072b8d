"""Toy node types for engine/API tests (registered only when a test imports this module).

`toy-stack` makes square layers; `toy-grow` is a LayerNode that buffers each layer's region by a
per-layer distance; `toy-area` sums areas (a plain node); `toy-fail` raises a PlanningError on a
chosen layer. Call counters let tests see what was recomputed.
"""

from __future__ import annotations

from collections import Counter

import shapely.errors
from pydantic import Field
from shapely.geometry import MultiPolygon, box

from waamflow.core.errors import PlanningError
from waamflow.core.model import Layer, Layered
from waamflow.engine.node import LayerNode, Node, NodeParams, Port, register, unit

CALLS: Counter = Counter()


@register
class ToyStack(Node):
    """Square layers of side `size` mm, `count` of them, `height` mm each."""

    type = "toy-stack"
    category = "test"
    outputs = (Port("layers", "layers"),)

    class Params(NodeParams):
        size: float = Field(10.0, gt=0, json_schema_extra=unit("mm"))
        count: int = Field(5, ge=1, le=10_000)
        height: float = Field(1.5, gt=0, json_schema_extra=unit("mm"))

    def run(self, ctx, params, inputs):
        CALLS["toy-stack"] += 1
        layers = tuple(
            Layer(i, (i + 1) * params.height, params.height, MultiPolygon([box(0, 0, params.size, params.size)]))
            for i in range(params.count)
        )
        return {"layers": Layered(layers)}


@register
class ToyGrow(LayerNode):
    """Buffers each layer's region by `distance` mm (or `per_layer[index]`)."""

    type = "toy-grow"
    category = "test"
    inputs = (Port("layers", "layers"),)
    outputs = (Port("layers", "layers"),)

    class Params(NodeParams):
        distance: float = Field(1.0, json_schema_extra=unit("mm"))
        per_layer: dict[int, float] = Field(default_factory=dict)

    def layer_params(self, params, index, items):
        return params.per_layer.get(index, params.distance)

    def run_layer(self, ctx, params, index, items):
        CALLS["toy-grow"] += 1
        d = params.per_layer.get(index, params.distance)
        layer = items["layers"]
        grown = layer.region.buffer(d, join_style="mitre")
        if d > 5:
            ctx.warn("large growth", layer=index)
        return {"layers": Layer(layer.index, layer.z, layer.thickness, MultiPolygon([grown]))}


@register
class ToyArea(Node):
    """Total area of all layers (mm²)."""

    type = "toy-area"
    category = "test"
    inputs = (Port("layers", "layers"),)
    outputs = (Port("toolpath", "toolpath"),)

    class Params(NodeParams):
        scale: float = 1.0

    def run(self, ctx, params, inputs):
        CALLS["toy-area"] += 1
        total = sum(l.area for l in inputs["layers"] if l is not None) * params.scale
        return {"toolpath": total}

    def artifacts(self, ctx, params, outputs):
        if params.scale < 0:
            raise PlanningError("a negative area cannot be written")
        return {"area.txt": f"{outputs['toolpath']:.3f}"}


@register
class ToyFail(LayerNode):
    """Fails on layer `fail_at` with a PlanningError naming section 'bs1/A'."""

    type = "toy-fail"
    category = "test"
    inputs = (Port("layers", "layers"),)
    outputs = (Port("layers", "layers"),)

    class Params(NodeParams):
        fail_at: int = -1
        geos: bool = False  # fail as the geometry kernel does instead

    def run_layer(self, ctx, params, index, items):
        if index == params.fail_at and params.geos:
            raise shapely.errors.GEOSException(
                "TopologyException: side location conflict at -83.636605329297936 -15.387182998070729. "
                "This can occur if the input geometry is invalid."
            )
        if index == params.fail_at:
            raise PlanningError("curve yields 2 regions", section="bs1/A")
        return {"layers": items["layers"]}


def recipe(nodes, edges, inputs=None, name="toy"):
    return {
        "format": "waamflow/1",
        "name": name,
        "inputs": inputs or {},
        "nodes": [{"id": i, "type": t, "params": p} for i, t, p in nodes],
        "edges": [{"from": a, "to": b} for a, b in edges],
    }


def chain(grow=None, area=None, stack=None, inputs=None):
    return recipe(
        [("stack", "toy-stack", stack or {}), ("grow", "toy-grow", grow or {}), ("area", "toy-area", area or {})],
        [("stack.layers", "grow.layers"), ("grow.layers", "area.layers")],
        inputs,
    )


@register
class ToyReads(Node):
    """Sums the numbers in the files named (one per line) in `listing`, a plain string param:
    the node tells the engine what it reads (`read_files`), as simulate-robot does for a cell."""

    type = "toy-reads"
    category = "test"
    outputs = (Port("toolpath", "toolpath"),)

    class Params(NodeParams):
        listing: str = ""

    def read_files(self, params, read_bytes):
        data = read_bytes(params.listing) if params.listing else None
        names = data.decode().split() if data is not None else []
        return [params.listing, *names] if params.listing else []

    def run(self, ctx, params, inputs):
        CALLS["toy-reads"] += 1
        names = ctx.read_text(params.listing).split()
        return {"toolpath": sum(float(ctx.read_text(n)) for n in names)}
