"""The fine-grid samples of a controller simulation (`simulate.simulate`, steps 4-5 of its model).

Blocks (runs of spans between exact stops) on one time line; samples every h = cycle / FINE
inside each block, filtered by the controller's moving average; the programmed segment and the
deviation of each sample; corner errors; the arc's ON intervals.

Every figure here is computed exactly as the single-pass version did (the same floating-point
operations on the same numbers, in the same order): the speed comes from doing less work per
sample, not other work. Where an array op was split (chunks of CHUNK samples, squared distances
compared before their square root), the result is bit-identical:
- elementwise ops and minimum.at are per sample, so chunking changes nothing;
- ‖v‖ of a 3-vector is √((x²+y²)+z²) in `np.linalg.norm(axis=1)` and in `row_norms`;
- √ is monotonic and correctly rounded, so min √a = √(min a);
- a row slice holds the numbers a gather of the same rows does (the moving average), and
  np.maximum then np.minimum is np.clip (the arc clock).
tests/trajectory/test_fine.py checks each against the plain form; test_sim_reference.py the
figures of four shipped recipes against the ones recorded before.
Units: mm, s, mm/s.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ..core.errors import PlanningError
from .blend import BlendedPath, polyline_distance, polyline_geometry
from .speedplan import SpanProfiles, Spans

FINE = 3  # fine samples per interpolation cycle
MAX_FINE_SAMPLES = 3_000_000  # above this (≈ 2.8 h at 12 ms), sample at the cycle itself to bound memory
MAX_SAMPLES = 30_000_000  # ≈ 100 h at 12 ms: beyond, refuse rather than exhaust memory
CHUNK = 1 << 15  # samples per pass of the per-sample geometry: its arrays stay in the CPU cache


@dataclass(frozen=True, eq=False)
class Timeline:
    """Blocks of spans between exact stops on the simulation's time line (s).

    block_start / block_end: (nb,) first / last span of each block. raw_dur: motion time of each
    block before the filter. start_vertex: programmed vertex each block starts at. h: fine step.
    nf: filter window in fine samples (fractional). block_len: block time with the filter's
    tail. gap_before: standstill before each block. T0: block start times. t_end: end of motion.
    span_t: start time of each span within its block."""

    block_start: np.ndarray
    block_end: np.ndarray
    raw_dur: np.ndarray
    start_vertex: np.ndarray
    h: float
    nf: float
    block_len: np.ndarray
    gap_before: np.ndarray
    T0: np.ndarray
    t_end: float
    span_t: np.ndarray

    @property
    def nb(self) -> int:
        return len(self.block_end)


def timeline(
    spans: Spans,
    prof: SpanProfiles,
    standstill: np.ndarray,
    switches: np.ndarray,
    dt: float,
    smoothing_s: float,
    arc_switch_dwell_s: float,
) -> Timeline:
    """Blocks and their start times. standstill: (n,) dwell at each vertex; switches: (n,) 1 where
    the arc switches (or pauses) there, each followed by one arc-switch dwell. A program beyond
    MAX_SAMPLES cycles is a PlanningError."""
    block_end = np.flatnonzero(spans.stop_after)  # last span of each block
    block_start = np.concatenate([[0], block_end[:-1] + 1])
    nb = len(block_end)
    raw_dur = np.add.reduceat(prof.duration, block_start)
    start_vertex = np.concatenate([[0], spans.vertex_after[block_end[:-1]]])
    h = dt / FINE
    motion_s = raw_dur.sum() + smoothing_s * nb
    if motion_s / h > MAX_FINE_SAMPLES:
        h = dt
    if motion_s / dt > MAX_SAMPLES:
        raise PlanningError(
            f"program too long to simulate: {motion_s / 3600:.0f} h of motion at "
            f"{dt * 1000:g} ms (limit {MAX_SAMPLES * dt / 3600:.0f} h)"
        )
    nf = max(1.0, smoothing_s / h)  # filter window in fine samples (fractional)
    tf = (nf - 1.0) * h  # extra time the filter adds to a block
    gap_before = standstill[start_vertex] + switches[start_vertex] * arc_switch_dwell_s
    block_len = raw_dur + tf
    T0 = np.zeros(nb)
    t_cursor = 0.0
    for b in range(nb):
        t_cursor += gap_before[b]
        T0[b] = t_cursor
        t_cursor += block_len[b]
    span_t = prof.duration.cumsum() - prof.duration
    span_t -= np.repeat(span_t[block_start], block_end - block_start + 1)
    return Timeline(block_start, block_end, raw_dur, start_vertex, h, nf, block_len, gap_before, T0, t_cursor, span_t)


def _phase_starts(prof: SpanProfiles) -> np.ndarray:
    """(K, 8) start time of each of a span's 7 phases and its end (`speedplan.evaluate`'s, once per span)."""
    return np.concatenate([np.zeros((len(prof.t), 1)), np.cumsum(prof.t, axis=1)], axis=1)


def _positions(
    prof: SpanProfiles, starts: np.ndarray, si: np.ndarray, tau: np.ndarray, flat: dict | None = None
) -> np.ndarray:
    """Position along each span at local times tau: `speedplan.evaluate`'s first value, with the
    phase starts computed once per span (`_phase_starts`) instead of once per sample. flat:
    `_flat_profiles(prof, starts)`, the same numbers gathered by `take` on flat copies (a 2-D
    gather [si, ph] costs twice as much)."""
    f = _flat_profiles(prof, starts) if flat is None else flat
    st = starts[si]
    ph = np.minimum((tau[:, None] >= st[:, 1:]).sum(axis=1), 6)
    i7, i8 = si * 7 + ph, si * 8 + ph  # flat indices of [si, ph] in the (K, 7) and (K, 8) arrays
    dt = np.clip(tau - f["starts"].take(i8), 0.0, None)
    dt = np.minimum(dt, f["t"].take(i7))
    s = f["p"].take(i8) + f["v"].take(i8) * dt + f["a"].take(i8) * dt * dt / 2 + f["j"].take(i7) * dt**3 / 6
    return np.where(tau >= st[:, 7], f["p"].take(si * 8 + 7), s)


def _flat_profiles(prof: SpanProfiles, starts: np.ndarray) -> dict[str, np.ndarray]:
    """The (K, 7) and (K, 8) arrays `_positions` gathers from, flattened (contiguous copies)."""
    return {
        "starts": np.ascontiguousarray(starts).ravel(),
        "t": np.ascontiguousarray(prof.t).ravel(),
        "j": np.ascontiguousarray(prof.j).ravel(),
        "p": np.ascontiguousarray(prof.p).ravel(),
        "v": np.ascontiguousarray(prof.v).ravel(),
        "a": np.ascontiguousarray(prof.a).ravel(),
    }


def moving_average(x: np.ndarray, w: float) -> np.ndarray:
    """Causal moving average of (k, c) samples over a window of w ≥ 1 samples (w may be
    fractional: the cumulative sum is interpolated), padded with x[0] before the start."""
    if w <= 1.0:
        return x
    npad = int(np.ceil(w))
    pad = np.vstack([np.repeat(x[:1], npad, axis=0), x])
    c = np.vstack([np.zeros((1, x.shape[1])), np.cumsum(pad, axis=0)])  # c[i] = sum pad[:i]
    k = len(x)
    hi = np.arange(k) + npad + 1  # sum up to and including sample k
    lo = hi - w
    l0 = np.floor(lo).astype(np.int64)
    frac = (lo - l0)[:, None]
    # l0 is hi shifted by a constant unless rounding moved a floor: then rows are gathered
    a = int(l0[0])
    if l0[-1] - a == k - 1 and np.array_equal(l0, np.arange(a, a + k)):
        c_lo = c[a : a + k] * (1 - frac) + c[a + 1 : a + 1 + k] * frac
    else:
        c_lo = c[l0] * (1 - frac) + c[l0 + 1] * frac
    return (c[npad + 1 : npad + 1 + k] - c_lo) / w


def sample_blocks(
    tl: Timeline,
    spans: Spans,
    prof: SpanProfiles,
    path: BlendedPath,
    progress: Callable[[float, str], None] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Fine samples, block by block: (t (k,), filtered xyz (k, 3), filtered arc length (k,),
    block of each sample (k,)). Uniform samples inside each block plus one exactly at its end
    (the filter has settled there: the window lies wholly after the raw motion's end, so the
    point is exact)."""
    starts_all = _phase_starts(prof)
    flat = _flat_profiles(prof, starts_all)
    # `path.at` with the dense path's coordinates as contiguous columns, copied once (np.interp
    # copies a strided column on every call: the whole dense path, once per block and axis)
    cols = np.ascontiguousarray(path.points.T)
    h, nb = tl.h, tl.nb
    fine_t, fine_xyz, fine_s, fine_blk = [], [], [], []
    for b in range(nb):
        k = int(np.ceil(tl.block_len[b] / h - 1e-9))
        tau = np.minimum(np.arange(k + 1) * h, tl.raw_dur[b])
        sp0, sp1 = tl.block_start[b], tl.block_end[b]
        si = np.clip(np.searchsorted(tl.span_t[sp0 : sp1 + 1], tau, side="right") - 1, 0, sp1 - sp0) + sp0
        ds = _positions(prof, starts_all, si, tau - tl.span_t[si], flat)
        s_raw = spans.s0[si] + np.minimum(ds, spans.s1[si] - spans.s0[si])
        xyzs = np.column_stack(
            [
                np.interp(s_raw, path.s, cols[0]),
                np.interp(s_raw, path.s, cols[1]),
                np.interp(s_raw, path.s, cols[2]),
                s_raw,
            ]
        )
        filt = moving_average(xyzs, tl.nf)
        filt[-1] = xyzs[-1]
        tloc = np.arange(k + 1) * h
        tloc[-1] = tl.block_len[b]
        fine_t.append(tl.T0[b] + tloc)
        fine_xyz.append(filt[:, :3])
        fine_s.append(filt[:, 3])
        fine_blk.append(np.full(k + 1, b))
        if progress and b % 200 == 0:
            progress(0.5 + 0.3 * b / nb, "sampling")
    return np.concatenate(fine_t), np.vstack(fine_xyz), np.concatenate(fine_s), np.concatenate(fine_blk)


