"""Geometry shared by the patterns: the study's pass layout rule, the straight guide frame, guide
stations and chords across the section.

A straight `Frame` puts a section in (s, t) coordinates: s along the guide's chord, t across it
(left of the guide positive), origin at the guide's start, mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon

from ..core.geom import default_guide
from ..core.tolerances import TOL

#: Robot study (da Silva Viola et al. 2023, §OR definition): a pass is added while the boundary
#: margin W_bound exceeds this fraction of the bead spacing W_WB.
MARGIN_RATIO = 0.4

#: Offsets and pass lines are nudged by this (mm) so a pass lying exactly on an inset edge still
#: intersects it despite round-off; the project's merge tolerance, far below machine resolution.
NUDGE = TOL.merge


def pass_layout(width: float, spacing: float) -> tuple[int, float]:
    """Pass count n_WB and boundary margin W_bound (mm) for a section `width` mm wide.

    Robot study rule: n = floor(W / W_WB), W_bound = (W − (n − 1)·W_WB) / 2, and a pass is added
    while W_bound > 0.4·W_WB. Small OR 21.5 mm → 5 passes, 1.89 mm; large OR 43 mm → 10 passes,
    1.57 mm. Since floor() leaves W_bound in [W_WB/2, W_WB), at most one pass is ever added; we
    refuse to add it when it would leave a zero margin (W an exact multiple of W_WB: the study's
    rule would put the outer passes on the boundary, half their bead outside) — e.g. 12 mm at a
    6 mm spacing gives 2 passes 3 mm from the edges, not 3 passes with the outer two on them.
    """
    if width <= 0 or spacing <= 0:
        raise ValueError("width and spacing must be positive")
    n = max(1, math.floor(width / spacing + 1e-9))
    margin = (width - (n - 1) * spacing) / 2.0
    while margin > MARGIN_RATIO * spacing and (width - n * spacing) / 2.0 > 1e-9:
        n += 1
        margin = (width - (n - 1) * spacing) / 2.0
    return n, margin


@dataclass(frozen=True)
class Frame:
    """Straight pass frame: origin (2,) mm, u (2,) unit pass direction, v (2,) unit left normal."""

    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray

    def to_local(self, xy: np.ndarray) -> np.ndarray:
        """(k, 2) layer-local x, y → (k, 2) s, t (mm)."""
        d = np.asarray(xy, dtype=float).reshape(-1, 2) - self.origin
        return np.column_stack([d @ self.u, d @ self.v])

    def to_world(self, st: np.ndarray) -> np.ndarray:
        """(k, 2) s, t → (k, 2) layer-local x, y (mm)."""
        st = np.asarray(st, dtype=float).reshape(-1, 2)
        return self.origin + st[:, :1] * self.u + st[:, 1:] * self.v

    def local(self, geom):
        return shapely.transform(geom, self.to_local)


def guide_or_default(region: Polygon, guide: LineString | None) -> LineString:
    return default_guide(region) if guide is None or guide.is_empty else guide


def straight_frame(region: Polygon, guide: LineString | None) -> Frame:
    """Frame along the chord of the guide (start → end); a curved guide gives its overall direction."""
    g = np.asarray(guide_or_default(region, guide).coords, dtype=float)
    d = g[-1] - g[0]
    norm = float(np.hypot(*d))
    if norm == 0.0:
        raise ValueError("guide has coincident start and end")
    u = d / norm
    return Frame(origin=g[0].copy(), u=u, v=np.array([-u[1], u[0]]))


def unit_tangent(line: LineString, s: float, h: float) -> np.ndarray:
    """(2,) unit tangent of a polyline at arc length s (mm), central difference over ±h (mm)."""
    a = np.asarray(line.interpolate(max(s - h, 0.0)).coords[0])
    b = np.asarray(line.interpolate(min(s + h, line.length)).coords[0])
    d = b - a
    n = float(np.hypot(*d))
    if n == 0.0:
        c = np.asarray(line.coords, dtype=float)
        d, n = c[-1] - c[0], float(np.hypot(*(c[-1] - c[0])))
    return d / n


def extend_line(line: LineString, before: float, after: float) -> LineString:
    """The polyline with straight tangent extensions of `before`/`after` mm at its ends."""
    c = np.asarray(line.coords, dtype=float)
    t0 = c[1] - c[0]
    t1 = c[-1] - c[-2]
    t0 /= np.hypot(*t0)
    t1 /= np.hypot(*t1)
    pts = [c[0] - before * t0] if before > 0 else []
    pts += list(c)
    if after > 0:
        pts.append(c[-1] + after * t1)
    return LineString(pts)


def guide_span(region: Polygon, guide: LineString) -> tuple[float, float]:
    """Arc-length range (mm) of the guide from its first entry into the region to its last exit."""
    inter = guide.intersection(region)
    if inter.is_empty:
        raise ValueError("guide does not cross the section")
    pts = shapely.get_coordinates(inter)
    s = shapely.line_locate_point(guide, shapely.points(pts))
    return float(s.min()), float(s.max())


def nudged(region):
    """The region grown by NUDGE with mitred corners, valid: GEOS's mitre buffer of a sliver can
    come back crossing itself (a fuzzed 21.8 mm² piece: a 3e-12 mm² lobe through it), and every
    chord cut from it then stopped with "TopologyException: side location conflict"."""
    grown = region.buffer(NUDGE, join_style="mitre")
    if grown.is_valid:
        return grown
    return region.buffer(NUDGE, quad_segs=8)  # round joins: what the mitre was for (a straight end) holds


def cross_chord(region: Polygon, p: np.ndarray, n: np.ndarray, reach: float) -> tuple[float, float]:
    """Extent (t_lo, t_hi) along unit direction n of the region's chord through point p (mm),
    taking the piece of the chord that contains p (or the nearest piece)."""
    line = LineString([p - reach * n, p + reach * n])
    inter = line.intersection(region)
    parts = [g for g in shapely.get_parts(inter) if not g.is_empty and g.length > 0]
    if not parts:
        return 0.0, 0.0
    pt = shapely.points(p)
    best = min(parts, key=lambda g: g.distance(pt))
    c = shapely.get_coordinates(best) - p
    t = c @ n
    return float(t.min()), float(t.max())
