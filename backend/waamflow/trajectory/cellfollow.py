"""Positioner angles that vary ALONG a layer: the `auto` plan's last stages (trajectory.cellplan).

Tried on a layer only after every per-layer choice (one set of angles for the whole layer) failed,
and verified with the same checks (`cellplan._Planner.check` on a per-point angle array):

- `follow-normal`: a layer whose points' own tool axes spread so that no single set of angles
  brings every point within the flat tolerance (a non-planar layer, a toolpath whose tool axis
  turns along the layer): each point takes the gravity angles of its own normal (−tool axis, part
  frame), the Paden–Kahan branch and ±360° shift nearest the previous point's, inside the axis
  limits — every point deposited flat.
- `follow-turn` (2-axis positioners): a layer whose far side the arm cannot reach (or reaches
  colliding) at any fixed angle — a ring wider than the arm reaches around from one side: the tilt
  stays at the layer's gravity angle and the turntable (E2) turns along the layer so each point is
  welded at a fixed azimuth about the turntable axis, facing the robot's base (then 30° and 60°
  either side of it), unwrapped continuously along the layer (coordinated motion). The turn
  between two points is the azimuth their segment spans about the turntable axis (360°/n on a
  ring of n segments). The layer as a whole takes a 360° shift that keeps every point inside the
  axis limits: first one that leaves room for another such lap after it (so the next layer need
  not unwind), then the one whose first point is nearest the previous layer's last angle (the
  least turn on the travel into the layer). Where the limits force the turntable to unwind on the
  travel, the verification follows the part round with the torch (coordinated motion: the TCP
  stays on the part while the axes interpolate), and the layer's note says how far it unwinds.

Points off the arc (the travel into the layer and between its sections) take the angles of the
next arc point (the last one's after the last), so the positioner turns on the travel. The
positioner's speed (URDF) is checked against the programmed weld speed: `axis_speed` gives the
fastest axis rate a layer's angles need (deg/s) and its limit; above it the simulation slows the
path (its `axis_speed` stretches), and the plan's report says so. `candidates` yields a layer's
along-layer choices for the plan, `row` its report row. Units: mm, s, deg.
"""

from __future__ import annotations

import math

import numpy as np

from .cell import _sp1

FOLLOW_AZIMUTHS_DEG = (0.0, 30.0, -30.0, 60.0, -60.0)  # follow-turn: the welding azimuth off the robot's side
FOLLOW_STAGES = ("follow-normal", "follow-turn")  # the along-layer stages, tried last by the plan
SPREAD_EPS_DEG = 0.01  # a layer whose point normals spread less is planned on its mean normal alone


def arc_points(pl, a: int, b: int) -> np.ndarray:
    """Indices of the points a..b that start or end an arc-ON segment (sorted)."""
    segs = np.arange(a, b)
    on = segs[pl.arc[a:b]]
    return np.unique(np.concatenate([on, on + 1])) if len(on) else np.zeros(0, int)


def point_normals(pl, idx: np.ndarray) -> np.ndarray:
    """Part-frame layer normals (−tool axis, unit) at the points idx."""
    n = -pl.A[idx]
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def spread_deg(normals: np.ndarray) -> float:
    """Largest angle (deg) between a point normal and the layer's mean normal."""
    if len(normals) == 0:
        return 0.0
    m = normals.mean(axis=0)
    m /= max(float(np.linalg.norm(m)), 1e-12)
    return float(np.degrees(np.arccos(np.clip(normals @ m, -1.0, 1.0))).max())


