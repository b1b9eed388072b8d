"""Parallel (MPP, Michel et al. 2019, §strategies): equidistant passes parallel to the guide,
linked at alternating ends; follows curved guides.

The section's extent across the guide (t_min..t_max, measured on normals every W_WB/2 mm along the
guide) gives the pass count and boundary margin by the study's rule (`pass_layout`); pass k is the
guide offset by t_min + W_bound + k·W_WB (the guide is first extended tangentially so every offset
reaches the boundary), clipped to the section from its first entry to its last exit. Passes
alternate in direction and are joined by straight links; each pass gets the run-ups.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon
from shapely.ops import substring

from .flags import Draft
from .frame import NUDGE, cross_chord, extend_line, guide_or_default, pass_layout
from .oscillate import stations
from .spec import StrategySpec


def _clip_span(line: LineString, region: Polygon) -> LineString | None:
    inter = line.intersection(region)
    if inter.is_empty:
        return None
    s = shapely.line_locate_point(line, shapely.points(shapely.get_coordinates(inter)))
    a, b = float(s.min()), float(s.max())
    if b - a <= 1e-9:
        return None
    return substring(line, a, b)


def _single(curve) -> LineString:
    """An offset of a strongly curved guide may come back in pieces: keep the longest."""
    parts = [g for g in shapely.get_parts(shapely.line_merge(curve) if curve.geom_type != "LineString" else curve)
             if g.geom_type == "LineString"]
    return max(parts, key=lambda g: g.length)


def plan(region: Polygon, guide: LineString | None, spec: StrategySpec) -> Draft:
    g = guide_or_default(region, guide)
    x0, y0, x1, y1 = region.bounds
    reach = 2.0 * math.hypot(x1 - x0, y1 - y0)
    pts, normals = stations(region, g, spec.spacing / 2.0)
    probe = region.buffer(NUDGE, join_style="mitre")
    lims = np.array([cross_chord(probe, p, n, reach) for p, n in zip(pts, normals)])
    t_min, t_max = float(lims[:, 0].min()) + NUDGE, float(lims[:, 1].max()) - NUDGE
    count, margin = pass_layout(t_max - t_min, spec.spacing)
    long_guide = extend_line(g, reach, reach)
    out: list[np.ndarray] = []
    for k in range(count):
        off = t_min + margin + k * spec.spacing
        curve = long_guide if abs(off) < 1e-12 else _single(long_guide.offset_curve(off))
        piece = _clip_span(curve, region)
        if piece is None:
            continue
        c = np.asarray(extend_line(piece, spec.extension_before, spec.extension_after).coords
                       if len(out) % 2 == 0 else
                       extend_line(shapely.reverse(piece), spec.extension_before, spec.extension_after).coords)
        out.append(c)
    if not out:
        raise ValueError("no parallel pass fits the section")
    p = np.vstack(out)
    return Draft(p, np.ones(len(p) - 1, dtype=bool))
