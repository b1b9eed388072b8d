"""The study's passes over any section, along straight or curved guides (world coordinates).

Pass k is the guide offset sideways by t_k = t_min + W_bound + k·W_WB (left of the guide
positive), clipped to the section from its first entry to its last exit, oriented along the
guide. t_min..t_max is the section's extent across the guide: exact in the straight frame for a
straight guide, measured on the guide's normals every W_WB/2 for a curved one. The guide is first
extended tangentially so every offset reaches the boundary.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon
from shapely.ops import substring

from .frame import NUDGE, cross_chord, nudged, extend_line, pass_layout, straight_frame


@dataclass(frozen=True, eq=False)
class Pass:
    """One pass: offset t (mm, left of the guide positive) and its points (k, 2) mm along the guide."""

    t: float
    points: np.ndarray

    @property
    def line(self) -> LineString:
        return LineString(self.points)


@dataclass(frozen=True, eq=False)
class PassPlan:
    """Passes in order of increasing t, the boundary margin W_bound (mm) and the section width (mm)."""

    passes: tuple[Pass, ...]
    margin: float
    width: float
    straight: bool
    guide: LineString  # the guide extended well past the section (for offsets)
    region: Polygon


def is_straight(guide: LineString, tol: float = 1e-9) -> bool:
    c = np.asarray(guide.coords, dtype=float)
    d = c[-1] - c[0]
    n = float(np.hypot(*d))
    if len(c) == 2 or n == 0.0:
        return True
    off = np.abs((c - c[0]) @ np.array([-d[1], d[0]]) / n)
    return bool(off.max() <= tol)


def reach_of(region: Polygon) -> float:
    x0, y0, x1, y1 = region.bounds
    return 2.0 * math.hypot(x1 - x0, y1 - y0) + 1.0


def band(region: Polygon, guide: LineString, spacing: float) -> tuple[float, float]:
    """(t_min, t_max): the section's extent across the guide, mm."""
    if is_straight(guide):
        _, t_min, _, t_max = straight_frame(region, guide).local(region).bounds
        return t_min, t_max
    from .oscillate import stations  # curved guide: chords on the normals

    probe = nudged(region)
    pts, normals = stations(region, guide, spacing / 2.0)
    lims = np.array([cross_chord(probe, p, n, reach_of(region)) for p, n in zip(pts, normals)])
    return float(lims[:, 0].min()) + NUDGE, float(lims[:, 1].max()) - NUDGE


def _single(curve) -> LineString | None:
    """An offset of a strongly curved guide may come back in pieces: keep the longest."""
    if curve.is_empty:
        return None
    if curve.geom_type != "LineString":
        curve = shapely.line_merge(curve)
    parts = [g for g in shapely.get_parts(curve) if g.geom_type == "LineString" and g.length > 0]
    return max(parts, key=lambda g: g.length) if parts else None


# A pass closer than this to the guide is the guide (no deposit can tell): GEOS's offset of a guide
# of nearly collinear points by under ~1e-6 mm can fail outright ("cannot create std::vector larger
# than max_size()"; 1,113 of 20,000 distances drawn from 1e-14-1e-6 mm on the test's guide, none of
# 40,000 from 1e-6-10 mm).
OFFSET_MIN_MM = 1e-6


def offset_piece(long_guide: LineString, t: float, target) -> np.ndarray | None:
    """(k, 2) points of the guide offset by t (mm, left +) from its first entry into `target` to its
    last exit, or None when it misses."""
    curve = long_guide if abs(t) < OFFSET_MIN_MM else _single(long_guide.offset_curve(t))
    if curve is None:
        return None
    inter = curve.intersection(target)
    if inter.is_empty:
        return None
    s = shapely.line_locate_point(curve, shapely.points(shapely.get_coordinates(inter)))
    a, b = float(s.min()), float(s.max())
    if b - a <= 1e-9:
        return None
    return np.asarray(substring(curve, a, b).coords, dtype=float)


def plan_passes(region: Polygon, guide: LineString, spacing: float, inset: float | None = None) -> PassPlan:
    """Lay out the study's passes across a section (see module doc). With `inset` (mm, e.g. W_bound
    for the in-section patterns) passes are clipped to the region shrunk by that distance (mitred
    corners), so pass ends keep the same margin to the boundary as the sides."""
    t_min, t_max = band(region, guide, spacing)
    width = t_max - t_min
    n, margin = pass_layout(width, spacing)
    reach = reach_of(region)
    long_guide = extend_line(guide, reach, reach)
    target = region
    if inset is not None and inset > NUDGE:
        target = region.buffer(-(inset - NUDGE), join_style="mitre")
    passes = []
    for k in range(n):
        t = t_min + margin + k * spacing
        pts = offset_piece(long_guide, t, target)
        if pts is None and target is not region:
            pts = offset_piece(long_guide, t, region)
        if pts is not None:
            passes.append(Pass(t, pts))
    if not passes:
        raise ValueError(_no_pass(long_guide, t_min, width, margin, n, spacing))
    return PassPlan(tuple(passes), margin, width, is_straight(guide), long_guide, region)


def _no_pass(long_guide: LineString, t_min: float, width: float, margin: float, n: int, spacing: float) -> str:
    """Why no offset of the guide crossed the section, and what to do."""
    ts = [t_min + margin + k * spacing for k in range(n)]
    folded = sum(1 for t in ts if abs(t) >= OFFSET_MIN_MM and len(shapely.get_parts(long_guide.offset_curve(t))) > 1)
    text = (
        f"no pass fits the section: none of the {n} offsets of its guide ({spacing:.2f} mm apart across its "
        f"{width:.1f} mm wide band) crosses it"
    )
    if folded:
        return (
            text + f"; the guide turns back on itself ({folded} of its offsets fall apart): draw a smoother guide "
            "with no turn sharper than the section is wide, or choose contour"
        )
    return text + ": draw the guide across the section, or choose contour"


def end_direction(pts: np.ndarray, at_start: bool = True) -> np.ndarray:
    """Unit direction out of the path at its start (backwards along its first stretch) or end
    (onwards along its last), from the nearest point that differs from the end point: a path may
    begin with a repeated point (compas_slicer's bunny, layer 41: a spiral's first two points were
    equal, its lead-in direction 0/0). Zero when every point is the same."""
    q = pts if at_start else pts[::-1]
    d = np.hypot(*(q[1:] - q[0]).T)
    far = np.flatnonzero(d > 1e-9)
    if not len(far):
        return np.zeros(2)
    return (q[0] - q[far[0] + 1]) / d[far[0]]


def oriented(p: Pass, forward: bool, before: float, after: float) -> np.ndarray:
    """The pass's points in travel direction, with straight run-ups of `before`/`after` mm."""
    pts = p.points if forward else p.points[::-1]
    out = [pts]
    if before > 0:
        out.insert(0, (pts[0] + before * end_direction(pts))[None])
    if after > 0:
        out.append((pts[-1] + after * end_direction(pts, at_start=False))[None])
    return np.vstack(out)


def to_boundary(region: Polygon, p: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Where a ray from p along unit `direction` first meets the region boundary (p if nowhere, or
    when the direction is zero)."""
    if not np.isfinite(direction).all() or not np.any(direction):
        return p
    ray = LineString([p, p + reach_of(region) * direction])
    hits = shapely.get_coordinates(ray.intersection(region.boundary))
    if len(hits) == 0:
        return p
    return hits[np.argmin(np.hypot(*(hits - p).T))]
