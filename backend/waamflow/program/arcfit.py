"""Arc fitting: replace runs of polyline points that lie on a circle by circular arcs.

Used by the post-processors for G2/G3 (G-code), CIRC (KUKA) and ArcC/MoveC (ABB) when the
`arc_tolerance` setting is > 0. An arc is accepted only where it stays within the tolerance of
the polyline it replaces: every vertex within `tolerance` of the circle and of its plane, every
chord's sagitta r − √(r² − (L/2)²) ≤ tolerance, vertices strictly advancing around the circle,
sweep under 360°. Straight runs (all vertices within tolerance of the chord) stay lines. Arc end
points are polyline vertices, so the program still passes exactly through the arc ends.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.tolerances import TOL


@dataclass(frozen=True, eq=False)
class FittedArc:
    """A circular arc through polyline vertices start..end (indices into the fitted points).

    via: index of an interior vertex (the middle one), the CIRC/ArcC auxiliary point.
    center: (3,) float mm. normal: (3,) unit, the arc runs counter-clockwise about it.
    radius: mm. sweep: rad, > 0.
    """

    start: int
    end: int
    via: int
    center: np.ndarray
    normal: np.ndarray
    radius: float
    sweep: float


def circle_through(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> tuple[np.ndarray, np.ndarray, float] | None:
    """Circle through three 3D points: (center (3,), unit normal (3,), radius) or None if collinear.

    The normal is oriented so that p0 → p1 → p2 runs counter-clockwise about it.
    """
    a = p1 - p0
    b = p2 - p0
    n = np.cross(a, b)
    nn = float(n @ n)
    if nn < 1e-18 * max(float(a @ a) * float(b @ b), 1e-300):
        return None
    center = p0 + np.cross(float(a @ a) * b - float(b @ b) * a, n) / (2.0 * nn)
    return center, n / np.sqrt(nn), float(np.linalg.norm(p0 - center))


_STRAIGHT = "straight"


def _arc_ok(pts: np.ndarray, tol: float, plane_normal: np.ndarray | None) -> FittedArc | str | None:
    """Fit one arc through all of `pts` ((k, 3), k ≥ 4) within `tol`: the arc, `_STRAIGHT` when
    the points are a straight line within `tol` (keep lines, but a longer run may still curve),
    or None when no arc fits."""
    k = len(pts)
    mid = k // 2
    chord = pts[-1] - pts[0]
    cl = float(np.linalg.norm(chord))
    if cl > 0:
        off = np.linalg.norm(np.cross(pts - pts[0], chord / cl), axis=1)
        if off.max() <= tol:
            along = (pts - pts[0]) @ (chord / cl)
            return _STRAIGHT if np.all(np.diff(along) > 0) else None
    circ = circle_through(pts[0], pts[mid], pts[-1])
    if circ is None:
        return None
    center, normal, r = circ
    if plane_normal is not None:
        if abs(float(normal @ plane_normal)) < 1.0 - 1e-9:
            return None
        h = pts @ plane_normal
        if np.ptp(h) > TOL.join:
            return None
    rel = pts - center
    if np.abs(rel @ normal).max() > tol:
        return None
    inplane = rel - np.outer(rel @ normal, normal)
    if np.abs(np.linalg.norm(inplane, axis=1) - r).max() > tol:
        return None
    u = inplane[0] / np.linalg.norm(inplane[0])
    v = np.cross(normal, u)
    ang = np.unwrap(np.arctan2(inplane @ v, inplane @ u))
    step = np.diff(ang)
    if np.any(step <= 0) or np.any(step >= np.pi):
        return None
    sweep = float(ang[-1] - ang[0])
    if sweep >= 2.0 * np.pi - 1e-6:
        return None
    half = np.linalg.norm(np.diff(pts, axis=0), axis=1) / 2.0
    if np.any(half > r) or np.any(r - np.sqrt(np.maximum(r * r - half * half, 0.0)) > tol):
        return None
    return FittedArc(0, k - 1, mid, center, normal, r, sweep)


def fit_arcs(
    points: np.ndarray,
    tolerance: float,
    *,
    min_segments: int = 3,
    max_points: int = 2000,
    plane_normal: np.ndarray | tuple[float, float, float] | None = None,
) -> list[FittedArc]:
    """Greedy arc fitting over a polyline.

    points: (n, 3) float mm. tolerance: mm, the largest allowed distance between arc and
    polyline. min_segments: fewest polyline segments an arc may replace. max_points: longest
    run tried. plane_normal: (3,) unit or None — if given, only arcs in planes normal to it at
    constant height along it (G17 arcs: (0, 0, 1)).
    From each start vertex the run is grown by doubling, then the longest acceptable end is found
    by bisection (O(log k) fits per arc, each O(k)). Returns non-overlapping arcs sorted by start;
    segments outside them stay lines.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    n = len(pts)
    arcs: list[FittedArc] = []
    if tolerance <= 0 or n < min_segments + 1:
        return arcs
    pn = None if plane_normal is None else np.asarray(plane_normal, dtype=float) / np.linalg.norm(plane_normal)

    def fit(i: int, j: int):
        return _arc_ok(pts[i : j + 1], tolerance, pn)

    i = 0
    while i < n - min_segments:
        j = i + min_segments
        first = fit(i, j)
        if first is None:
            i += 1
            continue
        good, good_fit, step = j, first, min_segments
        bad = None
        while True:  # grow by doubling while the run still fits (or is still straight)
            step *= 2
            j = min(i + step, n - 1, i + max_points - 1)
            if j <= good:
                break
            f = fit(i, j)
            if f is None:
                bad = j
                break
            good, good_fit = j, f
        if bad is not None:  # longest fitting end in (good, bad)
            lo, hi = good, bad
            while hi - lo > 1:
                m = (lo + hi) // 2
                f = fit(i, m)
                if f is None:
                    hi = m
                else:
                    lo, good_fit = m, f
            good = lo
            good_fit = fit(i, good)
        if isinstance(good_fit, FittedArc):
            arcs.append(
                FittedArc(
                    i,
                    i + good_fit.end,
                    i + good_fit.via,
                    good_fit.center,
                    good_fit.normal,
                    good_fit.radius,
                    good_fit.sweep,
                )
            )
            i = good
        else:  # a straight run: an arc can only start near its end
            i = max(i + 1, good - min_segments)
    return arcs
