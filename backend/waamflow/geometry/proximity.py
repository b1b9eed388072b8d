"""A few points against a triangle mesh, exactly, without a spatial index: is a point within a
distance of the surface, is it inside the closed mesh.

trimesh answers both through an r-tree of the triangles, built once per mesh: on the bench's
1,008,000-triangle vase that build took 4.4 s (its Python stream loader) for the one ignition of
a helical program. Here each point scans the triangles' bounding boxes (six comparisons a
triangle, vectorised: ~10 ms a point on a million triangles) and measures only the few whose box
it touches, so a handful of points costs milliseconds; `worth_scanning` says when the scans are
cheaper than the index (the caller then uses trimesh's).
"""

from __future__ import annotations

import numpy as np

SCAN_BUDGET = 2e8  # points × triangles a scan may cost before an index pays (~2 s of numpy)
# The ray of the inside test leans off +z by these (irrational-looking) slopes: a ray along an axis
# runs exactly through the edges and vertices of axis-aligned meshes (a box's diagonal), where a
# hit would count twice or not at all.
_RAY = np.array([0.000731, 0.000563, 1.0])
_RAY = _RAY / np.linalg.norm(_RAY)


def worth_scanning(n_points: int, n_triangles: int) -> bool:
    """Whether scanning the triangles per point beats building an index over them."""
    return n_points * n_triangles <= SCAN_BUDGET


class TriangleBoxes:
    """A mesh's triangles (m, 3, 3) and their axis-aligned bounds, computed once for many points."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self.tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]
        self.lo = self.tri.min(axis=1)
        self.hi = self.tri.max(axis=1)

    def touching(self, p: np.ndarray, pad: float) -> np.ndarray:
        """Indices of the triangles whose box, grown by `pad`, holds the point p (3,)."""
        lo, hi = self.lo, self.hi
        m = (lo[:, 0] <= p[0] + pad) & (hi[:, 0] >= p[0] - pad)
        m &= (lo[:, 1] <= p[1] + pad) & (hi[:, 1] >= p[1] - pad)
        m &= (lo[:, 2] <= p[2] + pad) & (hi[:, 2] >= p[2] - pad)
        return np.flatnonzero(m)


def point_triangle_distance(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """(k,) exact distance from the point p (3,) to each triangle of tri (k, 3, 3): to its plane
    where p projects inside it, else to the nearest of its three edges (a degenerate triangle:
    its edges)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, ac = b - a, c - a
    n = np.cross(ab, ac)
    nn = np.einsum("ij,ij->i", n, n)
    ok = nn > 1e-24
    ap = p - a
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.einsum("ij,ij->i", ap, n) / np.where(ok, nn, 1.0)  # signed height / |n|²
        q = ap - h[:, None] * n  # p projected on the plane, relative to a
        # barycentric coordinates of the projection
        d00, d01, d11 = (np.einsum("ij,ij->i", u, w) for u, w in ((ab, ab), (ab, ac), (ac, ac)))
        d20, d21 = np.einsum("ij,ij->i", q, ab), np.einsum("ij,ij->i", q, ac)
        den = d00 * d11 - d01 * d01
        v = (d11 * d20 - d01 * d21) / den
        w = (d00 * d21 - d01 * d20) / den
    inside = ok & (v >= 0) & (w >= 0) & (v + w <= 1)
    best = np.where(inside, np.abs(h) * np.sqrt(np.where(ok, nn, 0.0)), np.inf)
    for s, e in ((a, b), (b, c), (c, a)):
        d = e - s
        dd = np.einsum("ij,ij->i", d, d)
        t = np.clip(np.einsum("ij,ij->i", p - s, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(p - (s + t[:, None] * d), axis=1))
    return best


def near_surface(boxes: TriangleBoxes, pts: np.ndarray, tol: float) -> np.ndarray:
    """(n,) bool: each point lies within `tol` of the mesh's surface."""
    out = np.zeros(len(pts), bool)
    for i, p in enumerate(np.asarray(pts, dtype=np.float64)):
        k = boxes.touching(p, tol)
        out[i] = bool(len(k)) and float(point_triangle_distance(p, boxes.tri[k]).min()) <= tol
    return out


def inside_closed(boxes: TriangleBoxes, pts: np.ndarray) -> np.ndarray:
    """(n,) bool: each point lies inside the closed mesh (odd number of crossings of a ray leaning
    slightly off +z; Möller–Trumbore on the triangles the ray can reach)."""
    out = np.zeros(len(pts), bool)
    top = float(boxes.hi[:, 2].max()) if len(boxes.hi) else 0.0
    for i, p in enumerate(np.asarray(pts, dtype=np.float64)):
        drift = float(np.hypot(_RAY[0], _RAY[1]) / _RAY[2]) * max(top - p[2], 0.0) + 1e-9
        lo, hi = boxes.lo, boxes.hi
        m = (hi[:, 2] >= p[2]) & (lo[:, 0] <= p[0] + drift) & (hi[:, 0] >= p[0] - drift)
        m &= (lo[:, 1] <= p[1] + drift) & (hi[:, 1] >= p[1] - drift)
        tri = boxes.tri[m]
        if not len(tri):
            continue
        e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        pv = np.cross(_RAY, e2)
        det = np.einsum("ij,ij->i", e1, pv)
        good = np.abs(det) > 1e-18
        inv = 1.0 / np.where(good, det, 1.0)
        tv = p - tri[:, 0]
        u = np.einsum("ij,ij->i", tv, pv) * inv
        qv = np.cross(tv, e1)
        v = (qv @ _RAY) * inv
        t = np.einsum("ij,ij->i", e2, qv) * inv
        hits = good & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        out[i] = bool(np.count_nonzero(hits) % 2)
    return out
