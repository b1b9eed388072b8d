"""Path speed profile along arc length: junction speeds + a jerk-limited one-DOF profile per span (the controller's interpolator).

The blended path is cut into spans (straight parts at their programmed speed, blend curves at
their corner cap). Junction speeds are planned first — caps from corners, 0 at exact stops —
then a backward and a forward pass make every span able to reach its exit speed, using the exact
jerk-limited distance needed to change speed between two zero-acceleration states:

    D(v0, v1) = (v0 + v1)/2 · (Δ/a + a/j)     if Δ = |v1 − v0| ≥ a²/j   (acceleration saturates)
    D(v0, v1) = (v0 + v1) · √(Δ/j)            otherwise

(the distance ruckig's velocity interface covers for the same change). Speeding up and slowing
down have their own limits (a, j) and (a_dec, j_dec): the KRC2 of the study ramps up and down
differently (robot-study.md, identified T/L_init_accel vs T/L_final_decel). Then every span gets
its time-optimal profile (s_i, v_i, 0) → (s_i+1, v_i+1, 0) in closed form, vectorised: the
seven-phase layout of ruckig's one-DOF position profiles (robot-modelling-notes.md, "Ruckig"),
which the community ruckig cannot produce with different speed-up and slow-down limits.
Profiles are kept as piecewise-cubic phases and evaluated vectorised.

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
    acc: np.ndarray | None = None
    jerk: np.ndarray | None = None
    dec: np.ndarray | None = None
    dec_jerk: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class SpanProfiles:
    """Jerk-limited phases of all spans. duration: (K,) s. t/j: (K, 7) phase durations s and jerks.
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


def plan_spans(
    path: BlendedPath,
    speed: np.ndarray,
    stop: np.ndarray,
    a: float,
    j: float,
    a_dec: float | None = None,
    j_dec: float | None = None,
    limits=None,
    lookahead: int = 0,
) -> Spans:
    """Cut the blended path into spans and plan junction speeds (backward then forward pass).

    speed: (n-1,) programmed speed per segment (already capped), mm/s. stop: (n,) bool.
    a, j: speed-up limits; a_dec, j_dec: slow-down limits (None = the speed-up ones). The
    backward pass (can every span slow down to its exit speed?) uses the slow-down limits, the
    forward pass (can it speed up to it?) the speed-up ones. limits: optional callable
    (programmed speed per span (K,) mm/s) → (acc, jerk, dec, dec_jerk) arrays (K,), overriding
    the constants (limits identified per speed, `RobotProfile.ramp_limits`); a blend curve's
    programmed speed is the lower of its two segments'.
    lookahead: N > 0 = a G-code planner's block buffer: every span's entry speed must allow a
    stop at the end of the N spans from it (the planner sees N blocks and plans the last to
    stop), with the trapezoid distance v² = v_end² + 2·a_dec·L (planners with unlimited jerk).
    """
    a_dec = a if a_dec is None else a_dec
    j_dec = j if j_dec is None else j_dec
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
    vprog = np.concatenate([speed, np.minimum(speed[:-1], speed[1:])])[order]
    keep = (s1 - s0) > 1e-9
    s0, s1, vmax, lcap, rcap, rvert = s0[keep], s1[keep], vmax[keep], lcap[keep], rcap[keep], rvert[keep]
    vprog = vprog[keep]
    K = len(s0)
    jc = np.zeros(K + 1)
    if K > 1:
        jc[1:-1] = np.minimum(rcap[:-1], lcap[1:])
    stop_after = np.asarray(stop, dtype=bool)[rvert]
    jc[1:][stop_after] = 0.0
    jc = np.minimum(jc, np.concatenate([[np.inf], vmax])).clip(min=0.0)
    jc[:-1] = np.minimum(jc[:-1], vmax)
    if limits is not None:
        A, J, AD, JD = (np.asarray(x, dtype=float) for x in limits(vprog))
    else:
        A, J, AD, JD = (np.full(K, float(x)) for x in (a, j, a_dec, j_dec))
    # a junction that constrains nothing (straight on at the same speed and limits, no stop) is
    # no junction: merge its spans, so a pass cut into short pieces ramps as one motion (every
    # span profile starts and ends at zero acceleration)
    if K > 1:
        free = (
            ~stop_after[:-1]
            & (jc[1:-1] >= vmax[:-1] * (1 - 1e-12))
            & (vmax[1:] == vmax[:-1])
            & (A[1:] == A[:-1])
            & (J[1:] == J[:-1])
            & (AD[1:] == AD[:-1])
            & (JD[1:] == JD[:-1])
        )
        if free.any():
            first = np.concatenate([[True], ~free])
            last = np.concatenate([~free, [True]])
            s0, s1 = s0[first], s1[last]
            vmax, rvert, stop_after = vmax[first], rvert[last], stop_after[last]
            A, J, AD, JD = A[first], J[first], AD[first], JD[first]
            jc = np.concatenate([jc[:1], jc[1:][last]])
            K = len(s0)
    L = s1 - s0
    v = jc.tolist()
    Ll = (L * (1 - 1e-4)).tolist()  # keep off the feasibility edge
    Al, Jl, ADl, JDl = A.tolist(), J.tolist(), AD.tolist(), JD.tolist()
    # reachable_speed(v1, ...) ≥ v1: a junction no faster than the one after it (before it, in
    # the forward pass) is not lowered, and is skipped without the call (most junctions of a pass
    # at one speed; the same speeds as calling it everywhere)
    for i in range(K - 1, -1, -1):
        if v[i + 1] < v[i]:
            r = reachable_speed(v[i + 1], Ll[i], ADl[i], JDl[i])
            if r < v[i]:
                v[i] = r
    _forward(v, Ll, Al, Jl)
    if 0 < lookahead < K:
        v = _buffer_limit(np.asarray(v), np.asarray(Ll), AD, int(lookahead)).tolist()
        _forward(v, Ll, Al, Jl)
    return Spans(s0, s1, vmax, np.asarray(v), stop_after, rvert, A, J, AD, JD)