def row_norms(v: np.ndarray) -> np.ndarray:
    """‖v_i‖ of (k, 3) rows: `np.linalg.norm(v, axis=1)` to the bit, without its (k, 3) temporaries."""
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    return np.sqrt(x * x + y * y + z * z)


def nearest_segment(
    xyz: np.ndarray, points: np.ndarray, guess: np.ndarray, reach: int = 2
) -> tuple[np.ndarray, np.ndarray]:
    """`blend.polyline_distance` in chunks of CHUNK samples (the same result, its temporaries in
    cache; the polyline's geometry computed once)."""
    if len(xyz) <= CHUNK:
        return polyline_distance(xyz, points, guess, reach=reach)
    dist = np.empty(len(xyz))
    seg = np.empty(len(xyz), dtype=np.int64)
    geometry = polyline_geometry(points)
    for i in range(0, len(xyz), CHUNK):
        dist[i : i + CHUNK], seg[i : i + CHUNK] = polyline_distance(
            xyz[i : i + CHUNK], points, guess[i : i + CHUNK], reach=reach, geometry=geometry
        )
    return dist, seg


def _dist2(xyz: np.ndarray, PT: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Squared distance of each sample to vertex v of P (the sum `row_norms` takes the root of);
    PT = P's columns, contiguous: `take` on one of them gathers P[v, c] at half the cost."""
    x = xyz[:, 0] - PT[0].take(v)
    y = xyz[:, 1] - PT[1].take(v)
    z = xyz[:, 2] - PT[2].take(v)
    return x * x + y * y + z * z


def _near_vertices(P: np.ndarray, xyz: np.ndarray, seg: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(closest approach of the samples to each vertex (n,) mm, NaN where no sample is near;
    distance of each sample to its segment's start and end vertex). A vertex between very short
    segments may own no sample: samples of the segments two vertices either side count too."""
    n = len(P)
    near2 = np.full(n, np.inf)
    d0 = np.empty(len(xyz))
    d1 = np.empty(len(xyz))
    PT = np.ascontiguousarray(P.T)
    for i in range(0, len(xyz), CHUNK):
        q, sg = xyz[i : i + CHUNK], seg[i : i + CHUNK]
        a2, b2 = _dist2(q, PT, sg), _dist2(q, PT, sg + 1)
        np.minimum.at(near2, sg, a2)
        np.minimum.at(near2, sg + 1, b2)
        for off in (-2, -1, 2, 3):
            v = np.clip(sg + off, 0, n - 1)
            np.minimum.at(near2, v, _dist2(q, PT, v))
        d0[i : i + CHUNK], d1[i : i + CHUNK] = np.sqrt(a2), np.sqrt(b2)
    near_v = np.sqrt(near2)
    near_v[~np.isfinite(near_v)] = np.nan
    return near_v, d0, d1


def corner_errors(
    P: np.ndarray,
    path: BlendedPath,
    xyz: np.ndarray,
    seg: np.ndarray,
    speed: np.ndarray,
    prog_speed: np.ndarray,
    blk: np.ndarray,
) -> dict[str, np.ndarray]:
    """Per blended vertex: interior angle (deg); corner error = closest approach of the actual
    path to the programmed vertex (mm, the study's corner error); min speed near it (mm/s);
    mean speed through the corner = mean over the slow-down transient around the closest
    approach (speed below 98 % of the programmed speed), mm/s."""
    n = len(P)
    near_v, d0, d1 = _near_vertices(P, xyz, seg)
    vmin = np.full(n, np.inf)
    vert = np.where(d0 <= d1, seg, seg + 1)
    dmin = np.minimum(d0, d1)
    close = dmin <= np.maximum(path.d[vert], 0.5) * 2
    np.minimum.at(vmin, vert[close], speed[close])
    idx = np.flatnonzero(path.d > 0)
    u1 = P[idx] - P[idx - 1]
    u2 = P[idx + 1] - P[idx]
    cosang = np.einsum("ij,ij->i", u1, u2) / (np.linalg.norm(u1, axis=1) * np.linalg.norm(u2, axis=1))
    interior = 180.0 - np.degrees(np.arccos(np.clip(cosang, -1, 1)))
    # closest sample to each vertex (the first of equals), then the run of slow samples (within
    # a block) that holds it
    best = np.full(n, np.inf)
    np.minimum.at(best, vert, dmin)
    cand = np.flatnonzero(dmin == best[vert])
    closest = np.full(n, len(xyz))
    np.minimum.at(closest, vert[cand], cand)
    closest[closest == len(xyz)] = -1
    slow = speed < 0.98 * prog_speed[seg]
    run_start = np.concatenate([[True], (slow[1:] != slow[:-1]) | (blk[1:] != blk[:-1])])
    run_id = np.cumsum(run_start) - 1
    run_sum = np.bincount(run_id, weights=speed)
    run_cnt = np.bincount(run_id)
    c = closest[idx]
    cc = np.maximum(c, 0)
    mean_v = np.where(
        c < 0, np.nan, np.where(slow[cc], run_sum[run_id[cc]] / np.maximum(run_cnt[run_id[cc]], 1), speed[cc])
    )
    return {
        "vertex": idx,
        "interior_deg": interior,
        "error_mm": near_v[idx],
        "min_speed_mm_s": vmin[idx],
        "mean_speed_mm_s": mean_v,
    }


def arc_clock(iv: list[tuple[float, float]]) -> Callable[[Any], np.ndarray]:
    """A(t): total arc-ON time up to t (s), for disjoint, time-ordered intervals."""
    on = np.array([a for a, _ in iv], dtype=float)
    length = np.array([b - a for a, b in iv], dtype=float)
    before = np.concatenate([[0.0], np.cumsum(length)])

    def clock(t: Any) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        if not len(on):
            return np.zeros_like(t)
        k = np.searchsorted(on, t, side="right") - 1
        kk = np.maximum(k, 0)
        x = np.asarray(t - on[kk])  # clipped to [0, length] in place (np.clip's numbers)
        np.maximum(x, 0.0, out=x)
        np.minimum(x, length[kk], out=x)
        x += before[kk]
        return np.where(k >= 0, x, 0.0)

    return clock
