"""Fillets of thin walls (Venturini et al. 2018, §4), for `walls`: corner paths turned on an arc
(`round_corners`: the path on the midsurface of a filleted wall, radius R_f + EWW/2) and the check
that a crossing's fillet corners get metal (`fillet_region`: the finished fillet between two
branches; `fillet_uncovered`: the corners the deposited beads leave partly empty).

All coordinates layer-local (x, y) mm, angles deg unless named otherwise.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from shapely.geometry import LineString, Point, Polygon
from shapely.ops import unary_union

from .junctions import _unit

if TYPE_CHECKING:
    from .walls import WallSpec


# Largest sagitta (mm) of the chords that lay a corner fillet arc: far below a bead's ripple.
FILLET_SAGITTA = 0.002


def _arc(a: np.ndarray, b: np.ndarray, center: np.ndarray, radius: float, left: bool) -> np.ndarray:
    """(m, 2) points from a to b (both on the circle) along the shorter arc, turning left or right,
    chords deviating at most FILLET_SAGITTA from the arc; a and b excluded."""
    a0 = math.atan2(*(a - center)[::-1])
    b0 = math.atan2(*(b - center)[::-1])
    sweep = (b0 - a0) % (2 * math.pi) if left else -((a0 - b0) % (2 * math.pi))
    step = 2.0 * math.acos(max(1.0 - FILLET_SAGITTA / radius, -1.0))
    n = max(8, int(math.ceil(abs(sweep) / step)))
    t = a0 + sweep * np.arange(1, n) / n
    return center + radius * np.column_stack([np.cos(t), np.sin(t)])


def round_corners(xy: np.ndarray, corners: list[dict], radius: float, tol: float) -> tuple[np.ndarray, list[str]]:
    """Turn the path `xy` (k, 2) at every interior vertex that is a corner feature on an arc of
    `radius` mm tangent to both walls (a shorter wall clips the radius, with a note). Corner
    features: dicts with "point" and "kind". Returns (new points, notes)."""
    if radius <= 0 or len(xy) < 3 or not corners:
        return xy, []
    pts = np.array([f["point"] for f in corners], float)
    at = [k for k in range(1, len(xy) - 1) if float(np.hypot(*(pts - xy[k]).T).min()) <= tol]
    if not at:
        return xy, []
    notes: list[str] = []
    out: list[np.ndarray] = [xy[0]]
    for k in range(1, len(xy) - 1):
        p = xy[k]
        if k not in at:
            out.append(p)
            continue
        u, v = _unit(p - xy[k - 1]), _unit(xy[k + 1] - p)
        turn = math.atan2(u[0] * v[1] - u[1] * v[0], float(u @ v))
        if abs(turn) < 1e-9:
            out.append(p)
            continue
        share_a = 0.5 if k - 1 in at else 1.0  # a wall between two rounded corners: half each
        share_b = 0.5 if k + 1 in at else 1.0
        room = min(share_a * float(np.hypot(*(p - xy[k - 1]))), share_b * float(np.hypot(*(xy[k + 1] - p))))
        r = radius
        t = r * math.tan(abs(turn) / 2.0)
        if t > room + 1e-9:
            r = room / math.tan(abs(turn) / 2.0)
            t = room
            where = [round(float(x), 3) + 0.0 for x in p]
            notes.append(
                f"corner at {where}: fillet path radius {radius:g} mm needs {radius * math.tan(abs(turn) / 2):.1f} "
                f"mm of straight wall each side, there is {room:.1f} mm: turned on {r:.2f} mm"
            )
        if r <= tol:
            out.append(p)
            continue
        a, b = p - u * t, p + v * t
        left = turn > 0
        normal = np.array([-u[1], u[0]]) if left else np.array([u[1], -u[0]])
        center = a + normal * r
        out.append(a)
        out.extend(_arc(a, b, center, r, left))
        out.append(b)
    out.append(xy[-1])
    arr = np.asarray(out, float)
    keep = np.concatenate([[True], np.hypot(*np.diff(arr, axis=0).T) > 1e-9])
    return arr[keep], notes


def fillet_region(center, d0, d1, eww: float, fillet_radius: float) -> Polygon:
    """The finished fillet between two branches leaving `center` along unit d0 and d1 (CCW, corner
    angle α < 180°): bounded by the wall faces at EWW/2 from the branches and the fillet arc of
    radius R_f tangent to both. Polygon (mm)."""
    center, d0, d1 = (np.asarray(x, float) for x in (center, d0, d1))
    alpha = math.atan2(d0[0] * d1[1] - d0[1] * d1[0], float(d0 @ d1)) % (2 * math.pi)
    bis = _unit(d0 + d1)
    e, R = eww / 2.0, fillet_radius
    q = center + bis * (e / math.sin(alpha / 2.0))  # where the two faces meet
    o = center + bis * ((e + R) / math.sin(alpha / 2.0))  # fillet arc centre
    n0 = np.array([-d0[1], d0[0]])  # d0's normal into the corner
    n1 = np.array([d1[1], -d1[0]])  # d1's normal into the corner
    t0 = center + d0 * float((o - center) @ d0) + n0 * e
    t1 = center + d1 * float((o - center) @ d1) + n1 * e
    kite = Polygon([q, t0, o, t1])
    return kite.difference(Point(o).buffer(R, quad_segs=64))


def fillet_uncovered(f: dict, passes, spec: "WallSpec") -> list[tuple[float, float, float]]:
    """Fillet corners of crossing `f` that the deposited beads (width spec.bead_width, centred on
    `passes`) leave partly empty: (branch angle, next branch angle (deg), empty area mm²) for
    each corner whose empty share of the finished fillet (radius spec.fillet_radius) exceeds 1 %."""
    w, R = spec.bead_width, spec.fillet_radius
    if w <= 0 or R <= 0 or "directions" not in f:
        return []
    J = np.asarray(f["point"], float)
    dirs = [np.asarray(d, float) for d in f["directions"]]
    reach = (spec.effective_width / 2.0 + R) * 4.0 + spec.influence_radius + w
    near = Point(J).buffer(reach)
    beads = [
        LineString(p.xy).buffer(w / 2.0, quad_segs=16)
        for p in passes
        if len(p.xy) >= 2 and LineString(p.xy).intersects(near)
    ]
    deposit = unary_union(beads) if beads else Polygon()
    out = []
    for k, alpha in enumerate(f["corner_angles_deg"]):
        if alpha > 180.0 - spec.corner_angle_deg:
            continue  # flat or reflex: no fillet
        region = fillet_region(J, dirs[k], dirs[(k + 1) % len(dirs)], spec.effective_width, R)
        if region.is_empty or region.area <= 0:
            continue
        empty = region.difference(deposit).area
        if empty > 0.01 * region.area:
            a0 = math.degrees(math.atan2(dirs[k][1], dirs[k][0])) % 360.0
            a1 = math.degrees(math.atan2(dirs[(k + 1) % len(dirs)][1], dirs[(k + 1) % len(dirs)][0])) % 360.0
            out.append((a0, a1, float(empty)))
    return out
