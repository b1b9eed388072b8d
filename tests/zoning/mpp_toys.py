"""Test-only node types for running the MPP nodes through the engine without the slicer/strategy.

`toy-mpp-walls`: layers of a 100 × 6 mm wall that opens a 20 mm window (two regions) from layer
`window_from` up. `toy-mpp-pass`: one bead along each section's clipped guide (a stand-in for the
strategy node, which belongs to the strategy library).
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import shapely
from pydantic import Field
from shapely.geometry import box

from waamflow.core.model import Layer, LayerPaths, Layered, SectionPath, as_multipolygon
from waamflow.engine.node import LayerNode, Node, NodeParams, Port, register

CALLS: Counter = Counter()


@register
class ToyWalls(Node):
    """Wall layers (100 × 6 mm, 1.5 mm high) with a window (two regions) from `window_from` up."""

    type = "toy-mpp-walls"
    category = "test"
    outputs = (Port("layers", "layers"),)

    class Params(NodeParams):
        count: int = Field(10, ge=1, le=100_000)
        window_from: int = Field(10**6, ge=0)

    def run(self, ctx, params, inputs):
        full = as_multipolygon(box(0, 0, 100, 6))
        split = as_multipolygon(shapely.union(box(0, 0, 40, 6), box(60, 0, 100, 6)))
        return {
            "layers": Layered(
                tuple(
                    Layer(i, 1.5 * (i + 1), 1.5, split if i >= params.window_from else full)
                    for i in range(params.count)
                )
            )
        }


@register
class ToyPass(LayerNode):
    """One bead per section along its clipped guide at 5 mm/s (stand-in strategy)."""

    type = "toy-mpp-pass"
    category = "test"
    inputs = (Port("sections", "sections"),)
    outputs = (Port("toolpath", "toolpath"),)
    over = "sections"

    def run_layer(self, ctx, params, index, items):
        CALLS["toy-mpp-pass"] += 1
        ls = items["sections"]
        paths = []
        for s in ls.sections:
            pts = ls.layer.to_world(np.asarray(s.guide.coords))
            n = len(pts) - 1
            paths.append(SectionPath(s.key, "pass", pts, np.ones(n, bool), np.ones(n, bool), np.full(n, 5.0)))
        return {"toolpath": LayerPaths(ls.layer, tuple(paths))}