def _forward(v: list[float], L: list[float], A: list[float], J: list[float]) -> None:
    """`plan_spans`' forward pass in place: each junction speed lowered to what the span before
    it can speed up to from the junction before (skipping those no faster than that one)."""
    for i in range(len(L)):
        if v[i] < v[i + 1]:
            r = reachable_speed(v[i], L[i], A[i], J[i])
            if r < v[i + 1]:
                v[i + 1] = r


def _buffer_limit(v: np.ndarray, L: np.ndarray, dec: np.ndarray, n: int) -> np.ndarray:
    """Junction speeds (K+1,) lowered so that from every junction i a stop fits within the next n
    spans: R_0 = 0, R_m(i) = min(v_i, √(R_{m−1}(i+1)² + 2·dec_i·L_i)); v_i ≤ R_n(i)."""
    r = np.zeros(len(v))
    for _ in range(n):
        r = np.minimum(v, np.concatenate([np.sqrt(r[1:] ** 2 + 2.0 * dec * L), [0.0]]))
    return np.minimum(v, r)


def _ramp(dv: np.ndarray, a, j) -> tuple[np.ndarray, np.ndarray]:
    """Jerk-limited speed change by dv ≥ 0 between zero accelerations: (jerk phase time, constant
    acceleration phase time), s — the ramp is jerk, constant acceleration, jerk (each jerk phase
    t1, so its speed curve is point-symmetric and it covers (v_start + v_end)/2 · (2·t1 + t2))."""
    sat = dv >= a * a / j
    t1 = np.where(sat, a / j, np.sqrt(np.maximum(dv, 0.0) / j))
    t2 = np.where(sat, dv / a - a / j, 0.0)
    return t1, t2


def _span_limit(given: float | None, own: np.ndarray | None, k: int, what: str) -> np.ndarray:
    """A limit per span for `profile_spans`: the given constant for all k spans, else the spans'
    own (`plan_spans` sets them); neither is a ValueError naming the limit."""
    if given is not None:
        return np.full(k, float(given))
    if own is None:
        raise ValueError(
            f"profile_spans: no {what}: pass it, or plan the spans with plan_spans (which sets each span's limits)"
        )
    return own


