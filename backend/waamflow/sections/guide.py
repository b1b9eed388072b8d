"""Guides: the deposition direction of a section (Michel et al. 2019, step 3).

A guide is an open planar polyline. It must cross the section boundary (exterior and holes)
exactly twice; the crossing first met along the guide is where deposition starts, the other where
it stops, and the section keeps the part of the guide between them.

Without a user guide, the section gets `core.geom.default_guide` (long axis of its minimum rotated
rectangle). That line may cross a non-convex region more than twice; since the user did not draw
it, we keep its longest piece inside the region instead of failing (its ends are on the boundary).
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.ops import substring

from ..core.errors import PlanningError, RecipeError
from ..core.geom import default_guide
from ..core.model import Section
from ..core.tolerances import TOL


def guide_line(points: Sequence[Sequence[float]], key: str = "") -> LineString:
    """(k, 2) mm points → LineString, RecipeError when it is not a usable open polyline."""
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 2 or not np.isfinite(pts).all():
        raise RecipeError("a guide needs at least 2 finite [x, y] points", section=key or None)
    line = LineString(pts)
    if line.length <= TOL.min_segment:
        raise RecipeError("guide has no length", section=key or None)
    return line


def guide_crossings(region: Polygon, guide: LineString) -> list[float]:
    """Distances along `guide` (mm, sorted) where it meets the region boundary.

    Points closer than TOL.join along the guide count once (a crossing through a boundary vertex).
    A guide running along the boundary yields its two ends there: it is not a clean crossing, so
    callers must treat any count ≠ 2 as a failure anyway.
    """
    hit = shapely.intersection(guide, region.boundary)
    if hit.is_empty:
        return []
    params: list[float] = []
    for g in shapely.get_parts(hit):
        if isinstance(g, Point):
            params.append(guide.project(g))
        else:  # overlap along the boundary: count both ends
            cs = np.asarray(g.coords)
            params.extend([guide.project(Point(cs[0])), guide.project(Point(cs[-1]))])
    params.sort()
    out: list[float] = []
    for p in params:
        if not out or p - out[-1] > TOL.join:
            out.append(p)
    return out


def _clip(section: Section, guide: LineString, s0: float, s1: float) -> Section:
    clipped = substring(guide, s0, s1)
    cs = np.asarray(clipped.coords)
    return dataclasses.replace(
        section,
        guide=LineString(cs),
        start=(float(cs[0, 0]), float(cs[0, 1])),
        stop=(float(cs[-1, 0]), float(cs[-1, 1])),
    )


def apply_guide(section: Section, guide: LineString | None, *, layer: int | None = None) -> Section:
    """Return `section` with its guide clipped between the two boundary crossings (start → stop).

    guide None → default guide (see module doc). A user guide crossing the boundary other than
    exactly twice raises PlanningError naming the layer and section.
    """
    if guide is None:
        return _default(section, layer)
    xs = guide_crossings(section.region, guide)
    if len(xs) != 2:
        raise PlanningError(
            f"guide crosses the section boundary {len(xs)} times (needs exactly 2)", layer=layer, section=section.key
        )
    return _clip(section, guide, xs[0], xs[1])


def _default(section: Section, layer: int | None) -> Section:
    try:
        line = default_guide(section.region)
    except ValueError as e:
        raise PlanningError(str(e), layer=layer, section=section.key) from e
    inside = [
        g
        for g in shapely.get_parts(shapely.intersection(line, section.region))
        if isinstance(g, LineString) and g.length > TOL.min_segment
    ]
    if not inside:
        raise PlanningError("default guide does not cross the section; draw a guide", layer=layer, section=section.key)
    piece = max(inside, key=lambda g: g.length)
    a, b = line.project(Point(piece.coords[0])), line.project(Point(piece.coords[-1]))
    return _clip(section, line, min(a, b), max(a, b))
