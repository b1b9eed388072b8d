"""Contour-parallel (the fill the MPP study compared against, Michel et al. 2019): closed offsets
of the section boundary, outermost first, connected into as few paths as possible.

Offsets: ring k is the region's inward offset by w/2 + k·d (w = bead_width, so the outer bead's
edge sits on the boundary), holes included, until the offset vanishes. The step-over d follows
the tangent overlapping model of Ding et al., "A multi-bead overlapping model for robotic wire and
arc additive manufacturing (WAAM)", Robotics and Computer-Integrated Manufacturing 31 (2015)
101–110: for a parabolic bead cross-section, neighbouring beads give a flat top when their centre
distance is d = 0.738·w (`TANGENT_OVERLAP`).

Slivers. An offset piece too thin for a ring of its own — at inner levels so thin that one bead
along its middle reaches the beads of the ring outside it (width ≤ 2·(w − d)), at the outermost
level (where the ring's beads make the section's edge) its two sides within a tenth of a bead width
of each other (`SLIVER_OUTER`) — is welded once along its centre line: the chordal axis
(geometry.chordal_axis), or the centre loop of a thin annulus. Its ring ran out and back along the
strip (compas_slicer's distorted_a, layer 65: a 0.5 mm sliver welded twice over 9 mm).

Connection: a ring at level k+1 is chained to the nearest ring at level k that lies within 1.5·d
and has no child yet (a nested chain is one continuous arc-ON path: each loop is run once, closing
on itself, then a straight step joins the next loop). A chain's loops start where they are closest
to each other: its innermost piece at its point nearest the path so far, and each loop outside at
its point nearest the start of the loop inside it, so every step crosses one step-over (a piece of
an offset that split lies in one lobe of its parent: a loop started where the path happened to
arrive stepped 20-38 mm across the section, arc ON, over what the other lobe's rings weld). A step
longer than `LINK_MAX` step-overs all the same is flown arc OFF. A level-k ring that splits into
several rings gives one chain per extra piece; chains are visited nearest-first and joined by
arc-OFF links. Loops run counter-clockwise (exteriors) or clockwise (holes), following shapely's
orientation of the offset polygons.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon

from ..geometry.chordal_axis import chordal_axis
from .flags import Draft
from .spec import StrategySpec

#: Centre distance / bead width for a flat top (Ding et al. 2015, tangent overlapping model).
TANGENT_OVERLAP = 0.738
MAX_RINGS = 10_000
#: An outermost piece whose two sides lie closer than this share of a bead width is one line welded
#: twice and is welded once along its centre line. Small: the centre line's bead falls short of the
#: section's edge by half the piece's width on each side, which its ring reached (rabbit layer 64's
#: ears, 1.4 mm pieces of 6 mm beads: 0.7 mm strips along both sides, 4 × 22 mm², at 3/8).
SLIVER_OUTER = 0.1
#: Longest arc-ON step between nested loops, in step-overs: a mitre corner's step is √2·d (the
#: offsets' mitre limit is 2).
LINK_MAX = 2.0
#: A core (`_cores`) narrower than this share of a bead width is left unwelded. Volume balance of
#: parabolic beads: the beads either side of a core of width c stand c + w apart, and the metal the
#: layer lacks between them is (c + w)/d − 1 beads; a bead along the core brings it nearer the
#: layer's volume only when that is half a bead or more: c ≥ 1.5·d − w (0.107·w).
CORE_MIN = 1.5 * TANGENT_OVERLAP - 1.0
#: Arcs of the cores' round offset: 4 segments a quarter circle (its corners within
#: 1 - cos(π/8) = 8 % of w/2; a core's centre line is all that is taken from it)
QUAD_SEGS = 4


def step_over(bead_width: float) -> float:
    """Centre distance between neighbouring beads (mm) for a flat top (tangent overlapping model)."""
    return TANGENT_OVERLAP * bead_width


def offset_rings(region: Polygon, bead_width: float) -> list[list[np.ndarray]]:
    """Per level, the closed rings ((k, 2) arrays, first point repeated) of the inward offsets; a
    sliver's centre line instead of its ring (open, or closed for a thin annulus: `_sliver`); and
    after a level's rings, the centre lines of the cores they leave (`_cores`)."""
    d = step_over(bead_width)
    levels: list[list[np.ndarray]] = []
    k = 0
    ringed = None  # the previous level's pieces that got rings
    while True:
        off = region.buffer(-(bead_width / 2.0 + k * d), join_style="mitre", mitre_limit=2.0)
        polys = [g for g in shapely.get_parts(off) if isinstance(g, Polygon) and g.area > 1e-6]
        cores: list[np.ndarray] = _cores(ringed, polys, bead_width) if ringed else []
        if not polys:
            if cores:
                levels.append(cores)
            break
        thin = SLIVER_OUTER * bead_width if k == 0 else 2.0 * (bead_width - d)
        rings, ringed = [], []
        for p in shapely.orient_polygons(polys):
            axis = _sliver(p, thin)
            if axis is not None:
                rings.append(axis)
                continue
            ringed.append(p)
            rings.append(np.asarray(p.exterior.coords, dtype=float))
            rings += [np.asarray(h.coords, dtype=float) for h in p.interiors]
        levels.append(rings + cores)
        k += 1
        if sum(len(lv) for lv in levels) > MAX_RINGS:
            raise ValueError(f"contour: more than {MAX_RINGS} rings (bead width too small for the section?)")
    if not levels:
        # narrower than one bead: one pass along its centre line (a ring's centre loop, else the
        # chordal axis: a straight axis through the region's centroid missed a bent or ring-shaped
        # region's middle: compas_slicer's branches_16, layer 71, a 4.9 mm ring, 89 % left bare)
        line = _centre_line(region, bead_width / 4.0)
        if line is not None:
            return [[line]]
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


