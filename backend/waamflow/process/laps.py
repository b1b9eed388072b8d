"""A layer's view of a toolpath: what is welded within its height, a helix's lap included.

A section that climbs through several layers' heights in one go (`interpass.climb`: wall-path's
helix, laid in its first layer with one ignition) belongs to the layer it starts in; a view of one
layer (the mask canvas) shows each layer the lap welded within that layer's height, and says which
helix it is part of."""

from __future__ import annotations

import weakref
from collections import OrderedDict

import numpy as np

from ..core.model import Layered, LayerPaths, SectionPath
from .interpass import Spanning, climb


def lap_in_layer(sp: SectionPath, top: float, thickness: float) -> SectionPath | None:
    """The stretch of a climbing section whose segments' midpoints lie within (top − thickness,
    top] (planar layers: z, mm), as one section path; None when none does."""
    p = np.asarray(sp.points, float)
    mid = 0.5 * (p[:-1, 2] + p[1:, 2])
    tol = 1e-6 * max(1.0, abs(top))
    seg = np.flatnonzero((mid > top - thickness + tol) & (mid <= top + tol))
    if not len(seg):
        return None
    a, b = int(seg[0]), int(seg[-1]) + 1  # a helix's lap is one stretch: from its first segment to its last
    return SectionPath(
        sp.key,
        sp.strategy,
        p[a : b + 1],
        np.asarray(sp.arc)[a:b],
        np.asarray(sp.inside)[a:b],
        np.asarray(sp.speed)[a:b],
        zone=tuple(sp.zone[a:b]) if sp.zone else (),
        zone_colors=dict(sp.zone_colors),
        zone_params={k: dict(v) for k, v in sp.zone_params.items()},
        tool_axis=None if sp.tool_axis is None else np.asarray(sp.tool_axis)[a : b + 1],
        tool=sp.tool,
        tool_params=dict(sp.tool_params),
    )


#: climb() of the sections other layers' views ask about, by section object, held weakly (a
#: preview's layers come from the server's cache: the same objects request after request).
#: Measuring all 420 sections of graphs/bracket.json each preview cost 6 ms of the canvas's ~10 ms.
_CLIMBS: OrderedDict[int, tuple[weakref.ref, Spanning | None]] = OrderedDict()
_CLIMBS_SIZE = 20_000


def _climb(sp: SectionPath, lp: LayerPaths) -> Spanning | None:
    hit = _CLIMBS.get(id(sp))
    if hit is not None and hit[0]() is sp:
        return hit[1]
    span = climb(sp, lp.layer)
    _CLIMBS[id(sp)] = (weakref.ref(sp), span)
    if len(_CLIMBS) > _CLIMBS_SIZE:
        _CLIMBS.popitem(last=False)
    return span


def layer_view(toolpath: Layered | None, lp: LayerPaths) -> list[tuple[SectionPath, Spanning | None]]:
    """The sections welded within layer `lp`'s height: its own (a helix of its own cut to its first
    lap), and the laps of helices laid in other layers of `toolpath` that climb through it, each
    with its `Spanning` (None for a section of one layer). Planar layers only cut laps: a fan
    layer's sections come as they are."""
    out: list[tuple[SectionPath, Spanning | None]] = []
    planar = lp.layer.frame is None
    for sp in lp.sections:
        span = _climb(sp, lp) if planar else None
        lap = lap_in_layer(sp, lp.layer.z, lp.layer.thickness) if span is not None else None
        out.append((lap, span) if lap is not None else (sp, None))
    if toolpath is None or not planar:
        return out
    for other in toolpath.items:
        if other is None or other is lp or other.layer.index == lp.layer.index or other.layer.frame is not None:
            continue
        for sp in other.sections:
            span = _climb(sp, other)
            if span is None or not (span.z_from < lp.layer.z + 1e-9 and span.z_to > lp.layer.z - lp.layer.thickness):
                continue
            lap = lap_in_layer(sp, lp.layer.z, lp.layer.thickness)
            if lap is not None:
                out.append((lap, span))
    return out
