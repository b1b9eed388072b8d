"""Corner division: cut a non-convex section at its reflex corners into convex-enough pieces.

MPP (Michel et al. 2019, step 2) replaces a sharp turn of a section by two sections meeting at the
corner, each with its own guide along its long axis. Here the cut is made automatically: at a
reflex corner (interior angle over 180° + `MIN_TURN_DEG`) one of the two edges meeting there is
extended into the section until it meets the boundary, and the section is split along that
segment. Of the two candidate cuts the shorter wins (it is the arm's width at the corner); at equal
length the one leaving the larger piece (the long arm kept whole). Pieces are cut again until none
has a reflex corner left or `MAX_PIECES` is reached. An L of a 120 × 16 mm and a 64 × 16 mm arm
gives 120 × 16 + 16 × 48 mm; a square frame (a hole with four reflex corners) gives four bars.

Gentle turns (a polygonised arc: 64 segments turn 5.6° each) are not corners: a round hole stays,
and its section is left to a pattern that fills it whole (contour).

Pure: shapely in, shapely out (layer-local mm).
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon
from shapely.ops import split

from ..core.tolerances import TOL

#: A vertex is a corner when the boundary turns away from the section by more than this (deg):
#: a polygonised circle of 16+ segments (≤ 22.5° per vertex) stays smooth, a chamfer of 45° or a
#: right-angled corner is cut.
MIN_TURN_DEG = 25.0
#: At most this many pieces per section (a sawtooth edge would otherwise split without end).
MAX_PIECES = 32
#: A cut that leaves a piece smaller than this share of the section is not made (sliver).
MIN_PIECE_SHARE = 0.01
#: At most this many cuts that open a hole to the boundary (they divide nothing by themselves): a
#: frame needs one; a layer of 205 small holes was opened hole by hole, 0.1-6 s a cut.
MAX_HOLES_OPENED = 8
#: Width (mm) of the slit that opens a hole to the boundary (a cut from a hole's corner): two
#: join tolerances, far below a bead width, so the beads of the pieces on both sides close it.
SLIT = 2 * TOL.join


def reflex_corners(
    region: Polygon, min_turn_deg: float = MIN_TURN_DEG
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(vertex, incoming edge direction, outgoing edge direction) of every reflex corner, mm/unit.

    Rings are oriented so the section lies on the left (exterior counter-clockwise, holes
    clockwise): a right turn of more than `min_turn_deg` is a reflex corner."""
    poly = shapely.orient_polygons(region.simplify(TOL.simplify, preserve_topology=True))
    out = []
    sin_min = math.sin(math.radians(min_turn_deg))
    cos_min = math.cos(math.radians(min_turn_deg))
    for ring in [poly.exterior, *poly.interiors]:
        c = np.asarray(ring.coords, dtype=float)[:-1]
        if len(c) < 3:
            continue
        prev = c - np.roll(c, 1, axis=0)
        nxt = np.roll(c, -1, axis=0) - c
        lp = np.hypot(*prev.T)
        ln = np.hypot(*nxt.T)
        ok = (lp > TOL.min_segment) & (ln > TOL.min_segment)
        u_in = prev / np.where(ok, lp, 1.0)[:, None]
        u_out = nxt / np.where(ok, ln, 1.0)[:, None]
        cross = u_in[:, 0] * u_out[:, 1] - u_in[:, 1] * u_out[:, 0]
        dot = np.einsum("ij,ij->i", u_in, u_out)
        # turning right (cross < 0) by more than min_turn: sin of the turn > sin_min or turn > 90°
        reflex = ok & (cross < 0) & ((-cross > sin_min) | (dot < cos_min))
        out += [(c[i], u_in[i], u_out[i]) for i in np.flatnonzero(reflex)]
    return out


