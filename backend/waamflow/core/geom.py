"""Small 2D geometry helpers shared by several kernels (sections, paths)."""

from __future__ import annotations

from typing import Any

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon


def default_guide(region: Polygon) -> LineString:
    """The MPP default guide: the long axis of the region's minimum rotated rectangle.

    Returns a 2-point LineString through the rectangle's centre along its longer side, extended
    10 % past the rectangle on both ends so it crosses the region boundary (mm, layer-local).
    """
    rect = shapely.minimum_rotated_rectangle(region)
    c = np.asarray(rect.exterior.coords)[:4]
    e1, e2 = c[1] - c[0], c[2] - c[1]
    axis, across = (e1, e2) if np.linalg.norm(e1) >= np.linalg.norm(e2) else (e2, e1)
    length = float(np.linalg.norm(axis))
    if length == 0.0:
        raise ValueError("degenerate region: no long axis")
    u = axis / length
    # orient deterministically: +x first, then +y
    if u[0] < -1e-12 or (abs(u[0]) <= 1e-12 and u[1] < 0):
        u = -u
    centre = c.mean(axis=0)
    half = 0.55 * length
    return LineString([centre - half * u, centre + half * u])


def opened_hole(uncovered: Any, width: float) -> tuple[float, tuple[float, float] | None]:
    """The area (mm²) of the largest piece of a layer's uncovered geometry at least half a bead wide
    (opened by width / 4) and a point inside it; (0, None) when the uncovered area is under one bead
    width squared (not opened: the preflight's hole_warn_widths is at least 1) or nothing that wide
    is left."""
    if uncovered is None or uncovered.is_empty or float(uncovered.area) < width * width:
        return 0.0, None
    r = width / 4.0
    opened = uncovered.buffer(-r, quad_segs=4).buffer(r, quad_segs=4)
    pieces = [g for g in shapely.get_parts(opened) if not g.is_empty]
    if not pieces:
        return 0.0, None
    big = max(pieces, key=lambda g: g.area)
    p = big.representative_point()
    return float(big.area), (float(p.x), float(p.y))
