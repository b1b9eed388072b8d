"""Contour-parallel (the fill the MPP study compared against, Michel et al. 2019): closed offsets
of the section boundary, outermost first, connected into as few paths as possible.

Offsets: ring k is the region's inward offset by w/2 + k·d (w = bead_width, so the outer bead's
edge sits on the boundary), holes included, until the offset vanishes. The step-over d follows
the tangent overlapping model of Ding et al., "A multi-bead overlapping model for robotic wire and
arc additive manufacturing (WAAM)", Robotics and Computer-Integrated Manufacturing 31 (2015)
101–110: for a parabolic bead cross-section, neighbouring beads give a flat top when their centre
distance is d = 0.738·w (`TANGENT_OVERLAP`).

Connection: a ring at level k+1 is chained to the nearest ring at level k that lies within 1.5·d
and has no child yet (a nested chain is one continuous arc-ON path: each loop is run once from its
point nearest the previous loop's end, closing on itself, then a straight step joins the next
loop). A level-k ring that splits into several rings gives one chain per extra piece; chains are
visited nearest-first and joined by arc-OFF links. Loops run counter-clockwise (exteriors) or
clockwise (holes), following shapely's orientation of the offset polygons.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon

from .flags import Draft
from .spec import StrategySpec

#: Centre distance / bead width for a flat top (Ding et al. 2015, tangent overlapping model).
TANGENT_OVERLAP = 0.738
MAX_RINGS = 10_000


def step_over(bead_width: float) -> float:
    """Centre distance between neighbouring beads (mm) for a flat top (tangent overlapping model)."""
    return TANGENT_OVERLAP * bead_width


def offset_rings(region: Polygon, bead_width: float) -> list[list[np.ndarray]]:
    """Per level, the closed rings ((k, 2) arrays, first point repeated) of the inward offsets."""
    d = step_over(bead_width)
    levels: list[list[np.ndarray]] = []
    k = 0
    while True:
        off = region.buffer(-(bead_width / 2.0 + k * d), join_style="mitre", mitre_limit=2.0)
        polys = [g for g in shapely.get_parts(off) if isinstance(g, Polygon) and g.area > 1e-6]
        if not polys:
            break
        rings = []
        for p in shapely.orient_polygons(polys):
            rings.append(np.asarray(p.exterior.coords, dtype=float))
            rings += [np.asarray(h.coords, dtype=float) for h in p.interiors]
        levels.append(rings)
        k += 1
        if sum(len(lv) for lv in levels) > MAX_RINGS:
            raise ValueError(f"contour: more than {MAX_RINGS} rings (bead width too small for the section?)")
    if not levels:
        # narrower than one bead: one pass along the long axis of the region
        c = region.centroid
        rect = np.asarray(shapely.minimum_rotated_rectangle(region).exterior.coords)[:4]
        e1, e2 = rect[1] - rect[0], rect[2] - rect[1]
        u = e1 if np.hypot(*e1) >= np.hypot(*e2) else e2
        half = 0.5 * np.hypot(*u)
        u = u / np.hypot(*u)
        line = LineString([np.array(c.coords[0]) - half * u, np.array(c.coords[0]) + half * u]).intersection(region)
        parts = [g for g in shapely.get_parts(line) if g.geom_type == "LineString"]
        if not parts:
            raise ValueError("contour: section too small for one bead")
        levels.append([np.asarray(max(parts, key=lambda g: g.length).coords, dtype=float)])
    return levels


def _rotate(ring: np.ndarray, at: np.ndarray) -> np.ndarray:
    """A closed ring run once from its point nearest `at` (inserted on the ring) back to it."""
    if len(ring) < 3 or not np.allclose(ring[0], ring[-1]):
        return ring if np.hypot(*(ring[0] - at)) <= np.hypot(*(ring[-1] - at)) else ring[::-1]
    line = LineString(ring)
    s = line.project(Point(at))
    p = np.asarray(line.interpolate(s).coords[0])
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ring, axis=0), axis=1))])
    i = int(np.searchsorted(cum, s, side="right"))
    body = np.vstack([ring[i:-1], ring[:i]])
    return np.vstack([p, body, p])


def plan(region: Polygon, guide: LineString, spec: StrategySpec) -> Draft:
    levels = offset_rings(region, spec.bead_width)
    d = step_over(spec.bead_width)
    # chain: child[(level, i)] = index at level + 1
    child: dict[tuple[int, int], int] = {}
    has_parent: set[tuple[int, int]] = set()
    for lv in range(len(levels) - 1):
        outer = [LineString(r) for r in levels[lv]]
        for j in sorted(range(len(levels[lv + 1])), key=lambda j: -LineString(levels[lv + 1][j]).length):
            inner = LineString(levels[lv + 1][j])
            cand = [(inner.distance(o), i) for i, o in enumerate(outer) if (lv, i) not in child]
            cand = [c for c in cand if c[0] <= 1.5 * d]
            if cand:
                i = min(cand)[1]
                child[(lv, i)] = j
                has_parent.add((lv + 1, j))
    roots = [(lv, i) for lv in range(len(levels)) for i in range(len(levels[lv])) if (lv, i) not in has_parent]
    start = np.asarray(guide.coords[0], dtype=float) if guide is not None else np.asarray(region.exterior.coords[0])
    pts: list[np.ndarray] = []
    arc: list[bool] = []
    here = start
    todo = set(roots)
    while todo:
        lv, i = min(todo, key=lambda r: Point(here).distance(LineString(levels[r[0]][r[1]])))
        todo.discard((lv, i))
        first = True
        while True:
            loop = _rotate(levels[lv][i], here)
            if pts:
                arc.append(not first)  # a step between nested loops is arc ON, a jump to a new chain OFF
            pts.append(loop)
            arc += [True] * (len(loop) - 1)
            here = loop[-1]
            first = False
            if (lv, i) not in child:
                break
            lv, i = lv + 1, child[(lv, i)]
    # flatten: consecutive loops share no point, the joining segment is the step/link
    flat = np.vstack(pts)
    return Draft(flat, np.asarray(arc, dtype=bool))
