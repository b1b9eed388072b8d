"""The simulation's fine samples and what they add up to: each sample's programmed segment, deviation,
time weight and arc state (`_attribute` → `_Samples`), the simulation's figures (`_metrics`, see
`simulate.METRIC_UNITS`) and its per-sample trace (`_trace`).

Split from `trajectory.simulate` (issue 27): that module plans and times the motion (blend, speed
profiles, timeline, fine sampling); this one accounts for the samples it produces. Units: mm, s.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from ..core.moves import DEPOSIT
from .blend import BlendedPath
from .fine import Timeline, nearest_segment

if TYPE_CHECKING:  # the simulation imports this module
    from .simulate import _Program


@dataclass(frozen=True, eq=False)
class _Samples:
    """The fine samples and what each one owns: t, xyz, step (to the next sample, 0 across
    blocks), blk, seg (programmed segment), deviation (mm), w (time owned, s), arc_w (arc-ON
    time in it, s), inside (bool)."""

    t: np.ndarray
    xyz: np.ndarray
    step: np.ndarray
    blk: np.ndarray
    seg: np.ndarray
    deviation: np.ndarray
    w: np.ndarray
    arc_w: np.ndarray
    inside: np.ndarray


def _attribute(
    prog: _Program,
    path: BlendedPath,
    tl: Timeline,
    t: np.ndarray,
    xyz: np.ndarray,
    s_f: np.ndarray,
    blk: np.ndarray,
    step: np.ndarray,
    arc_time: Callable[[Any], np.ndarray],
) -> _Samples:
    """Programmed segment, deviation, time weights and arc state of every fine sample. Each sample
    owns the interval to the next one; the standstill before a block (arc switch, ignition,
    interlayer dwell) belongs to the block's first sample."""
    dense_i = np.clip(np.searchsorted(path.s, s_f, side="right") - 1, 0, len(path.seg) - 1)
    deviation, seg = nearest_segment(xyz, prog.points, path.seg[dense_i], reach=2)
    same = blk[1:] == blk[:-1]
    step = np.where(same, step, 0.0)
    t_next = np.concatenate([t[1:], [tl.t_end]])
    last = np.concatenate([~same, [True]])
    first = np.concatenate([[True], ~same])
    t_from = t.copy()
    t_from[first] = np.concatenate([[0.0], t[:-1][last[:-1]]])  # previous block's end (0 for the first)
    t_to = np.where(last, t, t_next)
    # the arc clock at t_to and t_from, read off its values at the samples' own times (t_to and
    # t_from are sample times but for the end of motion and 0)
    a_t = arc_time(t)
    a_to = np.where(last, a_t, np.concatenate([a_t[1:], arc_time(np.array([tl.t_end]))]))
    a_from = a_t.copy()
    a_from[first] = np.concatenate([arc_time(np.array([0.0])), a_t[:-1][last[:-1]]])
    inside = prog.inside[seg] & (prog.kind[seg] == DEPOSIT)
    return _Samples(t, xyz, step, blk, seg, deviation, t_to - t_from, a_to - a_from, inside)


def _metrics(
    prog: _Program,
    path: BlendedPath,
    stop: np.ndarray,
    sm: _Samples,
    total_time: float,
    burnback: float,
    vol_samples: np.ndarray,
    seg_len: np.ndarray,
) -> dict[str, float]:
    """The simulation's figures (see METRIC_UNITS), corner errors apart."""
    w, arc_w, step, inside, deviation = sm.w, sm.arc_w, sm.step, sm.inside, sm.deviation
    arc_on = arc_w > 0.5 * np.maximum(w, 1e-12)
    moving = np.concatenate([step > 1e-9, [False]])
    prog_len = float(seg_len.sum())
    act_len = float(step.sum())
    dev_w = w * moving
    return {
        "total_time_s": total_time,
        "programmed_length_mm": prog_len,
        "actual_length_mm": act_len,
        "length_ratio": act_len / prog_len if prog_len > 0 else 0.0,
        "arc_on_time_s": float(arc_w.sum()),  # within the cycle [0, total_time]: ≤ total_time
        "arc_off_lag_after_end_s": float(burnback),
        "arc_on_length_mm": float((step * arc_on[:-1]).sum()),
        "deposited_volume_mm3": float(vol_samples.sum()),
        "programmed_volume_mm3": float((prog.wire_rate * seg_len / prog.speed)[prog.arc].sum()),
        "max_deviation_mm": float(deviation.max()),
        "mean_deviation_mm": float((deviation * dev_w).sum() / dev_w.sum()) if dev_w.sum() > 0 else 0.0,
        "time_inside_s": float((w * inside).sum()),
        "time_outside_s": float((w * ~inside).sum()),
        "arc_off_time_inside_s": float((np.clip(w - arc_w, 0.0, None) * inside).sum()),
        "arc_on_time_outside_s": float((arc_w * ~inside).sum()),
        "actual_length_outside_mm": float((step * ~inside[:-1]).sum()),
        "average_speed_mm_s": act_len / total_time if total_time > 0 else 0.0,
        "stops": float(stop.sum()),
        "blended_corners": float((path.d > 0).sum()),
        "min_corner_speed_mm_s": float(path.cap[path.d > 0].min()) if (path.d > 0).any() else 0.0,
    }


def _trace(
    prog: _Program,
    sm: _Samples,
    spd: np.ndarray,
    vol_samples: np.ndarray,
    total_time: float,
    dt: float,
    arc_time: Callable[[Any], np.ndarray],
) -> dict[str, np.ndarray]:
    """The trace at the interpolation cycle (see SimulationResult.trace)."""
    t, xyz, seg = sm.t, sm.xyz, sm.seg
    t_out = np.arange(0.0, total_time + 0.5 * dt, dt)
    idx = np.clip(np.searchsorted(t, t_out, side="right") - 1, 0, len(t) - 1)
    s_act = np.concatenate([[0.0], np.cumsum(sm.step)])
    return {
        "t": t_out,
        "x": np.interp(t_out, t, xyz[:, 0]),
        "y": np.interp(t_out, t, xyz[:, 1]),
        "z": np.interp(t_out, t, xyz[:, 2]),
        "speed": spd[idx],
        "arc": (arc_time(t_out + 1e-9) - arc_time(t_out)) > 0,
        "deviation": sm.deviation[idx],
        "s": np.interp(t_out, t, s_act),
        "layer": prog.layer[seg[idx]],
        "section": prog.section[seg[idx]],
        "inside": sm.inside[idx],
        "volume": np.interp(t_out, t, np.cumsum(vol_samples)),
        "segment": seg[idx],
    }
