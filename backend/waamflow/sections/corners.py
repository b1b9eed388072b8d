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


def _cut(region: Polygon, v: np.ndarray, u: np.ndarray) -> tuple[float, list[Polygon]] | None:
    """Split `region` along the ray from corner v in unit direction u up to the first boundary hit:
    (cut length mm, pieces), or None when the ray does not cut it into pieces."""
    x0, y0, x1, y1 = region.bounds
    reach = 2.0 * math.hypot(x1 - x0, y1 - y0) + 1.0
    ray = LineString([v, v + reach * u])
    hits = shapely.get_coordinates(ray.intersection(region.boundary))
    d = (hits - v) @ u
    d = d[d > 10 * TOL.join]
    if len(d) == 0:
        return None
    length = float(d.min())
    mid = v + 0.5 * length * u
    if not region.contains(shapely.points(mid)):
        return None
    blade = LineString([v - 10 * TOL.join * u, v + (length + 10 * TOL.join) * u])
    pieces = _parts(split(region, blade))
    lost = 0.0
    if len(pieces) == 1 and len(region.interiors) > 0:
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


def _best_cut(region: Polygon) -> list[Polygon] | None:
    best = None
    for v, u_in, u_out in reflex_corners(region):
        for u in (u_in, -u_out):  # the incoming edge continued, the outgoing edge continued backwards
            got = _cut(region, v, u)
            if got is None:
                continue
            length, pieces = got
            rank = (round(length, 6), -max(p.area for p in pieces))
            if best is None or rank < best[0]:
                best = (rank, pieces)
    return None if best is None else best[1]


def corner_division(region: Polygon, max_pieces: int = MAX_PIECES) -> list[Polygon]:
    """The section cut at its reflex corners (see module doc): pieces largest first; [region] when
    it has no corner to cut at."""
    done: list[Polygon] = []
    todo = [region]
    while todo:
        p = todo.pop()
        if len(done) + len(todo) + 1 >= max_pieces:
            done.append(p)
            continue
        pieces = _best_cut(p)
        if pieces is None:
            done.append(p)
        else:
            todo += pieces
    return sorted(done, key=lambda g: -g.area)
