"""Layers welded in an order the torch cannot follow (planar programs).

A layer welded below metal welded before it at the same place, or at its height, drives the torch
into that metal (or lays a second bead where one already stands). Before this check a program
that swapped two layers (z 1.5, 3.0, 6.0, 4.5) or welded one twice passed the preflight with a
stacked-starts warning: every layer's coverage, the top and the wire balance (1.3×: a warning)
held. The layers are taken in program order; one that does not rise above every layer before it
by `MIN_RISE` of a layer height is compared with the layers before it that are not clearly below
it, by the overlap of their beads' footprints. A normal program rises every layer and costs one
comparison a layer; towers built one after the other never overlap.
"""

from __future__ import annotations

from typing import Any, Callable, Sequence

from .read.core import Run

MIN_RISE = 0.1  # of the typical layer height: less is no rise (a thin last layer rises 0.3 or more)
MIN_OVERLAP = 0.25  # of a bead width squared: a touch of two footprints' round ends is no overlap


def layer_order_problems(
    layers: Sequence[tuple[int, list[Run]]],
    heights: Sequence[float],
    h: float | None,
    width: float,
    rep: Any,
    s: Any,
    footprint: Callable[[list, float], Any],
) -> None:
    """The `layer_order` problems (`s.layer_order`) of planar layers in program order; heights:
    each layer's z (the median of its arc-ON points), h: the typical layer height."""
    if s.layer_order == "off" or not h or h <= 0 or len(layers) < 2:
        return
    feet: dict[int, Any] = {}

    def foot(k: int) -> Any:
        if k not in feet:
            feet[k] = footprint([r.points[:, :2] for r in layers[k][1] if len(r.points) > 1], width)
        return feet[k]

    top = heights[0]
    for k in range(1, len(layers)):
        z = heights[k]
        if z >= top + MIN_RISE * h:  # above everything welded before
            top = z
            continue
        top = max(top, z)
        for j in range(k):
            if heights[j] <= z - MIN_RISE * h:
                continue  # clearly below: the layer stands on it
            common = foot(k).intersection(foot(j))
            if common.area <= MIN_OVERLAP * width * width:
                continue
            zj = heights[j]
            where = "above it" if zj > z + MIN_RISE * h else "at its height"
            pt = common.representative_point()
            rep.problem(
                "layer_order",
                s.layer_order,
                f"layer {layers[k][0]} (z {z:.3f}) is welded after layer {layers[j][0]} (z {zj:.3f}), {where}, "
                f"where their beads overlap ({common.area:.0f} mm² around ({pt.x:.1f}, {pt.y:.1f})): the torch "
                "would weld into metal already deposited. Build the layers bottom-up (the sequence's order, or "
                "the program's layer order)",
                layer=layers[k][0],
                section=layers[k][1][0].section,
                value=z - zj,
                limit=MIN_RISE * h,
                point=(pt.x, pt.y, z),
            )
            break
