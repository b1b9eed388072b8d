"""Corner blending: the geometric path a CP controller really interpolates through a polyline.

Model (robot-modelling-notes.md, "Corner blending model"): at every vertex that is not an exact
stop, the vertex is replaced by a tangent curve that starts d before and ends d after it, with

    d = min(CDIS, (CDIS/CDIS_REF)·(d_min + v·apo_time), L_prev/2, L_next/2)   (KUKA `C_DIS`, mode "cdis")
    d = min(zone, L_prev/2, L_next/2)                     (ABB zonedata `zN`, mode "zone")

The KUKA curve is a circular arc (radius r = d / tan(α/2) for a turn angle α), the ABB "corner
path" a parabola. Both are written as one rational quadratic Bézier with control point at the
vertex and middle weight w = cos(α/2) (arc) or 1 (parabola). The corner speed cap is

    v_c = min(v_prev, v_next, √(a_n·r), (j_n·r²)^(1/3), min(v_prev, v_next)·r/ρ)

with r the curve's smallest radius of curvature (arc: d/tan(α/2); parabola: d·cos²(α/2)/sin(α/2))
and ρ the turn radius (the direction turns no faster than v/ρ; the last term is off when ρ = 0).

The speed-dependent part is the share of C_DIS a KRC really uses at speed v: the profile's
d_min and apo_time were fitted at the study's `$APO.CDIS = 5 mm` (CDIS_REF), and the law scales
them in proportion to the programmed C_DIS, so a larger C_DIS cuts corners further (more
deviation, shorter time) until half a segment limits it. At CDIS_REF the law is the fitted one.
(Before, `min(CDIS, d_min + v·apo_time)` saturated at d_min + v·apo_time = 1.81 mm at 40 mm/s:
every C_DIS ≥ 2 mm gave the same path.) The proportionality is assumed, not measured: the study
ran one C_DIS only.

G-code motion planners (mode "junction": grbl, Marlin with JUNCTION_DEVIATION, Klipper, and
LinuxCNC's exact-path mode) do not cut the corner: the tool follows the polyline and only the
speed at the junction is limited, from the junction deviation δ and the acceleration a
(grbl `planner.c`, the robot-modelling notes' CNC fallback):

    v_j = √(a·δ·sin(θ/2) / (1 − sin(θ/2))),   θ the interior angle between the two moves

(straight on: no limit; an exact reversal: 0, a stop).

All arrays are world mm. Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CURVE_POINTS = 9  # samples per blend curve (odd: the middle one is the curve's apex)
CDIS_REF = 5.0  # mm: the $APO.CDIS the profiles' apo_min_mm / apo_time_s were fitted at (the study's)
MIN_CORNER_SPEED = 0.01  # mm/s: a blend slower than this is an exact stop (exact reversals)


@dataclass(frozen=True, eq=False)
class BlendedPath:
    """The geometric path through a polyline with blended corners.

    points: (m, 3) float dense polyline of the blended path, mm. s: (m,) cumulative arc length, mm.
    seg: (m,) int programmed segment each dense point belongs to.
    d: (n,) blend distance at each programmed vertex (0 at stops and the two ends), mm.
    radius: (n,) smallest radius of curvature of each blend (inf where none), mm.
    cap: (n,) corner speed cap, mm/s (0 at stops).
    s_in / s_out: (n,) arc length where each vertex's blend starts / ends, mm (equal without blend).
    """

    points: np.ndarray
    s: np.ndarray
    seg: np.ndarray
    d: np.ndarray
    radius: np.ndarray
    cap: np.ndarray
    s_in: np.ndarray
    s_out: np.ndarray

    @property
    def length(self) -> float:
        return float(self.s[-1]) if len(self.s) else 0.0

    def at(self, s: np.ndarray) -> np.ndarray:
        """(k,) arc lengths → (k, 3) points on the blended path (linear between dense samples)."""
        return np.column_stack([np.interp(s, self.s, self.points[:, i]) for i in range(3)])


def blend_path(
    points: np.ndarray,
    speed: np.ndarray,
    stop: np.ndarray,
    *,
    mode: str = "cdis",
    distance: float = 5.0,
    apo_time_s: float = np.inf,
    apo_min_mm: float = 0.0,
    normal_acc: float = np.inf,
    normal_jerk: float = np.inf,
    turn_radius: float = 0.0,
    catchup: np.ndarray | None = None,
) -> BlendedPath:
    """Blend the corners of a polyline.

    points: (n, 3) mm, no zero-length segments. speed: (n-1,) programmed mm/s per segment.
    stop: (n,) bool, exact stop at the vertex (arc switch, dwell, ends). mode: "cdis" | "zone".
    distance: CDIS or zone radius, mm (0 = exact stop everywhere).
    normal_acc, normal_jerk: corner caps √(a_n·r), (j_n·r²)^(1/3) on a blend of radius r.
    turn_radius: ρ, mm (0 = off): the direction of motion turns no faster than v/ρ rad/s (v the
    programmed speed) — a blend of radius r < ρ runs at v·r/ρ at most.
    catchup: (n,) 0…1 per vertex or None — the post-stop catch-up (mode "cdis"): the
    speed-dependent limit apo_min_mm + v·apo_time_s is lifted by this fraction towards the
    geometric one, and a neighbour that is an exact stop (no blend of its own) leaves
    (0.5 + 0.5·catchup) of the segment to this blend instead of half.
    """
    P = np.asarray(points, dtype=float)
    n = len(P)
    D = np.diff(P, axis=0)
    L = np.linalg.norm(D, axis=1)
    U = D / L[:, None]
    d = np.zeros(n)
    alpha = np.zeros(n)
    cap = np.zeros(n)
    radius = np.full(n, np.inf)
    if mode == "junction":
        if n > 2:
            cap[1:-1] = junction_speed(U[:-1], U[1:], np.minimum(speed[:-1], speed[1:]), normal_acc, float(distance))
    elif n > 2:
        u1, u2 = U[:-1], U[1:]
        alpha[1:-1] = np.arccos(np.clip(np.einsum("ij,ij->i", u1, u2), -1.0, 1.0))
        v_corner = np.minimum(speed[:-1], speed[1:])  # a blend's programmed speed: the lower of its two
        share_prev = np.full(n - 2, 0.5)
        share_next = np.full(n - 2, 0.5)
        c = None
        if catchup is not None and mode == "cdis":
            c = np.clip(np.asarray(catchup, dtype=float)[1:-1], 0.0, 1.0)
            st0 = np.asarray(stop, dtype=bool).copy()
            st0[0] = st0[-1] = True
            share_prev = np.where(st0[:-2], 0.5 + 0.5 * c, 0.5)
            share_next = np.where(st0[2:], 0.5 + 0.5 * c, 0.5)
        dk = np.minimum.reduce([np.full(n - 2, float(distance)), L[:-1] * share_prev, L[1:] * share_next])
        if mode == "cdis":
            d_apo = (float(distance) / CDIS_REF) * (apo_min_mm + apo_time_s * v_corner)
            if c is not None:
                d_apo = np.where(c > 0, d_apo + c * np.maximum(dk - d_apo, 0.0), d_apo)
            dk = np.minimum(dk, d_apo)
        turn = alpha[1:-1]
        dk = np.where(turn > 1e-9, dk, 0.0)
        half = turn / 2
        with np.errstate(divide="ignore", invalid="ignore"):
            if mode == "cdis":
                r = np.where(dk > 0, dk / np.tan(half), np.inf)
            else:
                r = np.where(dk > 0, dk * np.cos(half) ** 2 / np.sin(half), np.inf)
            vc = np.minimum.reduce([v_corner, np.sqrt(normal_acc * r), np.cbrt(normal_jerk * r * r)])
            if turn_radius > 0:  # turn rate v_c / r ≤ v / ρ
                vc = np.minimum(vc, v_corner * np.minimum(1.0, r / turn_radius))
        # no blend possible at a real corner (distance 0), or a blend the controller could only
        # creep through (an exact reversal: radius → 0) = exact stop
        crawl = vc < MIN_CORNER_SPEED
        dk = np.where(crawl, 0.0, dk)
        r = np.where(crawl, np.inf, r)
        vc = np.where(((dk <= 0) & (turn > 1e-9)) | crawl, 0.0, vc)
        d[1:-1], radius[1:-1], cap[1:-1] = dk, r, vc
    st = np.asarray(stop, dtype=bool).copy()
    st[0] = st[-1] = True
    d[st] = 0.0
    cap[st] = 0.0
    radius[st] = np.inf

    dense, seg, s, s_in, s_out = _dense_path(P, U, d, alpha, mode)
    return BlendedPath(dense, s, seg, d, radius, cap, s_in, s_out)


def _dense_path(
    P: np.ndarray, U: np.ndarray, d: np.ndarray, alpha: np.ndarray, mode: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The blended path as a dense polyline (`blend_path`): P0, then CURVE_POINTS of each
    interior vertex's blend (a rational quadratic Bézier from d before to d after the vertex,
    weight cos(α/2) in "cdis" mode — a circular arc — else 1), then P[n-1]. Returns (dense
    points, segment of each, arc length s, s where each vertex's blend starts / ends)."""
    n = len(P)
    m = CURVE_POINTS
    t = np.linspace(0.0, 1.0, m)
    if n > 2:
        V = P[1:-1]
        A = V - d[1:-1, None] * U[:-1]
        B = V + d[1:-1, None] * U[1:]
        w = np.cos(alpha[1:-1] / 2) if mode == "cdis" else np.ones(n - 2)
        b0 = (1 - t) ** 2
        b1 = 2 * t * (1 - t)
        b2 = t**2
        num = (
            b0[None, :, None] * A[:, None, :]
            + (w[:, None] * b1[None, :])[:, :, None] * V[:, None, :]
            + b2[None, :, None] * B[:, None, :]
        )
        den = b0[None, :] + w[:, None] * b1[None, :] + b2[None, :]
        curves = (num / den[:, :, None]).reshape(-1, 3)
        seg_c = np.repeat(np.arange(n - 2), m) + (np.tile(t, n - 2) > 0.5)
    else:
        curves = np.zeros((0, 3))
        seg_c = np.zeros(0, dtype=int)
    dense = np.vstack([P[:1], curves, P[-1:]])
    seg = np.concatenate([[0], seg_c, [n - 2]]).astype(np.int64)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
    s_in = np.zeros(n)
    s_out = np.zeros(n)
    if n > 2:
        idx0 = 1 + np.arange(n - 2) * m
        s_in[1:-1] = s[idx0]
        s_out[1:-1] = s[idx0 + m - 1]
    s_in[-1] = s_out[-1] = s[-1]
    return dense, seg, s, s_in, s_out


