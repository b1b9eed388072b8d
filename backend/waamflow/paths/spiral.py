"""Spiral (robot study; reconstructed): a contour-parallel spiral inward, inside the section.

The study only says "a rectangular spiral inside the OR" and gives its programmed length (small
OR: 215.710 mm). Reconstruction, for any polygon: rings are the region's inward offsets (mitred,
so a rectangle stays a rectangle) at W_bound, W_bound + W_WB, W_bound + 2·W_WB, ... (W_bound and the
pass count from the study's rule across the guide). Each ring is run counter-clockwise from its
point nearest the current position and left W_WB before closing, then a straight step joins the
nearest point of the next ring. When the next offset vanishes but the half-step offset does not,
the remaining core is one centre pass (the long axis of the core, clipped to it and shortened by
W_WB/2 at each end). Like `rectangular`, the arc is struck on the boundary: a lead-in runs back
from the spiral's start along its first stretch to the section boundary. The spiral starts at
the ring vertex nearest the guide start (on a rectangle a corner, so every ring starts at its
corner and every step is exactly W_WB).
Small OR: 1.89 + 5 × 39.22 + 4 × 4.43 = 215.710 mm (exact). Run-ups extend the lead-in and the
last segment. Non-convex sections whose offsets split keep the largest piece of each ring; a
section only one pass wide gets that one pass; holes are not followed (crossing them is flagged
outside).
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.ops import substring

from ..geometry.chordal_axis import chordal_axis
from .flags import Draft, extend_ends
from .frame import guide_or_default, pass_layout
from .passes import band, end_direction, to_boundary
from .spec import StrategySpec


def _largest(geom) -> Polygon | None:
    parts = [g for g in shapely.get_parts(geom) if isinstance(g, Polygon) and not g.is_empty]
    return max(parts, key=lambda g: g.area) if parts else None


def _ring_path(poly: Polygon, at: np.ndarray, leave: float) -> np.ndarray:
    """(k, 2) points running counter-clockwise once around poly's exterior from the point nearest
    `at`, stopping `leave` mm before closing."""
    ring = LineString(shapely.orient_polygons(poly).exterior.coords)
    per = ring.length
    s0 = ring.project(Point(at))
    run = max(per - leave, 0.0)
    first = substring(ring, s0, min(s0 + run, per))
    pts = np.asarray(first.coords, dtype=float)
    if s0 + run > per:
        rest = substring(ring, 0.0, s0 + run - per)
        pts = np.vstack([pts, np.asarray(rest.coords, dtype=float)[1:]])
    return pts


def _core_line(core: Polygon, shorten: float, at: np.ndarray, keep_fraction: float = 0.0) -> np.ndarray | None:
    """The long axis of the core's minimum rotated rectangle, clipped to the core (longest piece),
    shortened by `shorten` mm at each end (or by keep_fraction of its length, when given) and
    oriented to start at the end nearest `at`."""
    rect = np.asarray(shapely.minimum_rotated_rectangle(core).exterior.coords)[:4]
    e1, e2 = rect[1] - rect[0], rect[2] - rect[1]
    axis = e1 if np.hypot(*e1) >= np.hypot(*e2) else e2
    u = axis / np.hypot(*axis)
    c = rect.mean(axis=0)
    reach = float(np.hypot(*axis))
    pieces = [
        g
        for g in shapely.get_parts(LineString([c - reach * u, c + reach * u]).intersection(core))
        if g.geom_type == "LineString"
    ]
    if not pieces:
        return None
    piece = max(pieces, key=lambda g: g.length)
    if keep_fraction:
        shorten = keep_fraction * piece.length
    if piece.length - 2 * shorten <= 1e-9:
        return None
    ends = np.asarray(substring(piece, shorten, piece.length - shorten).coords, dtype=float)[[0, -1]]
    return ends if np.hypot(*(ends[0] - at)) <= np.hypot(*(ends[1] - at)) else ends[::-1]


def plan(region: Polygon, guide: LineString | None, spec: StrategySpec) -> Draft:
    d = spec.spacing
    t_min, t_max = band(region, guide_or_default(region, guide), d)
    m = pass_layout(t_max - t_min, d)[1]
    g0 = np.asarray(guide_or_default(region, guide).coords[0], dtype=float)
    ring0 = _largest(region.buffer(-m, join_style="mitre"))
    if ring0 is None or _thin(ring0, d):
        return _single_pass(region, m, g0, spec)
    start = _start_vertex(ring0, g0)
    here, k = start, 0
    pieces = []
    while True:
        ring = _largest(region.buffer(-(m + k * d), join_style="mitre")) if k else ring0
        if ring is None or _thin(ring, d):
            core = _largest(region.buffer(-(m + (k - 0.5) * d), join_style="mitre")) if k else None
            if core is not None and not _thin(core, 0.5 * d):
                line = _core_line(core, d / 2, here)
                if line is not None:
                    pieces.append(line)
            break
        pts = _ring_path(ring, here, d)
        pieces.append(pts)
        here = pts[-1]
        k += 1
    pts = np.vstack(pieces)
    entry = to_boundary(region, pts[0], end_direction(pts))  # lead-in along the first stretch
    pts = extend_ends(np.vstack([entry[None], pts]), spec.extension_before, spec.extension_after)
    return Draft(pts, np.ones(len(pts) - 1, dtype=bool))


def _start_vertex(ring: Polygon, near: np.ndarray) -> np.ndarray:
    """The convex vertex of the ring nearest `near` (a concave corner would make the lead-in cross
    the spiral)."""
    c = np.asarray(shapely.orient_polygons(ring).exterior.coords, dtype=float)[:-1]
    prev, nxt = np.roll(c, 1, axis=0), np.roll(c, -1, axis=0)
    e0, e1 = c - prev, nxt - c
    convex = e0[:, 0] * e1[:, 1] - e0[:, 1] * e1[:, 0] > 0
    cand = c[convex] if convex.any() else c
    return cand[np.argmin(np.hypot(*(cand - near).T))]


def _single_pass(region: Polygon, m: float, g0: np.ndarray, spec: StrategySpec) -> Draft:
    """A section only one pass wide: its centre line (kept m mm from the ends, less on a section
    shorter than that), with a lead-in."""
    core = _largest(region.buffer(-m / 2.0, join_style="mitre"))
    line = None if core is None or core.area == 0 else _core_line(core, m / 2.0, g0)
    if line is None:
        line = _core_line(region, 0.0, g0, keep_fraction=0.25)
    if line is None:  # a bent section (a V) whose rectangle's long axis misses it: its chordal axis
        axis = chordal_axis(region, max(m / 4.0, 1e-3))
        line = axis if np.hypot(*(axis[0] - g0)) <= np.hypot(*(axis[-1] - g0)) else axis[::-1]
    entry = to_boundary(region, line[0], end_direction(line))
    pts = extend_ends(np.vstack([entry[None], line]), spec.extension_before, spec.extension_after)
    return Draft(pts, np.ones(len(pts) - 1, dtype=bool))


def _thin(poly: Polygon, width: float) -> bool:
    """True when the polygon is narrower than `width`·0.5 (a sliver left by round-off)."""
    rect = np.asarray(shapely.minimum_rotated_rectangle(poly).exterior.coords)[:4]
    short = min(np.hypot(*(rect[1] - rect[0])), np.hypot(*(rect[2] - rect[1])))
    return short < 0.5 * width