def _cores(ringed: list[Polygon], inner: list[Polygon], w: float) -> list[np.ndarray]:
    """Centre lines of what the rings of `ringed` (a level's pieces) leave for no bead: farther
    than w/2 inside them and farther than w/2 outside the next level's pieces `inner` (whose rings
    and the rings within cover the rest) — the erosion by w/2 of `ringed` less `inner`, one offset
    of a band about d wide, empty but for the cores. Such a core is left where the next offset
    vanishes: in a lobe narrower than w + 2·d, or past the innermost ring; it is at most
    2·(d − w/2) wide, so one bead along its centre line covers it. Cores under `CORE_MIN` bead widths
    wide lack less metal than half a bead and are left."""
    outer = shapely.multipolygons(ringed)
    if inner:
        outer = shapely.difference(outer, shapely.multipolygons(inner))
    inside = shapely.buffer(outer, -w / 2.0, quad_segs=QUAD_SEGS)
    out = []
    for g in shapely.get_parts(inside):
        if not isinstance(g, Polygon) or g.is_empty:
            continue
        if 2.0 * shapely.maximum_inscribed_circle(g, w / 1000.0).length < CORE_MIN * w:
            continue
        line = _centre_line(g, w / 4.0)
        if line is not None:
            out.append(line)
    return out


def _centre_line(g: Polygon, step: float, ring_step: float | None = None) -> np.ndarray | None:
    """A piece's centre line: its chordal axis (`step`), or its centre loop when it rings one hole
    (`ring_step`, default step/2: the chordal axis fills holes, and a torus layer's ring-shaped core
    was welded zigzag across its hole, pythonocc-demos' torus_default_resolution.stl); None for a
    piece round several holes (a core is then left, the coverage measures it)."""
    if not g.interiors:
        return chordal_axis(g, step)
    if len(g.interiors) == 1:
        from ..curved.centerline import ring_centerline

        return ring_centerline(g, max(step / 2.0 if ring_step is None else ring_step, 0.05))[0]
    return None