def profile_spans(
    spans: Spans, a: float | None = None, j: float | None = None, a_dec: float | None = None, j_dec: float | None = None
) -> SpanProfiles:
    """Time-optimal jerk-limited profile of every span, (0, v_i, 0) → (L_i, v_i+1, 0), vectorised.

    Each span speeds up from v_i to a peak v_p with the speed-up limits (a, j), cruises at v_p and
    slows down to v_i+1 with the slow-down limits (a_dec, j_dec): seven phases (jerk, constant
    acceleration, jerk, cruise, jerk, constant deceleration, jerk), the phase layout of ruckig's
    one-DOF position profiles, which cannot take different limits for speeding up and slowing
    down. v_p = the span's max speed when the span is long enough, else the largest speed whose
    two ramps fit the span (bisection). The junction speeds of `plan_spans` make every span
    feasible (v_p ≥ max(v_i, v_i+1)). The limits are the spans' own (`Spans.acc` …) unless given."""
    K = len(spans.s0)
    # per span: speed-up acceleration and jerk, slow-down deceleration and jerk
    acc_up = _span_limit(a, spans.acc, K, "acceleration (a / Spans.acc)")
    jerk_up = _span_limit(j, spans.jerk, K, "jerk (j / Spans.jerk)")
    acc_down = _span_limit(a_dec, spans.dec if spans.dec is not None else acc_up, K, "deceleration")
    jerk_down = _span_limit(j_dec, spans.dec_jerk if spans.dec_jerk is not None else jerk_up, K, "deceleration jerk")
    L = spans.s1 - spans.s0
    v0, v1 = spans.v[:-1], spans.v[1:]
    lo = np.maximum(v0, v1)
    hi = np.maximum(spans.vmax, lo)

    def dist(vp):
        tu1, tu2 = _ramp(vp - v0, acc_up, jerk_up)
        td1, td2 = _ramp(vp - v1, acc_down, jerk_down)
        return 0.5 * (v0 + vp) * (2 * tu1 + tu2) + 0.5 * (vp + v1) * (2 * td1 + td2)

    vp = hi.copy()
    short = dist(hi) > L
    if short.any():
        a_lo, a_hi = lo[short], hi[short]
        Ls = L[short]
        v0s, v1s = v0[short], v1[short]
        As, Js, ADs, JDs = acc_up[short], jerk_up[short], acc_down[short], jerk_down[short]
        for _ in range(60):
            mid = 0.5 * (a_lo + a_hi)
            tu1, tu2 = _ramp(mid - v0s, As, Js)
            td1, td2 = _ramp(mid - v1s, ADs, JDs)
            d = 0.5 * (v0s + mid) * (2 * tu1 + tu2) + 0.5 * (mid + v1s) * (2 * td1 + td2)
            over = d > Ls
            a_hi = np.where(over, mid, a_hi)
            a_lo = np.where(over, a_lo, mid)
        vp[short] = a_lo
    tu1, tu2 = _ramp(vp - v0, acc_up, jerk_up)
    td1, td2 = _ramp(vp - v1, acc_down, jerk_down)
    cruise = np.where(vp > 1e-12, np.maximum(L - dist(vp), 0.0) / np.maximum(vp, 1e-12), 0.0)
    T = np.column_stack([tu1, tu2, tu1, cruise, td1, td2, td1])
    ju = np.where(tu1 > 0, jerk_up, 0.0)
    jd = np.where(td1 > 0, jerk_down, 0.0)
    z = np.zeros(K)
    J = np.column_stack([ju, z, -ju, z, -jd, z, jd])
    Pp = np.zeros((K, 8))
    Vv = np.zeros((K, 8))
    Aa = np.zeros((K, 8))
    Vv[:, 0] = v0
    for k in range(7):
        dt, jj = T[:, k], J[:, k]
        p, v, acc = Pp[:, k], Vv[:, k], Aa[:, k]
        Pp[:, k + 1] = p + v * dt + acc * dt * dt / 2 + jj * dt**3 / 6
        Vv[:, k + 1] = v + acc * dt + jj * dt * dt / 2
        Aa[:, k + 1] = acc + jj * dt
    Aa[:, 7] = 0.0
    Vv[:, 7] = v1
    return SpanProfiles(T.sum(axis=1), T, J, Pp, Vv, Aa)


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
    s = p0 + v0 * dt + a0 * dt * dt / 2 + jj * dt**3 / 6
    v = v0 + a0 * dt + jj * dt * dt / 2
    end = tau >= starts[rows, 7]
    s = np.where(end, prof.p[span_index, 7], s)
    v = np.where(end, prof.v[span_index, 7], v)
    return s, v
