"""Where a planned section path deposits, and how much of its section it leaves without a bead.

Footprint of a path: its arc-ON runs buffered by half the bead width (round caps and joins: the
weld pool is round), as `process.coverage` measures it. A weave (oscillate) lays one wide bead:
where two consecutive strokes come back to the same side at most one bead width apart, the pool
bridges them, so the triangle of the three weave vertices is deposited as well (`weave=True`).
Without that bridge the default weave (strokes 3 mm apart, 6 mm bead) would show scallops 3 mm
deep between its vertices along both edges of the section (8 % of a 120 × 16 mm section) that the
continuous weave pool does not leave.

Units: mm, mm². Points are layer-local (x, y).
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import Polygon

from ..process.coverage import arc_runs, footprint

#: Patterns whose path is a weave laying one wide bead (see module doc).
WEAVES = frozenset({"oscillate"})
#: Round-off allowance on "at most one bead width apart" (relative): the default weave's same-side
#: vertices are exactly 2 × 3 mm = 6 mm apart.
_BRIDGE_TOL = 1e-6


def deposit(points: np.ndarray, arc: np.ndarray, bead_width: float, weave: bool = False):
    """Footprint (shapely areal geometry, mm) of the arc-ON beads of a path (see module doc).

    points: (n, 2|3) layer-local mm; arc: (n - 1,) bool; bead_width: mm."""
    runs = [r for r in arc_runs(points, arc) if len(r) >= 2]
    if not runs:
        return Polygon()
    foot = footprint(runs, bead_width)
    if not weave:
        return foot
    limit = bead_width * (1.0 + _BRIDGE_TOL)
    tris = []
    for r in runs:
        if len(r) < 3:
            continue
        a, b, c = r[:-2], r[1:-1], r[2:]
        near = np.hypot(*(c - a).T) <= limit
        if near.any():
            tris.append(shapely.polygons(np.stack([a[near], b[near], c[near], a[near]], axis=1)))
    if not tris:
        return foot
    tri = shapely.union_all(np.concatenate(tris))
    return shapely.union(foot, tri.buffer(bead_width / 2.0, quad_segs=16))


def uncovered(region: Polygon, points: np.ndarray, arc: np.ndarray, bead_width: float, weave: bool = False):
    """The part of `region` no bead of the path reaches (shapely geometry)."""
    foot = deposit(points, arc, bead_width, weave)
    return region.difference(foot) if not foot.is_empty else region


def uncovered_area(
    region: Polygon, points: np.ndarray, arc: np.ndarray, bead_width: float, weave: bool = False
) -> float:
    """Area (mm²) of `region` no bead of the path reaches."""
    return float(uncovered(region, points, arc, bead_width, weave).area)