def _reaches(region: Polygon, starts: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Length (mm) of the cut from each corner `starts[k]` along unit direction `dirs[k]` to the
    first boundary hit inside the section (NaN where the ray hits nothing or runs outside first),
    and whether it joins two rings (it opens a hole, dividing nothing). All rays at once (one
    shapely call per step): a layer of 205 holes had 396 corners."""
    x0, y0, x1, y1 = region.bounds
    reach = 2.0 * math.hypot(x1 - x0, y1 - y0) + 1.0
    rays = shapely.linestrings(np.stack([starts, starts + reach * dirs], axis=1))
    # the boundary's segments in a tree: a ray meets few of a many-holed layer's thousands
    ring_xy = [np.asarray(r.coords, dtype=float) for r in (region.exterior, *region.interiors)]
    segs = shapely.linestrings(np.concatenate([np.stack([c[:-1], c[1:]], axis=1) for c in ring_xy]))
    ring_of = np.repeat(np.arange(len(ring_xy)), [len(c) - 1 for c in ring_xy])
    tree = shapely.STRtree(segs)
    ray_i, seg_i = tree.query(rays, predicate="intersects")
    out = np.full(len(starts), np.nan)
    joins = np.zeros(len(starts), dtype=bool)
    if len(ray_i):
        hits = shapely.intersection(rays[ray_i], segs[seg_i])
        pts, owner = shapely.get_coordinates(hits, return_index=True)
        k = ray_i[owner]
        d = np.einsum("ij,ij->i", pts - starts[k], dirs[k])
        far = d > 10 * TOL.join
        np.fmin.at(out, k[far], d[far])  # NaN where nothing is hit beyond the corner
        first = far & (d == out[k])
        _near_i, near_seg = tree.query_nearest(shapely.points(starts), return_distance=False)
        start_ring = np.empty(len(starts), dtype=int)
        start_ring[_near_i] = ring_of[near_seg]
        joins[k[first]] = ring_of[seg_i[owner[first]]] != start_ring[k[first]]
    ok = np.flatnonzero(~np.isnan(out))
    if len(ok):
        shapely.prepare(region)
        mids = shapely.points(starts[ok] + 0.5 * out[ok, None] * dirs[ok])
        out[ok[~shapely.contains(region, mids)]] = np.nan
    return out, joins


def _cut(
    region: Polygon, v: np.ndarray, u: np.ndarray, length: float, holes_may_open: bool = True
) -> tuple[float, list[Polygon]] | None:
    """Split `region` along the cut of `length` mm from corner v in unit direction u (`_reaches`):
    (cut length mm, pieces), or None when it does not cut it into pieces (nor opens a hole, when
    `holes_may_open`)."""
    blade = LineString([v - 10 * TOL.join * u, v + (length + 10 * TOL.join) * u])
    pieces = _parts(split(region, blade))
    lost = 0.0
    if len(pieces) == 1 and len(region.interiors) > 0:
        if not holes_may_open:
            return None
        # the cut joins a hole to another ring: it opens the hole instead of dividing the section;
        # shapely's split keeps such a cut closed, so a slit SLIT mm wide is taken out instead
        pieces = _parts(region.difference(blade.buffer(SLIT / 2.0, cap_style="flat")))
        lost = SLIT * (length + 20 * TOL.join)
        if len(pieces) != 1 or len(pieces[0].interiors) >= len(region.interiors):
            return None
    elif len(pieces) < 2 or min(p.area for p in pieces) < MIN_PIECE_SHARE * region.area:
        return None
    if abs(sum(p.area for p in pieces) + lost - region.area) > 1e-6 * max(region.area, 1.0) + lost:
        return None
    return length, pieces


def _parts(geom) -> list[Polygon]:
    return [g for g in shapely.get_parts(geom) if isinstance(g, Polygon) and g.area > TOL.min_area]


def _best_cut(region: Polygon, holes_may_open: bool = True) -> list[Polygon] | None:
    """The shortest cut that divides the section (at equal length the one leaving the larger
    piece), or opens a hole when `holes_may_open`: candidates by length, split only until the
    shortest that works is known."""
    corners = reflex_corners(region)
    if not corners:
        return None
    # per corner: the incoming edge continued, the outgoing edge continued backwards
    starts = np.array([v for v, _i, _o in corners for _ in (0, 1)], dtype=float)
    dirs = np.array([d for _v, u_in, u_out in corners for d in (u_in, -u_out)], dtype=float)
    lengths, joins = _reaches(region, starts, dirs)
    usable = ~np.isnan(lengths) & (holes_may_open | ~joins)
    best = None
    for k in sorted(np.flatnonzero(usable), key=lambda k: (round(float(lengths[k]), 6), k)):
        if best is not None and round(float(lengths[k]), 6) > best[0][0]:
            break  # longer than a cut that works: no better rank left
        got = _cut(region, starts[k], dirs[k], float(lengths[k]), holes_may_open)
        if got is None:
            continue
        length, pieces = got
        rank = (round(length, 6), -max(p.area for p in pieces))
        if best is None or rank < best[0]:
            best = (rank, pieces)
    return None if best is None else best[1]


def corner_division(region: Polygon, max_pieces: int = MAX_PIECES) -> list[Polygon]:
    """The section cut at its reflex corners (see module doc): pieces largest first; [region] when
    it has no corner to cut at. At most `max_pieces` - 1 cuts in all, those opening a hole
    included, and `MAX_HOLES_OPENED` of those."""
    done: list[Polygon] = []
    todo = [region]
    cuts = opened = 0
    while todo:
        p = todo.pop()
        if len(done) + len(todo) + 1 >= max_pieces or cuts >= max_pieces - 1:
            done.append(p)
            continue
        pieces = _best_cut(p, holes_may_open=opened < MAX_HOLES_OPENED)
        if pieces is None:
            done.append(p)
        else:
            cuts += 1
            opened += len(pieces) == 1
            todo += pieces
    return sorted(done, key=lambda g: -g.area)
