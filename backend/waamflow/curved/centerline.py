"""Centre line of a single-bead ring: the perimeter path of one layer of a hollow thin wall.

A fan slice of a hollow single-bead wall (e.g. a bent duct) is a thin ring: an exterior and one
hole. Its deposition path is the curve half way between them. For a ring of fairly uniform width
the midpoint of each exterior sample and its nearest point on the hole is that curve (exact for
concentric circles and parallel offsets). The nearest points come from an R-tree of the hole's
facets (GEOS's prepared nearest points), all samples at once: a layer of a 2,000-vertex ring takes
about a millisecond, not a Python loop of projections.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import Polygon


def resample_ring(ring: np.ndarray, spacing: float) -> np.ndarray:
    """(m, 2) closed ring (first point repeated) resampled at ≤ spacing mm, keeping its start."""
    ring = np.asarray(ring, float)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(ring, axis=0).T))])
    n = max(int(np.ceil(s[-1] / spacing)), 8)
    t = np.linspace(0.0, s[-1], n + 1)
    return np.column_stack([np.interp(t, s, ring[:, 0]), np.interp(t, s, ring[:, 1])])


def ring_centerline(poly: Polygon, spacing: float = 1.0) -> tuple[np.ndarray, float]:
    """Centre line of a ring polygon (exterior + largest hole) as a closed (m, 2) polyline (mm,
    first point repeated, CCW), and the ring's mean width (mm). Raises ValueError for a polygon
    without hole (not a ring)."""
    if not poly.interiors:
        raise ValueError("region has no hole: not a single-bead ring")
    hole = max(poly.interiors, key=lambda r: Polygon(r).area)
    outer = resample_ring(np.asarray(poly.exterior.coords)[:, :2], spacing)[:-1]
    q = nearest_on_polyline(np.asarray(hole.coords)[:, :2], outer)
    mid = (outer + q) / 2.0
    widths = np.hypot(*(outer - q).T)
    if Polygon(mid).exterior.is_ccw is False:
        mid = mid[::-1]
    mid = np.vstack([mid, mid[:1]])
    return mid, float(np.mean(widths))


def seam_index(mid: np.ndarray, near: np.ndarray | None = None, straight_deg_per_mm: float = 0.5) -> int:
    """Where a lap of the closed centre line `mid` ((m, 2), first point repeated, mm) starts.

    With `near` ((2,) mm, the previous layer's seam in the same layer-local coordinates): the
    sample nearest to it, so seams stay aligned layer to layer however the section's ring happens
    to be ordered. Without: the middle of the longest straight stretch (turning under
    `straight_deg_per_mm`), where ignition and the stop's overlap sit on a straight bead rather
    than in a bend; on a lap with no straight stretch (a circle), its point farthest along +x
    (on a fan layer: farthest from the axis). Returns an index into mid[:-1].
    """
    pts = np.asarray(mid, float)[:-1]
    n = len(pts)
    if near is not None:
        return int(np.argmin(np.hypot(*(pts - np.asarray(near, float)).T)))
    d_in = pts - np.roll(pts, 1, axis=0)
    d_out = np.roll(pts, -1, axis=0) - pts
    turn = np.abs(np.arctan2(d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0], np.einsum("ij,ij->i", d_in, d_out)))
    step = (np.hypot(*d_in.T) + np.hypot(*d_out.T)) / 2.0
    straight = np.degrees(turn) <= straight_deg_per_mm * np.maximum(step, 1e-9)
    if straight.all() or not straight.any():
        return int(np.argmax(pts[:, 0])) if not straight.all() else 0
    # longest circular run of straight samples: start the scan just after a bent one
    first = int(np.flatnonzero(~straight)[0])
    order = (np.arange(n) + first + 1) % n
    run_start, run_len, best = 0, 0, (0, -1)
    for k, i in enumerate(order):
        if straight[i]:
            if run_len == 0:
                run_start = k
            run_len += 1
            if run_len > best[1]:
                best = (run_start, run_len)
        else:
            run_len = 0
    return int(order[best[0] + best[1] // 2])


def start_at(mid: np.ndarray, i: int) -> np.ndarray:
    """The closed polyline `mid` ((m, 2), first point repeated) re-started at its sample i."""
    pts = np.asarray(mid, float)[:-1]
    pts = np.roll(pts, -int(i), axis=0)
    return np.vstack([pts, pts[:1]])


def nearest_on_polyline(line: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """(n, 2) nearest point on the polyline `line` ((m, 2), m ≥ 2) of each of `pts` ((n, 2)): GEOS's
    nearest points of the prepared line (its facets indexed once) and every point, in one call
    (4x faster than an STRtree of the segments queried point by point: 0.13 against 0.51 s for the
    bench vase's 133 rings of 2,000 vertices and 500 samples each; the same points to 1e-17 mm)."""
    ring = shapely.linestrings(np.asarray(line, dtype=float))
    shapely.prepare(ring)
    return shapely.get_coordinates(shapely.shortest_line(ring, shapely.points(np.asarray(pts, dtype=float))))[0::2]
