"""Adapt the next layer to what was built: per-sample travel speed from the measured top and a
bead-height model corrected by what the last layer really gave (run-to-run control).

Height model (mass balance, the one the preflight uses): a bead laid at travel speed v with wire
feed WFS has cross-section A = WFS·πd²/4·η / v and height h = A/(k·w), so h = C/v with
C = WFS·πd²/4·η/(k·w) mm²/s. The plan's own C follows from its layer height and speed,
C = h_plan·v_plan (a mass-balanced plan lays its planned bead height h_plan at its speed: the
layer height, or on fan layers the local distance to the planned layer below), so no material data
is needed and the model holds for any recipe. The layer before tells how far reality is from it:
gain g = h_measured / h_predicted per sample (heat build-up, stops and corners repeat at the same
places layer after layer, as in iterative learning control); the next layer's speed at each
sample is

    v = g · C / (H_next − top_measured),   clamped to the process window,

where H_next is the planned crest height and top_measured the measured top beneath it. The
window (`Window`) bounds v to [min_factor, max_factor] × v_plan and to absolute limits; clamped
samples are counted and reported, never silently passed.

`adapted_layer(lp, track, v)` writes the per-sample speeds back into the layer's toolpath: each
arc-ON segment is cut into pieces of at most `piece_mm` and each piece gets the speed that keeps
its time equal to its samples' (harmonic mean), so the programme varies speed along a pass.

Units: mm, mm/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from ..core.model import LayerPaths
from .track import Track


@dataclass(frozen=True)
class Window:
    """The process window for adapted travel speeds: [min_factor, max_factor] × planned speed,
    and never outside [min_speed, max_speed] mm/s; gains clamped to [min_gain, max_gain]."""

    min_factor: float = 0.6
    max_factor: float = 1.6
    min_speed: float = 1.0
    max_speed: float = 60.0
    min_gain: float = 0.5
    max_gain: float = 2.0

    def __post_init__(self) -> None:
        if not 0 < self.min_factor <= 1 <= self.max_factor:
            raise ValueError("the window needs 0 < min_factor <= 1 <= max_factor")
        if not 0 < self.min_speed < self.max_speed:
            raise ValueError("the window needs 0 < min_speed < max_speed (mm/s)")


def beneath(
    next_track: Track, prev_track: Track | None, prev_top: np.ndarray | None, reach: float | None = None
) -> np.ndarray:
    """For every sample of the next layer, the height (along its build direction) of the top it
    will be laid on: the measured top of the nearest sample of the layer before (within `reach`
    mm), else the plan (H − t: the substrate or an unmeasured spot is taken as planned)."""
    H = next_track.planned_height()
    out = H - next_track.thickness
    if prev_track is None or prev_top is None or prev_track.n == 0 or next_track.n == 0:
        return out
    dev = np.where(np.isfinite(prev_top), prev_top - prev_track.planned_height(), 0.0)
    actual = prev_track.points + dev[:, None] * prev_track.normal
    spot = next_track.points - next_track.thickness * next_track.normal
    reach = max(6.0, 3.0 * next_track.thickness) if reach is None else reach
    d, j = cKDTree(prev_track.points).query(spot, k=1, distance_upper_bound=reach)
    hit = np.isfinite(d) & (j < prev_track.n)
    jj = np.where(hit, j, 0)
    seen = hit & np.isfinite(prev_top[jj])
    top = np.einsum("ij,ij->i", actual[jj], next_track.normal)
    return np.where(seen, top, out)


def carry(
    next_track: Track, prev_track: Track | None, values: np.ndarray | None, default: float, reach: float | None = None
) -> np.ndarray:
    """A per-sample value of the layer before (e.g. the gain) at the next layer's samples
    (nearest within `reach` mm; `default` where none or NaN)."""
    out = np.full(next_track.n, float(default))
    if prev_track is None or values is None or prev_track.n == 0 or next_track.n == 0:
        return out
    spot = next_track.points - next_track.thickness * next_track.normal
    reach = max(6.0, 3.0 * next_track.thickness) if reach is None else reach
    d, j = cKDTree(prev_track.points).query(spot, k=1, distance_upper_bound=reach)
    hit = np.isfinite(d) & (j < prev_track.n)
    v = np.where(hit, values[np.where(hit, j, 0)], np.nan)
    return np.where(np.isfinite(v), v, default)


@dataclass(frozen=True, eq=False)
class Adaptation:
    """Speeds chosen for one layer and why."""

    speed: np.ndarray  # (n,) mm/s
    predicted_top: np.ndarray
    needed_height: np.ndarray
    clamped_slow: int  # samples that wanted a speed below the window (needed more metal)
    clamped_fast: int  # samples that wanted a speed above it (needed less)

    def summary(self, track: Track) -> dict:
        v0 = track.speed
        return {
            "layer": track.layer,
            "samples": track.n,
            "speed_factor_min": round(float(np.min(self.speed / v0)), 4) if track.n else None,
            "speed_factor_max": round(float(np.max(self.speed / v0)), 4) if track.n else None,
            "needed_height_mm": [
                round(float(np.min(self.needed_height)), 3),
                round(float(np.max(self.needed_height)), 3),
            ]
            if track.n
            else None,
            "clamped_slow": self.clamped_slow,
            "clamped_fast": self.clamped_fast,
        }


def planned_heights(track: Track, prev_track: Track | None) -> np.ndarray:
    """The bead height the plan lays at each sample: its crest height minus the planned crest of
    the layer below there (fan layers vary along the layer), the layer height on the first layer."""
    if prev_track is None:
        return np.full(track.n, track.thickness)
    return track.planned_height() - beneath(track, prev_track, prev_track.planned_height())


def plan_speeds(
    track: Track, below: np.ndarray, gain: np.ndarray, window: Window = Window(), h_plan: np.ndarray | None = None
) -> Adaptation:
    """Per-sample speeds for `track` laid on tops `below`, with gains `gain` (see module doc);
    `h_plan`: the planned bead heights (`planned_heights`; default the layer height)."""
    v0 = track.speed
    if not np.isfinite(v0).all():
        bad = int(np.flatnonzero(~np.isfinite(v0))[0])
        raise ValueError(
            f"layer {track.layer}, section {track.keys[track.section[bad]]}: an arc-ON segment has no "
            "programmed speed, so its bead height cannot be adapted"
        )
    H = track.planned_height()
    C = (track.thickness if h_plan is None else np.asarray(h_plan, float)) * v0
    g = np.clip(gain, window.min_gain, window.max_gain)
    need = H - below
    lo = np.maximum(window.min_factor * v0, window.min_speed)
    hi = np.minimum(window.max_factor * v0, window.max_speed)
    with np.errstate(divide="ignore", invalid="ignore"):
        want = np.where(need > 1e-6, g * C / need, np.inf)
    v = np.clip(want, lo, hi)
    pred = below + g * C / v
    return Adaptation(v, pred, need, int((want < lo).sum()), int((want > hi).sum()))


def adapted_layer(lp: LayerPaths, track: Track, speed: np.ndarray, piece_mm: float = 5.0) -> LayerPaths:
    """`lp` with its arc-ON segments cut into pieces of ≤ `piece_mm` carrying the adapted speeds
    (see module doc); travel, zones and tool axes kept."""
    if len(speed) != track.n:
        raise ValueError("one speed per track sample")
    s_cum = np.cumsum(track.length) - track.length / 2
    sections = []
    for si, sp in enumerate(lp.sections):
        mask = track.section == si
        if not mask.any():
            sections.append(sp)
            continue
        P = np.asarray(sp.points, float)
        axis = None if sp.tool_axis is None else np.asarray(sp.tool_axis, float)
        pts, axes, arc, inside, spd, zone = [P[0]], [] if axis is None else [axis[0]], [], [], [], []
        for j in range(len(P) - 1):
            a, b = P[j], P[j + 1]
            L = float(np.linalg.norm(b - a))
            here = mask & (track.segment == j)
            if not sp.arc[j] or not here.any() or L <= 1e-9:
                pts.append(b)
                if axis is not None:
                    axes.append(axis[j + 1])
                arc.append(sp.arc[j])
                inside.append(sp.inside[j])
                spd.append(sp.speed[j])
                zone.append(sp.zone[j] if sp.zone else "")
                continue
            k = max(1, math.ceil(L / piece_mm))
            idx = np.flatnonzero(here)
            # sample positions along this segment, 0..1
            t_s = (s_cum[idx] - (s_cum[idx[0]] - track.length[idx[0]] / 2)) / L
            for m in range(k):
                t0, t1 = m / k, (m + 1) / k
                sel = (t_s >= t0) & (t_s < t1) if m < k - 1 else (t_s >= t0)
                ls, vs = track.length[idx][sel], speed[idx][sel]
                v = float(ls.sum() / (ls / vs).sum()) if sel.any() else float(sp.speed[j])
                pts.append(a + t1 * (b - a))
                if axis is not None:
                    ax = axis[j] * (1 - t1) + axis[j + 1] * t1
                    axes.append(ax / np.linalg.norm(ax))
                arc.append(True)
                inside.append(sp.inside[j])
                spd.append(v)
                zone.append(sp.zone[j] if sp.zone else "")
        sections.append(
            replace(
                sp,
                points=np.asarray(pts),
                arc=np.asarray(arc, bool),
                inside=np.asarray(inside, bool),
                speed=np.asarray(spd, float),
                zone=tuple(zone) if sp.zone else (),
                tool_axis=None if axis is None else np.asarray(axes),
            )
        )
    return replace(lp, sections=tuple(sections))
