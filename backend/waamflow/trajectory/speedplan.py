"""Path speed profile along arc length: junction speeds + ruckig as one DOF (the controller's interpolator).

The blended path is cut into spans (straight parts at their programmed speed, blend curves at
their corner cap). Junction speeds are planned first — caps from corners, 0 at exact stops —
then a backward and a forward pass make every span able to reach its exit speed, using the exact
jerk-limited distance needed to change speed between two zero-acceleration states:

    D(v0, v1) = (v0 + v1)/2 · (Δ/a + a/j)     if Δ = |v1 − v0| ≥ a²/j   (acceleration saturates)
    D(v0, v1) = (v0 + v1) · √(Δ/j)            otherwise

(the distance ruckig's velocity interface covers for the same change). Then one ruckig
position-interface call per span, (s_i, v_i, 0) → (s_i+1, v_i+1, 0), with the span's speed as
`max_velocity` (robot-modelling-notes.md, "Ruckig"). Profiles are kept as piecewise-cubic
phases and evaluated vectorised.

Units: mm, s, mm/s, mm/s², mm/s³.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .blend import BlendedPath


@dataclass(frozen=True, eq=False)
class Spans:
    """Spans of the blended path in order. s0/s1/vmax: (K,) mm, mm, mm/s. v: (K+1,) junction
    speeds, mm/s. stop_after: (K,) bool, an exact stop follows span i (block boundary).
    vertex_after: (K,) int programmed vertex at the span's end."""

    s0: np.ndarray
    s1: np.ndarray
    vmax: np.ndarray
    v: np.ndarray
    stop_after: np.ndarray
    vertex_after: np.ndarray


@dataclass(frozen=True, eq=False)
class SpanProfiles:
    """Ruckig phases of all spans. duration: (K,) s. t/j: (K, 7) phase durations s and jerks.
    p/v/a: (K, 8) state at the phase boundaries (p relative to the span start, mm)."""

    duration: np.ndarray
    t: np.ndarray
    j: np.ndarray
    p: np.ndarray
    v: np.ndarray
    a: np.ndarray


def change_distance(v0: float, v1: float, a: float, j: float) -> float:
    """Jerk-limited distance (mm) to change speed from v0 to v1 (mm/s) between zero accelerations."""
    dv = abs(v1 - v0)
    if dv >= a * a / j:
        return 0.5 * (v0 + v1) * (dv / a + a / j)
    return (v0 + v1) * math.sqrt(dv / j)


def reachable_speed(v1: float, length: float, a: float, j: float) -> float:
    """Largest speed v ≥ v1 (mm/s) that can change to v1 within `length` mm (inverse of D)."""
    if length <= 0:
        return v1
    k = a * a / j
    # saturated branch: v² + v·k + (−v1² + v1·k − 2aL) = 0
    c = -v1 * v1 + v1 * k - 2 * a * length
    v = 0.5 * (-k + math.sqrt(k * k - 4 * c))
    if v - v1 >= k:
        return v
    # unsaturated: (2·v1 + Δ)·√(Δ/j) = L, increasing in Δ ∈ [0, k]: bisection
    lo, hi = 0.0, k
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if (2 * v1 + mid) * math.sqrt(mid / j) > length:
            hi = mid
        else:
            lo = mid
    return v1 + lo


def plan_spans(path: BlendedPath, speed: np.ndarray, stop: np.ndarray, a: float, j: float) -> Spans:
    """Cut the blended path into spans and plan junction speeds (backward then forward pass).

    speed: (n-1,) programmed speed per segment (already capped), mm/s. stop: (n,) bool.
    """
    n = len(path.d)
    nseg = n - 1
    # interleave straight k (k = 0..n-2) and curve k+1 (k < n-2)
    st_s0 = path.s_out[:-1]
    st_s1 = path.s_in[1:]
    order = np.empty(2 * nseg - 1, dtype=np.int64)
    order[0::2] = np.arange(nseg)
    order[1::2] = nseg + np.arange(nseg - 1)
    s0 = np.concatenate([st_s0, path.s_in[1:-1]])[order]
    s1 = np.concatenate([st_s1, path.s_out[1:-1]])[order]
    vmax = np.concatenate([speed, path.cap[1:-1]])[order]
    lcap = np.concatenate([path.cap[:-1], path.cap[1:-1]])[order]
    rcap = np.concatenate([path.cap[1:], path.cap[1:-1]])[order]
    rvert = np.concatenate([np.arange(1, n), np.arange(1, n - 1)])[order]
    keep = (s1 - s0) > 1e-9
    s0, s1, vmax, lcap, rcap, rvert = s0[keep], s1[keep], vmax[keep], lcap[keep], rcap[keep], rvert[keep]
    K = len(s0)
    jc = np.zeros(K + 1)
    if K > 1:
        jc[1:-1] = np.minimum(rcap[:-1], lcap[1:])
    stop_after = np.asarray(stop, dtype=bool)[rvert]
    jc[1:][stop_after] = 0.0
    jc = np.minimum(jc, np.concatenate([[np.inf], vmax])).clip(min=0.0)
    jc[:-1] = np.minimum(jc[:-1], vmax)
    L = s1 - s0
    v = jc.tolist()
    Ll = (L * (1 - 1e-4)).tolist()  # keep off the feasibility edge, where ruckig's solution degenerates
    for i in range(K - 1, -1, -1):
        r = reachable_speed(v[i + 1], Ll[i], a, j)
        if r < v[i]:
            v[i] = r
    for i in range(K):
        r = reachable_speed(v[i], Ll[i], a, j)
        if r < v[i + 1]:
            v[i + 1] = r
    return Spans(s0, s1, vmax, np.asarray(v), stop_after, rvert)


