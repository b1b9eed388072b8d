"""Centre line of a single-bead ring: the perimeter path of one layer of a hollow thin wall.

A fan slice of a hollow single-bead wall (e.g. a bent duct) is a thin ring: an exterior and one
hole. Its deposition path is the curve half way between them. For a ring of fairly uniform width
the midpoint of each exterior sample and its nearest point on the hole is that curve (exact for
concentric circles and parallel offsets).
"""

from __future__ import annotations

import numpy as np
from shapely.geometry import LineString, Point, Polygon


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
    outer = resample_ring(np.asarray(poly.exterior.coords)[:, :2], spacing)
    inner = LineString(hole)
    mids, widths = [], []
    for p in outer[:-1]:
        q = inner.interpolate(inner.project(Point(p)))
        mids.append(((p[0] + q.x) / 2.0, (p[1] + q.y) / 2.0))
        widths.append(float(np.hypot(p[0] - q.x, p[1] - q.y)))
    mid = np.asarray(mids)
    if Polygon(mid).exterior.is_ccw is False:
        mid = mid[::-1]
    mid = np.vstack([mid, mid[:1]])
    return mid, float(np.mean(widths))
