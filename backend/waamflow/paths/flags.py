"""From a drafted polyline to a `Path2D`: split at section-boundary crossings, flag inside/arc."""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import Polygon

from ..core.tolerances import TOL
from .spec import Path2D

#: A point within this distance (mm) of the region counts as inside: the project's merge tolerance
#: (core.tolerances), so a path on the boundary is inside.
INSIDE_TOL = TOL.merge
#: Crossings closer than this (mm) to a segment end are the end itself, and points closer than this
#: to their predecessor are duplicates: a tenth of INSIDE_TOL, so no split leaves a piece that
#: straddles the boundary by more than INSIDE_TOL.
SPLIT_TOL = 0.1 * TOL.merge


def _drop_duplicates(points: np.ndarray, arc_ok: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    keep_seg = seg > SPLIT_TOL
    keep_pt = np.concatenate([[True], keep_seg])
    return points[keep_pt], arc_ok[keep_seg]


def finish(points: np.ndarray, arc_ok: np.ndarray, region: Polygon, arc_outside: str) -> Path2D:
    """Split every segment where it crosses the region boundary, then flag each piece.

    points: (n, 2) mm; arc_ok: (n - 1,) bool, False where the strategy itself keeps the arc off
    (raster returns). inside = the piece's midpoint is within INSIDE_TOL of the region (pieces do not
    cross the boundary, so this holds for the whole piece). arc = arc_ok and (inside or arc_outside
    == "on").
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    arc_ok = np.asarray(arc_ok, dtype=bool).reshape(-1)
    if len(points) < 2:
        raise ValueError("a path needs at least two points")
    points, arc_ok = _drop_duplicates(points, arc_ok)
    a, b = points[:-1], points[1:]
    segs = shapely.linestrings(np.stack([a, b], axis=1))
    boundary = region.boundary
    shapely.prepare(boundary)
    touching = np.flatnonzero(shapely.intersects(boundary, segs))  # prepared: fast test first
    hits = dict(zip(touching, shapely.intersection(segs[touching], boundary)))
    at: list[int] = []
    new: list[np.ndarray] = []
    for i in touching:
        d = b[i] - a[i]
        dd = float(d @ d)
        f = np.unique(((shapely.get_coordinates(hits[i]) - a[i]) @ d) / dd)
        tol = SPLIT_TOL / np.sqrt(dd)
        f = f[(f > tol) & (f < 1.0 - tol)]
        at += [int(i)] * len(f)
        new += list(a[i] + f[:, None] * d)
    at_arr = np.asarray(at, dtype=int)
    pts = np.insert(points, at_arr + 1, np.asarray(new).reshape(-1, 2), axis=0) if at else points
    ok = np.insert(arc_ok, at_arr, arc_ok[at_arr]) if at else arc_ok
    pts, ok = _drop_duplicates(pts, ok)
    if len(pts) < 2:
        raise ValueError("the path has zero length (section smaller than the pattern's margins)")
    mids = shapely.points(0.5 * (pts[:-1] + pts[1:]))
    inside = shapely.dwithin(region, mids, INSIDE_TOL)
    outside_ok = np.full(len(mids), arc_outside == "on")
    holes = [Polygon(h) for g in shapely.get_parts(region) for h in getattr(g, "interiors", ())]
    if arc_outside == "on" and holes:  # `on` is for run-ups into neighbouring sections; a hole is no section
        outside_ok &= ~shapely.contains(shapely.union_all(holes), mids)
    arc = ok & (inside | outside_ok)
    return Path2D(points=pts, arc=np.asarray(arc, dtype=bool), inside=np.asarray(inside, dtype=bool))


class Draft:
    """A drafted polyline before flagging: points (n, 2) mm, arc_ok (n - 1,) bool."""

    __slots__ = ("points", "arc_ok")

    def __init__(self, points, arc_ok) -> None:
        self.points = np.asarray(points, dtype=float).reshape(-1, 2)
        self.arc_ok = np.asarray(arc_ok, dtype=bool).reshape(-1)
        if len(self.arc_ok) != len(self.points) - 1:
            raise ValueError("arc_ok needs one entry per segment")


def extend_ends(points: np.ndarray, before: float, after: float) -> np.ndarray:
    """Prepend/append straight run-ups of `before`/`after` mm along the first/last segment."""
    p = np.asarray(points, dtype=float)
    out = [p]
    if before > 0:
        d = p[0] - p[1]
        out.insert(0, (p[0] + before * d / np.hypot(*d))[None])
    if after > 0:
        d = p[-1] - p[-2]
        out.append((p[-1] + after * d / np.hypot(*d))[None])
    return np.vstack(out)