def profile_spans(spans: Spans, a: float, j: float) -> SpanProfiles:
    """One ruckig position-interface call per span: (0, v_i, 0) → (L_i, v_i+1, 0)."""
    from ruckig import InputParameter, Result, Ruckig, Trajectory  # lazy: keeps start-up light
    K = len(spans.s0)
    otg = Ruckig(1)
    inp = InputParameter(1)
    traj = Trajectory(1)
    inp.max_acceleration = [a]
    inp.max_jerk = [j]
    inp.current_acceleration = [0.0]
    inp.target_acceleration = [0.0]
    dur = np.zeros(K)
    T = np.zeros((K, 7))
    J = np.zeros((K, 7))
    Pp = np.zeros((K, 8))
    Vv = np.zeros((K, 8))
    Aa = np.zeros((K, 8))
    L = (spans.s1 - spans.s0).tolist()
    vj = spans.v.tolist()
    vm = spans.vmax.tolist()
    for i in range(K):
        v0, v1 = vj[i], vj[i + 1]
        vmax = max(vm[i], v0, v1, 1e-6)
        inp.current_position = [0.0]
        inp.current_velocity = [v0]
        inp.target_position = [L[i]]
        inp.target_velocity = [v1]
        inp.max_velocity = [vmax]
        res = otg.calculate(inp, traj)
        shrink = 1.0
        while (res not in (Result.Working, Result.Finished) or min(traj.profiles[0][0].v) < -1e-9) and shrink > 1e-3:
            # numerically at the edge of feasibility: arrive a little slower
            shrink *= 0.9
            inp.target_velocity = [v1 * shrink]
            res = otg.calculate(inp, traj)
        if res not in (Result.Working, Result.Finished):
            raise RuntimeError(f"ruckig failed on span {i} (L={L[i]:.4f} mm, v {v0:.3f}→{v1:.3f} mm/s): {res}")
        prof = traj.profiles[0][0]
        dur[i] = traj.duration
        T[i] = prof.t
        J[i] = prof.j
        Pp[i] = prof.p
        Vv[i] = prof.v
        Aa[i] = prof.a
    return SpanProfiles(dur, T, J, Pp, Vv, Aa)


def evaluate(prof: SpanProfiles, span_index: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position (relative to the span start, mm) and speed (mm/s) at local times tau (s) in spans."""
    t = prof.t[span_index]
    starts = np.concatenate([np.zeros((len(t), 1)), np.cumsum(t, axis=1)], axis=1)  # (k, 8)
    ph = (tau[:, None] >= starts[:, 1:]).sum(axis=1)  # phase index 0..7
    ph = np.minimum(ph, 6)
    rows = np.arange(len(tau))
    dt = np.clip(tau - starts[rows, ph], 0.0, None)
    dt = np.minimum(dt, t[rows, ph])
    jj = prof.j[span_index, ph]
    p0 = prof.p[span_index, ph]
    v0 = prof.v[span_index, ph]
    a0 = prof.a[span_index, ph]
    s = p0 + v0 * dt + a0 * dt * dt / 2 + jj * dt ** 3 / 6
    v = v0 + a0 * dt + jj * dt * dt / 2
    end = tau >= starts[rows, 7]
    s = np.where(end, prof.p[span_index, 7], s)
    v = np.where(end, prof.v[span_index, 7], v)
    return s, v