def junction_speed(u_in: np.ndarray, u_out: np.ndarray, v: np.ndarray, acc: float, deviation: float) -> np.ndarray:
    """Junction speed of a G-code planner (grbl `planner.c` junction deviation), mm/s.

    u_in, u_out: (k, 3) unit directions of the moves into and out of each junction. v: (k,) the
    lower programmed speed of the two moves, mm/s. acc: mm/s². deviation: δ, mm. With cos θ =
    −u_in·u_out (θ the interior angle) and sin(θ/2) = √((1 − cos θ)/2): v_j² = a·δ·sin(θ/2) /
    (1 − sin(θ/2)); straight on (sin(θ/2) → 1) no limit, a reversal (sin(θ/2) = 0) a stop.
    Junctions below MIN_CORNER_SPEED are stops."""
    cos_theta = -np.einsum("ij,ij->i", u_in, u_out)
    sin_half = np.sqrt(np.clip(0.5 * (1.0 - cos_theta), 0.0, 1.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        vj = np.where(
            sin_half < 1.0 - 1e-12, np.sqrt(acc * deviation * sin_half / np.maximum(1.0 - sin_half, 1e-300)), np.inf
        )
    vj = np.minimum(vj, v)
    return np.where(vj < MIN_CORNER_SPEED, 0.0, vj)


def polyline_distance(
    q: np.ndarray, points: np.ndarray, near: np.ndarray, reach: int = 3, geometry: tuple | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Distance from each query point to a polyline, searching segments near a guess.

    q: (k, 3) mm. points: (n, 3) polyline. near: (k,) int guessed segment per query point.
    Checks segments near-reach … near+reach. Returns (distance (k,) mm, segment index (k,)).
    geometry: `polyline_geometry(points)`, when the caller asks about one polyline many times
    (the same numbers as computing it here).
    """
    PT, DT, inv = polyline_geometry(points) if geometry is None else geometry
    nseg = len(inv)
    qx, qy, qz = q[:, 0], q[:, 1], q[:, 2]
    best = np.full(len(q), np.inf)
    best_i = np.asarray(near, dtype=np.int64).copy()
    for off in range(-reach, reach + 1):
        i = np.clip(near + off, 0, nseg - 1)
        # `take` on contiguous columns: P[i, 0] etc. without the 2-D gather's cost
        ax, ay, az = PT[0].take(i), PT[1].take(i), PT[2].take(i)
        dx, dy, dz = DT[0].take(i), DT[1].take(i), DT[2].take(i)
        rx, ry, rz = qx - ax, qy - ay, qz - az
        tt = np.clip((rx * dx + ry * dy + rz * dz) * inv.take(i), 0.0, 1.0)
        ex, ey, ez = rx - tt * dx, ry - tt * dy, rz - tt * dz
        dist2 = ex * ex + ey * ey + ez * ez
        better = dist2 < best
        best = np.where(better, dist2, best)
        best_i = np.where(better, i, best_i)
    return np.sqrt(best), best_i


def polyline_geometry(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What `polyline_distance` needs of a polyline (n, 3): its vertices' and its segment
    vectors' coordinates as contiguous rows (3, n) and (3, n-1), and 1 / squared segment length
    (0 for a zero-length segment)."""
    P = np.asarray(points, dtype=float)
    D = P[1:] - P[:-1]
    LL = (D * D).sum(axis=1)
    inv = np.where(LL > 0, 1.0 / np.where(LL > 0, LL, 1.0), 0.0)
    return np.ascontiguousarray(P.T), np.ascontiguousarray(D.T), inv