def _sliver(p: Polygon, thin: float) -> np.ndarray | None:
    """The centre line of an offset piece at most `thin` wide (twice its largest inscribed circle's
    radius), else None: the chordal axis of a piece without holes, the centre loop of a thin
    annulus (one hole); a thin piece with more holes keeps its rings."""
    if 2.0 * p.area / p.length > thin or len(p.interiors) > 1:  # 2·area/perimeter ≤ that width
        return None
    if 2.0 * shapely.maximum_inscribed_circle(p).length > thin:
        return None
    return _centre_line(p, thin / 2.0, ring_step=thin / 2.0)


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


def _closed(ring: np.ndarray) -> bool:
    return len(ring) >= 3 and bool(np.allclose(ring[0], ring[-1]))


def _nearest_on(ring: np.ndarray, at: np.ndarray) -> np.ndarray:
    """The point of the ring (or open line) nearest `at`; an open line's nearer end."""
    if not _closed(ring):
        return ring[0] if np.hypot(*(ring[0] - at)) <= np.hypot(*(ring[-1] - at)) else ring[-1]
    line = LineString(ring)
    return np.asarray(line.interpolate(line.project(Point(at))).coords[0])


def _chains(levels: list[list[np.ndarray]], d: float) -> tuple[dict[tuple[int, int], int], list[tuple[int, int]]]:
    """child[(level, i)] = the index at level + 1 chained to that ring, and the chains' roots. An
    open piece (a sliver's axis) has nothing inside it and is no parent."""
    child: dict[tuple[int, int], int] = {}
    has_parent: set[tuple[int, int]] = set()
    for lv in range(len(levels) - 1):
        outer = [LineString(r) for r in levels[lv]]
        for j in sorted(range(len(levels[lv + 1])), key=lambda j: -LineString(levels[lv + 1][j]).length):
            inner = LineString(levels[lv + 1][j])
            cand = [
                (inner.distance(o), i) for i, o in enumerate(outer) if (lv, i) not in child and _closed(levels[lv][i])
            ]
            cand = [c for c in cand if c[0] <= 1.5 * d]
            if cand:
                i = min(cand)[1]
                child[(lv, i)] = j
                has_parent.add((lv + 1, j))
    roots = [(lv, i) for lv in range(len(levels)) for i in range(len(levels[lv])) if (lv, i) not in has_parent]
    return child, roots


def plan(region: Polygon, guide: LineString, spec: StrategySpec) -> Draft:
    levels = offset_rings(region, spec.bead_width)
    d = step_over(spec.bead_width)
    child, roots = _chains(levels, d)
    start = np.asarray(guide.coords[0], dtype=float) if guide is not None else np.asarray(region.exterior.coords[0])
    pts: list[np.ndarray] = []
    arc: list[bool] = []
    here = start
    todo = set(roots)
    while todo:
        lv, i = min(todo, key=lambda r: Point(here).distance(LineString(levels[r[0]][r[1]])))
        todo.discard((lv, i))
        chain = [(lv, i)]
        while chain[-1] in child:
            chain.append((chain[-1][0] + 1, child[chain[-1]]))
        # starts from the inside out: each loop where it is nearest the start of the one inside it
        starts = [_nearest_on(levels[chain[-1][0]][chain[-1][1]], here)]
        for k, m in reversed(chain[:-1]):
            starts.append(_nearest_on(levels[k][m], starts[-1]))
        starts.reverse()
        for n, ((k, m), at) in enumerate(zip(chain, starts)):
            loop = _rotate(levels[k][m], at)
            if pts:  # a step between nested loops is arc ON unless long, a jump to a new chain OFF
                arc.append(n > 0 and float(np.hypot(*(loop[0] - here))) <= LINK_MAX * d + 1e-9)
            pts.append(loop)
            arc += [True] * (len(loop) - 1)
            here = loop[-1]
    # flatten: consecutive loops share no point, the joining segment is the step/link
    flat = np.vstack(pts)
    return Draft(flat, np.asarray(arc, dtype=bool))
