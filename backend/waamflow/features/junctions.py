"""Junctions of thin-wall midsurface curves (Venturini et al. 2018, §3), for `recognition`.

`find_junctions` collects every curve end point and every curve–curve (or self-) intersection
point of one layer's curves, merges points within the tolerance into one junction and lists, per
junction, the curves through it (`Incidence`: arc length, whether the curve ends there) and the
unit direction of every wall branch leaving it, counter-clockwise. `classify` names a junction's
kind from its valence (entities, ends, branches; the table in `recognition`'s docstring) and
`t_subtype` a three-branch crossing's sub-type. `passes_through`, `direction_at` and
`is_closed` are the curve geometry both `recognition` and `walls` use.

All lengths mm, angles deg unless named otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Point


def is_closed(c: np.ndarray, tol: float) -> bool:
    return len(c) >= 4 and float(np.hypot(*(c[0] - c[-1]))) <= tol


def _unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    n = float(np.hypot(*v))
    return v / n if n > 0 else v


def _angle(v) -> float:
    return math.atan2(v[1], v[0])


@dataclass(frozen=True)
class Incidence:
    """Curve `curve` meets a junction at arc length `s` (mm); `end` is True when the curve ends
    there. directions: unit (2,) vectors leaving the junction along the curve (1 for an end,
    2 for a pass-through). split: a pass-through where the sketch joined two drawn entities end to
    end (counts as two entities ending there)."""

    curve: int
    s: float
    end: bool
    directions: tuple[tuple[float, float], ...]
    split: bool = False


@dataclass(frozen=True)
class Junction:
    point: tuple[float, float]
    incidences: tuple[Incidence, ...]

    @property
    def entities(self) -> int:
        return len({i.curve for i in self.incidences}) + sum(1 for i in self.incidences if i.split)

    @property
    def ends(self) -> int:
        return sum(1 for i in self.incidences if i.end) + 2 * sum(1 for i in self.incidences if i.split)

    @property
    def branches(self) -> list[np.ndarray]:
        """Unit branch directions sorted CCW by angle."""
        dirs = [np.array(d) for i in self.incidences for d in i.directions]
        return sorted(dirs, key=_angle)


def direction_at(line: LineString, s: float, sign: float, closed: bool, step: float) -> np.ndarray:
    """Unit direction leaving arc length s along `line` forwards (sign +1) or backwards (−1)."""
    length = line.length
    t = s + sign * step
    if closed:
        t %= length
    else:
        t = min(max(t, 0.0), length)
    p0 = np.array(line.interpolate(s).coords[0])
    p1 = np.array(line.interpolate(t).coords[0])
    return _unit(p1 - p0)


def _intersection_points(geom) -> list[tuple[float, float]]:
    pts: list[tuple[float, float]] = []
    for g in shapely.get_parts(geom):
        if g.is_empty:
            continue
        if g.geom_type == "Point":
            pts.append((g.x, g.y))
        elif g.geom_type in ("LineString", "LinearRing"):  # overlapping walls: their overlap ends
            pts.extend([tuple(g.coords[0]), tuple(g.coords[-1])])
        else:
            pts.extend(_intersection_points(g))
    return pts


def passes_through(c: np.ndarray, p, tol: float, closed: bool) -> list[float]:
    """Arc lengths (mm) at which polyline `c` passes within `tol` of point p, one per pass (a
    curve crossing itself passes twice). Consecutive segments touching p are one pass."""
    p = np.asarray(p, float)
    a, b = c[:-1], c[1:]
    ab = b - a
    L2 = np.einsum("ij,ij->i", ab, ab)
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
    d = np.hypot(*(a + t[:, None] * ab - p).T)
    near = np.flatnonzero(d <= tol)
    if not len(near):
        return []
    cum = np.concatenate([[0.0], np.cumsum(np.sqrt(L2))])
    groups: list[list[int]] = [[int(near[0])]]
    for k in near[1:]:
        if k == groups[-1][-1] + 1:
            groups[-1].append(int(k))
        else:
            groups.append([int(k)])
    if closed and len(groups) > 1 and groups[0][0] == 0 and groups[-1][-1] == len(a) - 1:
        groups[0] = groups.pop() + groups[0]  # the closing point: one pass across the seam
    out = []
    for g in groups:
        k = min(g, key=lambda i: d[i])
        out.append(float(cum[k] + t[k] * np.sqrt(L2[k])))
    return sorted(out)


def self_crossings(line: LineString) -> list[tuple[float, float]]:
    """Points where a polyline crosses or touches itself (noding splits it there)."""
    if line.is_simple:
        return []
    counts: dict[tuple[float, float], int] = {}
    for part in shapely.get_parts(shapely.node(line)):
        for q in (part.coords[0], part.coords[-1]):
            key = (round(q[0], 9), round(q[1], 9))
            counts[key] = counts.get(key, 0) + 1
    ends = {
        (round(line.coords[0][0], 9), round(line.coords[0][1], 9)),
        (round(line.coords[-1][0], 9), round(line.coords[-1][1], 9)),
    }
    return [q for q, n in counts.items() if n >= 3 or (n == 2 and q not in ends)]


def _joined_at(c: np.ndarray, p: np.ndarray, splits: np.ndarray, tol: float) -> bool:
    """True when polyline c has a vertex at p (within tol) that is a join point in `splits`: the
    curve was two drawn entities meeting there."""
    if not len(splits) or float(np.hypot(*(splits - p).T).min()) > tol:
        return False
    return bool(float(np.hypot(*(c - p).T).min()) <= tol)


def find_junctions(curves: list[np.ndarray], tol: float, splits=(), split_tol: float = 0.0) -> list[Junction]:
    """All end points and intersections, merged within `tol` (mm), with their incidences.
    splits: (x, y) points where two drawn entities were joined end to end into one curve; a
    pass-through of a curve with a vertex within max(tol, split_tol) of one is marked `split`."""
    from scipy.spatial import cKDTree  # lazy: keeps start-up light

    lines = [LineString(c) for c in curves]
    closed = [is_closed(c, tol) for c in curves]
    cand: list[tuple[float, float]] = []
    for c, cl in zip(curves, closed):
        if not cl:
            cand.extend([tuple(c[0]), tuple(c[-1])])
    tree = shapely.STRtree(lines)
    for i, line in enumerate(lines):
        cand.extend(self_crossings(line))
        for j in tree.query(line, predicate="dwithin", distance=tol):
            if j > i:
                cand.extend(_intersection_points(line.intersection(lines[j])))
    if not cand:
        return []
    pts = np.asarray(cand, float)
    # union-find of candidates within tol
    parent = list(range(len(pts)))

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b in cKDTree(pts).query_pairs(r=max(tol, 1e-12)):
        parent[find(a)] = find(b)
    groups: dict[int, list[int]] = {}
    for k in range(len(pts)):
        groups.setdefault(find(k), []).append(k)
    step = max(100 * tol, 1e-4)
    split_pts = np.asarray(splits, float).reshape(-1, 2)
    stol = max(tol, split_tol)
    junctions: list[Junction] = []
    for members in groups.values():
        p = pts[members].mean(axis=0)
        pt = Point(p)
        incs: list[Incidence] = []
        for j in tree.query(pt, predicate="dwithin", distance=tol):
            j = int(j)
            line, c = lines[j], curves[j]
            for s_ in passes_through(c, p, tol, closed[j]):
                at_start = not closed[j] and s_ <= tol
                at_end = not closed[j] and line.length - s_ <= tol
                if at_start or at_end:
                    s_ = 0.0 if at_start else line.length
                    d = direction_at(line, s_, 1.0 if at_start else -1.0, False, step)
                    incs.append(Incidence(j, s_, True, (tuple(d),)))
                    if at_start and at_end:  # a curve from p back to p
                        d2 = direction_at(line, line.length, -1.0, False, step)
                        incs.append(Incidence(j, line.length, True, (tuple(d2),)))
                else:
                    d1 = direction_at(line, s_, 1.0, closed[j], step)
                    d2 = direction_at(line, s_, -1.0, closed[j], step)
                    split = _joined_at(c, p, split_pts, stol)
                    incs.append(Incidence(j, s_, False, (tuple(d1), tuple(d2)), split))
        incs.sort(key=lambda i: (i.curve, i.s))
        junctions.append(Junction((float(p[0]), float(p[1])), tuple(incs)))
    junctions.sort(key=lambda jn: (round(jn.point[0], 6), round(jn.point[1], 6)))
    return junctions


def classify(j: Junction, corner_angle_deg: float) -> str | None:
    """Feature kind of a junction (see module table), or None (an isolated closing point)."""
    ents = j.entities
    arms = sum(len(i.directions) for i in j.incidences)
    if arms == 1:
        return "free_end"
    if arms == 2:
        if ents == 1:
            return None
        a, b = j.branches
        between = math.degrees(math.acos(float(np.clip(a @ b, -1.0, 1.0))))
        return "corner" if 180.0 - between >= corner_angle_deg else "continuous"
    if arms == 3:
        return "t_crossing" if ents <= 2 else "odd_t_crossing"
    if ents <= 2:
        return "direct_crossing"
    if ents == 3:
        return "odd_direct_crossing"
    return "four_direct_crossing"


def t_subtype(branches: list[np.ndarray], corner_angle_deg: float) -> str:
    """Sub-type of a three-branch crossing (study: straight / open / closed T-crossing) from the
    largest angle θ between neighbouring branches: straight when within corner_angle_deg of 180°,
    open when larger (a reflex side), closed when smaller (every side a fillet corner)."""
    theta = max(_corner_angles(branches))
    if theta >= 180.0 + corner_angle_deg:
        return "open"
    if theta <= 180.0 - corner_angle_deg:
        return "closed"
    return "straight"


def _corner_angles(branches: list[np.ndarray]) -> list[float]:
    """CCW angles (deg) from branch k to branch k+1, summing to 360."""
    ang = [math.degrees(_angle(b)) for b in branches]
    return [((ang[(k + 1) % len(ang)] - ang[k]) % 360.0) or 360.0 for k in range(len(ang))]