def point_tilts(pl, E: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Tilt (deg) from world vertical of each normal at its own angles (E: (m,) or (k, m))."""
    E = np.asarray(E, float)
    if E.ndim == 1:
        up = normals @ pl.cell.work_pose(E)[0].T
    else:
        up = np.array([pl.cell.work_pose(e)[0] @ v for e, v in zip(E, normals)])
    return np.degrees(np.arccos(np.clip(up[:, 2] if len(up) else np.zeros(0), -1.0, 1.0)))


def _fill(a: int, b: int, idx: np.ndarray, E_arc: np.ndarray) -> np.ndarray:
    """Angles at points a..b: the arc points' own, every other point the next arc point's (the
    last arc point's after it)."""
    out = np.empty((b - a + 1, E_arc.shape[1]))
    nxt = np.searchsorted(idx, np.arange(a, b + 1))
    out[:] = E_arc[np.minimum(nxt, len(idx) - 1)]
    return out


def follow_normal(pl, a: int, b: int, prev: np.ndarray) -> np.ndarray | None:
    """Per point a..b the gravity angles of its own normal, continuous along the layer (None: a
    point has none inside the axis limits, or they leave it off flat)."""
    idx = arc_points(pl, a, b)
    if len(idx) == 0:
        return None
    normals = point_normals(pl, idx)
    E_arc = np.empty((len(idx), pl.m))
    cur = np.asarray(prev, float)
    for k, n in enumerate(normals):
        g = pl.gravity(n, cur)
        if not g:
            return None
        cur = E_arc[k] = g[0]
    if point_tilts(pl, E_arc, normals).max() > pl.lim.flat_tol_deg + 1e-6:
        return None
    return _fill(a, b, idx, E_arc)


def turntable_axis(pl, e1: float) -> tuple[np.ndarray, np.ndarray]:
    """The turntable axis in the part frame (unit direction, a point on it, mm): the part turns
    about it as E2 moves (found from two poses at tilt e1, so any URDF's sign convention holds)."""
    Ra, ta = pl.cell.work_pose(np.array([e1, 0.0]))
    Rb, tb = pl.cell.work_pose(np.array([e1, 90.0]))
    Rr = Ra.T @ Rb  # Rot(d, 90°) in the part frame
    d = np.array([Rr[2, 1] - Rr[1, 2], Rr[0, 2] - Rr[2, 0], Rr[1, 0] - Rr[0, 1]])
    d /= max(float(np.linalg.norm(d)), 1e-12)
    p = np.linalg.lstsq(Ra - Rb, tb - ta, rcond=None)[0]  # Ra p + ta = Rb p + tb on the axis
    return d, p


def follow_turn(pl, a: int, b: int, prev: np.ndarray, e1: float, azimuth_deg: float) -> np.ndarray | None:
    """Per point a..b: tilt e1, the turntable turned so the point lies at `azimuth_deg` off the
    direction from the turntable axis to the robot base (None: not a 2-axis positioner, the layer
    does not fit the axis limits, or a point is left off flat)."""
    if pl.m != 2:
        return None
    idx = arc_points(pl, a, b)
    if len(idx) == 0:
        return None
    d, p0 = turntable_axis(pl, e1)
    R0, t0 = pl.cell.work_pose(np.array([e1, 0.0]))
    u = R0 @ d  # the turntable axis in the world (any E2)
    v = pl.base_t - (R0 @ p0 + t0)
    v -= u * (u @ v)
    if np.linalg.norm(v) < 1e-6:  # the robot on the turntable axis: no side to face
        return None
    th = math.radians(azimuth_deg)  # v turned about u by the azimuth (Rodrigues)
    v = v * math.cos(th) + np.cross(u, v) * math.sin(th) + u * (u @ v) * (1 - math.cos(th))
    vp = R0.T @ v  # in the part frame at E2 = 0
    r = pl.P[idx] - p0
    r -= np.outer(r @ d, d)
    e2 = np.empty(len(idx))
    last = float(prev[1])
    for k, rk in enumerate(r):
        if np.linalg.norm(rk) < 1e-6:  # on the axis: any E2, kept
            e2[k] = last
            continue
        x = math.degrees(_sp1(d, rk, vp))
        x += 360.0 * round((last - x) / 360.0)  # continuous along the layer
        e2[k] = last = x
    lo, hi = pl.lo[1], pl.hi[1]
    shifts = [
        360.0 * k for k in range(-4, 5) if e2.min() + 360.0 * k >= lo - 1e-7 and e2.max() + 360.0 * k <= hi + 1e-7
    ]
    if not shifts or not (pl.lo[0] - 1e-7 <= e1 <= pl.hi[0] + 1e-7):
        return None
    turn = e2[-1] - e2[0]

    def key(s: float) -> tuple[bool, float]:  # room for another such lap first, then the least motion
        return (not (lo - 1e-7 <= e2.min() + s + turn and e2.max() + s + turn <= hi + 1e-7), abs(e2[0] + s - prev[1]))

    e2 += min(shifts, key=key)
    E_arc = np.column_stack([np.full(len(idx), e1), e2])
    if point_tilts(pl, E_arc, point_normals(pl, idx)).max() > pl.lim.flat_tol_deg + 1e-6:
        return None
    return _fill(a, b, idx, E_arc)


def axis_speed(pl, a: int, b: int, E: np.ndarray) -> tuple[float, float]:
    """The fastest positioner axis rate (deg/s) the angles E (points a..b) need along the layer's
    arc-ON segments at their programmed speed, and that axis's URDF speed (deg/s)."""
    from .cell import positioner_kin

    w = positioner_kin(pl.cell.positioner.urdf).speed_deg_s
    segs = np.arange(a, b)
    on = pl.arc[a:b] & np.isfinite(pl.moves.speed[a:b]) & (np.asarray(pl.moves.speed[a:b]) > 0)
    if not on.any():
        return 0.0, float(w.min())
    L = np.linalg.norm(pl.P[segs + 1] - pl.P[segs], axis=1)[on]
    dE = np.abs(np.diff(E, axis=0))[on]
    dt = np.maximum(L / np.asarray(pl.moves.speed[a:b], float)[on], 1e-12)
    rate = dE / dt[:, None]
    j = np.unravel_index(int(np.argmax(rate)), rate.shape)
    return float(rate[j]), float(w[j[1]])


def candidates(pl, a: int, b: int, nrm, prev, stages, spread: float, azimuths):
    """Along-layer candidates (stage, per-point angles (b - a + 1, axes), 0, azimuth, note) of
    the given stages (this module); follow-normal only on a layer whose normals spread."""
    if "follow-normal" in stages and "follow-normal" in FOLLOW_STAGES and spread > SPREAD_EPS_DEG:
        E = follow_normal(pl, a, b, prev)
        if E is not None:
            yield (
                "follow-normal",
                E,
                0.0,
                0.0,
                f"each point at its own normal's gravity angles (the layer's normals spread {spread:.1f}°)",
            )
    if "follow-turn" in stages and "follow-turn" in FOLLOW_STAGES and pl.m == 2:
        g = pl.gravity(nrm, prev)
        e1 = float((g[0] if g else pl.best_tilt(nrm, prev)[0])[0])
        for az in azimuths:
            E = follow_turn(pl, a, b, prev, e1, az)
            if E is None:
                continue
            unwind = abs(float(E[0, 1] - prev[1]))
            yield (
                "follow-turn",
                E,
                0.0,
                az,
                f"turntable following the layer, each point welded {az:+g}° off the robot's side"
                + (
                    f" (it turns {unwind:.0f}° on the travel in, carrying the torch round the part: "
                    "weld the layers in alternating directions so each lap turns the table back)"
                    if unwind >= 180.0
                    else ""
                ),
            )


def row(pl, L: int, a: int, b: int, stage: str, e: np.ndarray, tried: int, why: str) -> dict:
    """The plan report's row of a layer (points a..b) planned with per-point angles e: the angles
    at its first arc point, their span, the worst point's tilt off flat and the positioner axis
    rate the programmed speed needs against its limit (over it: said in `why`)."""
    idx = arc_points(pl, a, b)
    tilt = point_tilts(pl, e[idx - a], point_normals(pl, idx))
    rate, limit = axis_speed(pl, a, b, e)
    if rate > limit + 1e-9:
        why += (
            f"; at the programmed speed the positioner would turn {rate:.1f}°/s, above its {limit:.0f}°/s: "
            "the path slows there"
        )
    return {
        "layer": int(L),
        "stage": stage,
        "e_deg": [round(float(v), 4) for v in e[idx[0] - a]],
        "e_span_deg": [round(float(v), 4) for v in e.max(axis=0) - e.min(axis=0)],
        "lean_deg": 0.0,
        "lean_dir_deg": 0.0,
        "tilt_deg": round(float(tilt.max()), 3),
        "axis_speed_deg_s": round(rate, 4),
        "axis_speed_limit_deg_s": round(limit, 4),
        "tried": tried,
        "why": why,
    }
