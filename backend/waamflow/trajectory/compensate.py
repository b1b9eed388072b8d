"""Uniform deposit by design: modulate the wire feed per short piece of path so the metal laid per
mm stays at its programmed value where the robot slows down (issue 16).

Why: the wire feed is constant while the arc burns, so deposit per mm = wire rate / actual speed,
and the robot really stops at every arc switch, slows in every blended corner and never reaches
the programmed speed on short moves (robot-study.md: "every slow-down deposits extra metal per
mm"; ~7 mm³/mm jumps at 40 mm/s).

How (one simulation, then exact): arc-ON segments are split into pieces of at most `step_mm`
(collinear vertices: the motion is unchanged). The controller model (`simulate_program`, the same
settings as simulate-robot) gives each piece's arc time T_i and the length L_i the robot really
travels on it (shorter than programmed where it cuts a corner: the bead is laid along the actual
path); the programmed deposit is q_i = rate_i / v_i (rate from the zone's wire feed speed, else
the constant feed). Since the motion does not depend on the wire feed, the feed that lays q_i·L_i
in T_i is

    rate_i' = rate_i · q_i / (V_i / L_i),      V_i = rate_i·T_i the uncompensated volume,

clipped to [min_ratio, max_ratio] × rate_i (a feeder cannot stop the wire under a burning arc,
nor push more than its motor allows; the ignition and crater standstills stay partly
uncompensated for that reason). Ratios are quantised to `quantum` (1 %) and neighbouring pieces
with the same ratio merged, so the program changes the feed only where it must. The pieces carry
the new feed as zone parameters of sub-zones `<zone>@<percent>` (e.g. `z1@87`): every
post-processor already emits a process change (WFS) at a zone change; on the controller these are
path-synchronous outputs (KRL TRIGGER WHEN DISTANCE, ABB TriggL), which do not stop the advance
run. Not modelled: the feeder's own response time (~50-100 ms on push-pull CMT drives), which
smooths the steps.

Why the feed and not the travel speed: the slow-downs are the controller's (full stops at arc
switches, corner speed caps, jerk-limited ramps); a higher programmed speed does not lift them, so
travel speed cannot even the deposit where it is uneven. The feed follows the speed instead, as
the welding power source's synergic line then follows the feed.

The measure: `deposit_per_mm_cv`, the coefficient of variation (length-weighted std / mean) of
the deposited volume per mm in 1 mm bins of actual arc-ON path length, from the simulated trace
(standstills with the arc burning add their volume to the bin where they happen).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..core.model import Layered, SectionPath
from ..core.moves import Moves, flatten
from .run import KinematicsOptions, simulate_program
from .simulate import SimOptions, SimulationResult

WIRE_AREA_DEFAULT_D = 1.2  # mm: the robot study's wire (94.25 mm³/s at 83.34 mm/s)


@dataclass(frozen=True)
class CompensationSettings:
    """step_mm: longest arc-ON piece (mm). min_ratio/max_ratio: feed bounds as fractions of the
    programmed feed. quantum: ratio resolution. wire_diameter_mm: to express the feed as WFS."""

    step_mm: float = 1.0
    min_ratio: float = 0.3
    max_ratio: float = 1.6
    quantum: float = 0.01
    wire_diameter_mm: float = WIRE_AREA_DEFAULT_D


def deposit_bins(trace: dict, bin_mm: float = 1.0, target: np.ndarray | None = None):
    """(s_mm bin start along arc-ON length, length_mm, mm³/mm[, target mm³/mm]) per bin of `bin_mm`
    of actual arc-ON path, from a simulated trace with cumulative `volume`. With `target` (the
    programmed mm³/mm per program segment, indexed by the trace's `segment`), also the bins'
    length-weighted programmed deposit."""
    s = np.asarray(trace["s"], float)
    v = np.asarray(trace["volume"], float)
    ds, dv = np.diff(s), np.diff(v)
    on = (dv > 1e-12) | (np.asarray(trace["arc"], bool)[:-1] & (ds > 0))
    sa = np.concatenate([[0.0], np.cumsum(ds * on)])
    b = np.floor(sa[:-1][on] / bin_mm).astype(np.int64)
    if not len(b):
        z = np.zeros(0)
        return (z, z, z, z) if target is not None else (z, z, z)
    length = np.bincount(b, ds[on])
    vol = np.bincount(b, dv[on])
    tgt = None
    if target is not None:
        t_s = np.asarray(target, float)[np.asarray(trace["segment"], int)[:-1]][on]
        tgt = np.bincount(b, ds[on] * t_s)
    keep = length > 1e-9
    vol_keep = vol[keep]
    # a standstill bin (no length) adds its volume to the next bin with length
    if (~keep).any():
        idx = np.minimum(np.searchsorted(np.flatnonzero(keep), np.flatnonzero(~keep)), keep.sum() - 1)
        np.add.at(vol_keep, idx, vol[~keep])
    starts = np.flatnonzero(keep) * bin_mm
    length = length[keep]
    tgt = tgt[keep] if tgt is not None else None
    if len(length) > 1 and length[-1] < 0.5 * bin_mm:  # the last, partial bin joins the one before
        length[-2] += length[-1]
        vol_keep[-2] += vol_keep[-1]
        if tgt is not None:
            tgt[-2] += tgt[-1]
            tgt = tgt[:-1]
        starts, length, vol_keep = starts[:-1], length[:-1], vol_keep[:-1]
    if tgt is not None:
        return starts, length, vol_keep / length, tgt / length
    return starts, length, vol_keep / length


def _cv(w: np.ndarray, q: np.ndarray) -> float:
    if w.sum() <= 0:
        return 0.0
    mean = float((w * q).sum() / w.sum())
    return float(np.sqrt((w * (q - mean) ** 2).sum() / w.sum()) / mean) if mean > 0 else 0.0


def deposit_cv(trace: dict, bin_mm: float = 1.0) -> float:
    """Coefficient of variation of the deposit per mm over arc-ON length (see module doc)."""
    _, w, q = deposit_bins(trace, bin_mm)
    return _cv(w, q)


def deposit_ratio_cv(res: SimulationResult, bin_mm: float = 1.0, target: np.ndarray | None = None) -> float:
    """Coefficient of variation of actual ÷ programmed deposit per mm over arc-ON length: the
    deviation from the target alone, without the variation zones program on purpose (ramps).
    target: programmed mm³/mm per program segment (default: the result's own; a compensated
    program's own "programmed" deposit includes the compensation, so pass the original's)."""
    if "segment" not in res.trace:
        return float("nan")
    t_seg = res.deposit["programmed_mm3_per_mm"] if target is None else target
    _, w, q, t = deposit_bins(res.trace, bin_mm, t_seg)
    ok = t > 1e-12
    return _cv(w[ok], q[ok] / t[ok])


def _blended(points: np.ndarray, arc: np.ndarray) -> np.ndarray:
    """(n,) bool: interior vertices the controller blends (direction change, no arc switch)."""
    n = len(points)
    out = np.zeros(n, dtype=bool)
    if n < 3:
        return out
    D = np.diff(points, axis=0)
    U = D / np.maximum(np.linalg.norm(D, axis=1, keepdims=True), 1e-12)
    cos = np.einsum("ij,ij->i", U[:-1], U[1:])
    out[1:-1] = (cos < np.cos(np.radians(0.5))) & (arc[:-1] == arc[1:])
    return out


def blend_reach(speed_prev: np.ndarray, speed_next: np.ndarray, cdis: float, blend: str, profile) -> np.ndarray:
    """Distance (mm) before/after a corner where the controller's blend starts: min(CDIS,
    apo_min + apo_time·v) in KUKA mode (the same rule as `blend.blend_path`), the zone radius else."""
    v = np.minimum(speed_prev, speed_next)
    if blend == "cdis" and profile is not None:
        return np.minimum(cdis, profile.apo_min_mm + profile.apo_time_s * v)
    return np.full(len(v), float(cdis))


def subdivide(sp: SectionPath, step_mm: float, cdis: float = 0.0, blend: str = "cdis", profile=None) -> SectionPath:
    """Split every arc-ON segment into pieces of at most step_mm (attributes copied). Next to a
    blended corner a piece of twice the blend reach (`blend_reach`, +2 %) stays whole: the
    controller starts a blend at most half a block before the corner, so shorter neighbours would
    change the corner the robot really takes. A segment too short for that is not split."""
    pts = np.asarray(sp.points, float)
    if len(pts) < 2:
        return sp
    arc = np.asarray(sp.arc, bool)
    L = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    bl = _blended(pts, arc)
    spd = np.asarray(sp.speed, float)
    keep = np.zeros(len(pts))
    if len(pts) > 2:
        keep[1:-1] = 2.04 * blend_reach(spd[:-1], spd[1:], cdis, blend, profile)
    keep[~bl] = 0.0
    cuts: list[np.ndarray] = []
    for i, li in enumerate(L):
        a, b = keep[i], keep[i + 1]
        inner = li - a - b
        if not arc[i] or inner <= 1e-6 or li <= step_mm:
            cuts.append(np.zeros(1))
            continue
        k = max(int(np.ceil(inner / step_mm - 1e-9)), 1)
        f = a + inner * np.arange(k + 1) / k
        f = np.unique(np.concatenate([[0.0], f[(f > 1e-6) & (f < li - 1e-6)]])) / li
        cuts.append(f)
    parent = np.concatenate([np.full(len(c), i) for i, c in enumerate(cuts)])
    frac = np.concatenate(cuts)
    if len(parent) == len(L):
        return sp
    new = pts[parent] + frac[:, None] * (pts[parent + 1] - pts[parent])
    points = np.vstack([new, pts[-1:]])
    axis = None
    if sp.tool_axis is not None:
        ax = np.asarray(sp.tool_axis, float)
        a_ = ax[parent] + frac[:, None] * (ax[parent + 1] - ax[parent])
        a_ /= np.maximum(np.linalg.norm(a_, axis=1, keepdims=True), 1e-12)
        axis = np.vstack([a_, ax[-1:]])
    return replace(
        sp,
        points=points,
        arc=arc[parent],
        inside=np.asarray(sp.inside)[parent],
        speed=np.asarray(sp.speed, float)[parent],
        zone=tuple(sp.zone[i] for i in parent) if sp.zone else (),
        tool_axis=axis,
    )


def subdivide_toolpath(tp, step_mm: float, cdis: float = 0.0, blend: str = "cdis", profile=None):
    items = tp.items if isinstance(tp, Layered) else tuple(tp)
    return Layered(
        tuple(
            None
            if lp is None
            else replace(lp, sections=tuple(subdivide(sp, step_mm, cdis, blend, profile) for sp in lp.sections))
            for lp in items
        )
    )


def _rate(moves: Moves, opt: SimOptions) -> np.ndarray:
    """Programmed wire feed per move segment, mm³/s (as the simulator resolves it)."""
    rate = np.full(len(moves.points) - 1, float(opt.wire_feed_mm3_s))
    if opt.wire_diameter_mm and moves.zone_params:
        area = np.pi * opt.wire_diameter_mm**2 / 4.0
        for (sec, zone), params in moves.zone_params.items():
            wfs = params.get("wire_feed_speed")
            if wfs:
                rate[(moves.section == sec) & (moves.zone == zone)] = float(wfs) * 1000.0 / 60.0 * area
    return rate


def actual_lengths(res: SimulationResult) -> np.ndarray:
    """(n_program_segments,) length (mm) the robot really travels on each program segment (trace
    samples attributed to their nearest segment; corners it cuts count where it cuts them)."""
    tr = res.trace
    n = len(res.deposit["length_mm"])
    if "segment" not in tr:
        return np.asarray(res.deposit["length_mm"], float)
    ds = np.diff(np.asarray(tr["s"], float))
    return np.bincount(np.asarray(tr["segment"], int)[:-1], ds, minlength=n)[:n]


def piece_ratios(moves: Moves, res: SimulationResult, opt: SimOptions, cfg: CompensationSettings) -> np.ndarray:
    """(n_moves - 1,) feed ratio per move segment (1 where not arc-ON), quantised and clipped.

    The target is the programmed deposit per mm of the path the robot really travels: where the
    controller cuts a corner the bead is laid along the shorter, actual path."""
    L = moves.segment_lengths
    src = np.flatnonzero(L > 1e-6)  # the simulator drops zero-length segments
    d = res.deposit
    prog, act = np.asarray(d["programmed_mm3_per_mm"]), np.asarray(d["actual_mm3_per_mm"])
    L_prog = np.asarray(d["length_mm"], float)
    L_act = actual_lengths(res)
    L_use = np.where(L_act > 0.05 * L_prog, L_act, L_prog)
    act_real = act * L_prog / L_use  # volume per mm of actual travel
    ratio = np.ones(len(L))
    ok = np.asarray(d["arc"], bool) & (act_real > 1e-12) & (prog > 0)
    r = np.clip(prog[ok] / act_real[ok], cfg.min_ratio, cfg.max_ratio)
    ratio[src[ok]] = np.round(r / cfg.quantum) * cfg.quantum
    return ratio


def apply_ratios(
    tp: Layered, moves: Moves, ratio: np.ndarray, base_rate: np.ndarray, wire_diameter_mm: float
) -> Layered:
    """Toolpath whose arc-ON segments carry sub-zones `<zone>@<percent>` with the scaled feed as
    WFS (m/min) for a wire of `wire_diameter_mm` (every arc-ON segment, ratio 1 included, so the
    feed is explicit wherever the arc burns)."""
    area = np.pi * wire_diameter_mm**2 / 4.0
    out: list[Any] = []
    i = 0
    first = True
    for lp in tp.items:
        if lp is None:
            out.append(None)
            continue
        secs = []
        for sp in lp.sections:
            n = len(sp.points) - 1
            if n < 1:
                secs.append(sp)
                continue
            if not first:
                i += 1 + (0 if sp.approach is None else len(sp.approach))  # travel into this section
            first = False
            r, br = ratio[i : i + n], base_rate[i : i + n]
            i += n
            zones = list(sp.zone) if sp.zone else [""] * n
            params = {z: dict(v) for z, v in sp.zone_params.items()}
            colors = dict(sp.zone_colors)
            new_z = []
            for j in range(n):
                z = zones[j]
                if not sp.arc[j]:
                    new_z.append(z)
                    continue
                pct = int(round(r[j] * 100))
                zid = f"{z}@{pct}"
                if zid not in params:
                    p = {k: v for k, v in params.get(z, {}).items() if k != "dwell"}
                    p["wire_feed_speed"] = round(float(br[j] * r[j] / area * 60.0 / 1000.0), 4)
                    params[zid] = p
                    colors[zid] = colors.get(z, "#888888")
                new_z.append(zid)
            # a sub-zone that starts a zone keeps the zone's dwell (ignition/zone dwell stay where they were)
            for j in range(n):
                if (
                    new_z[j] != zones[j]
                    and (j == 0 or zones[j - 1] != zones[j])
                    and "dwell" in params.get(zones[j], {})
                ):
                    params.setdefault(new_z[j], {})
                    params[new_z[j]] = {**params[new_z[j]], "dwell": params[zones[j]]["dwell"]}
            secs.append(replace(sp, zone=tuple(new_z), zone_params=params, zone_colors=colors))
        out.append(replace(lp, sections=tuple(secs)))
    return Layered(tuple(out))


@dataclass(frozen=True, eq=False)
class Compensation:
    toolpath: Layered
    before: SimulationResult
    after: SimulationResult
    report: dict


def compensate(
    tp,
    profile,
    opt: SimOptions,
    kin: KinematicsOptions | None = None,
    cfg: CompensationSettings = CompensationSettings(),
) -> Compensation:
    """Subdivide, simulate, scale the feed per piece, simulate again (see module doc)."""
    fine = subdivide_toolpath(tp, cfg.step_mm, opt.cdis, opt.blend, profile)
    moves = flatten(fine)
    before = simulate_program(moves, profile, opt, kin)
    ratio = piece_ratios(moves, before, opt, cfg)
    base = _rate(moves, opt)  # the feed as the simulator resolves it (zone WFS only with a wire diameter)
    diameter = opt.wire_diameter_mm or cfg.wire_diameter_mm
    out = apply_ratios(fine, moves, ratio, base, diameter)
    after = simulate_program(flatten(out), profile, replace(opt, wire_diameter_mm=diameter), kin)
    arc = np.asarray(moves.arc, bool)
    r_on = ratio[arc]
    cv0, cv1 = deposit_cv(before.trace), deposit_cv(after.trace)
    report = {
        "deposit_per_mm_cv_before": round(cv0, 5),
        "deposit_per_mm_cv_after": round(cv1, 5),
        "deposit_ratio_cv_before": round(deposit_ratio_cv(before), 5),
        "deposit_ratio_cv_after": round(deposit_ratio_cv(after, target=before.deposit["programmed_mm3_per_mm"]), 5),
        "cv_reduction": round(1 - cv1 / cv0, 4) if cv0 > 0 else 0.0,
        "pieces": int(arc.sum()),
        "step_mm": cfg.step_mm,
        "feed_ratio_min": round(float(r_on.min()), 3) if len(r_on) else 1.0,
        "feed_ratio_max": round(float(r_on.max()), 3) if len(r_on) else 1.0,
        "clipped_pieces": int(((r_on <= cfg.min_ratio + 1e-9) | (r_on >= cfg.max_ratio - 1e-9)).sum()),
        "deposited_volume_mm3_before": round(before.metrics["deposited_volume_mm3"], 3),
        "deposited_volume_mm3_after": round(after.metrics["deposited_volume_mm3"], 3),
        "programmed_volume_mm3": round(before.metrics["programmed_volume_mm3"], 3),
        "settings": dataclasses.asdict(cfg),
    }
    return Compensation(out, before, after, report)


def deposit_bin_series(plain: SimulationResult, after: SimulationResult, bin_mm: float = 1.0) -> dict:
    """The deposit per mm in `bin_mm` bins of actual arc-ON path (the quantity behind
    `deposit_per_mm_cv`) of the program at constant feed and compensated, and the programmed
    deposit, for plotting (`deposit["bins"]`)."""
    out: dict = {"bin_mm": bin_mm}
    if "segment" in plain.trace:
        s0, _, q0, t0 = deposit_bins(plain.trace, bin_mm, plain.deposit["programmed_mm3_per_mm"])
        out["programmed"] = t0
    else:
        s0, _, q0 = deposit_bins(plain.trace, bin_mm)
    s1, _, q1 = deposit_bins(after.trace, bin_mm)
    out.update(s_mm=s0, constant_feed=q0, s_compensated_mm=s1, compensated=q1)
    return out


def simulate_compensated(
    tp,
    profile,
    opt: SimOptions,
    kin: KinematicsOptions | None = None,
    cfg: CompensationSettings = CompensationSettings(),
    progress=None,
) -> SimulationResult:
    """simulate-robot with compensation on: the compensated program's simulation, with
    `deposit_per_mm_cv` (compensated), `deposit_per_mm_cv_before` (the program as given) and the
    uncompensated deposit per segment beside the compensated one (`deposit["uncompensated_mm3_per_mm"]`)."""
    plain = simulate_program(flatten(tp), profile, opt, kin, progress=progress)
    comp = compensate(tp, profile, opt, kin, cfg)
    cv0, cv1 = deposit_cv(plain.trace), deposit_cv(comp.after.trace)
    metrics = {
        **comp.after.metrics,
        "programmed_volume_mm3": comp.before.metrics["programmed_volume_mm3"],
        "deposit_per_mm_cv": cv1,
        "deposit_per_mm_cv_before": cv0,
        "deposit_per_mm_cv_after": cv1,
        "deposit_ratio_cv": deposit_ratio_cv(comp.after, target=comp.before.deposit["programmed_mm3_per_mm"]),
        "deposit_ratio_cv_before": deposit_ratio_cv(plain),
        "feed_ratio_min": comp.report["feed_ratio_min"],
        "feed_ratio_max": comp.report["feed_ratio_max"],
        "compensated_pieces": float(comp.report["pieces"]),
    }
    deposit: dict[str, Any] = {
        **comp.after.deposit,
        "uncompensated_mm3_per_mm": comp.before.deposit["actual_mm3_per_mm"],
        "programmed_mm3_per_mm": comp.before.deposit["programmed_mm3_per_mm"],
        "compensated_feed_mm3_per_mm": comp.after.deposit["programmed_mm3_per_mm"],
        "bins": deposit_bin_series(plain, comp.after),
    }
    return replace(comp.after, metrics=metrics, deposit=deposit, warnings=plain.warnings)


def deposit_svg(
    deposit: dict, title: str = "Deposit per mm along the path", s_range: tuple[float, float] | None = None
) -> str:
    """Plot of the deposit per mm: with compensation (`deposit["bins"]`), constant feed against
    compensated in the 1 mm bins of actual arc-ON path that `deposit_per_mm_cv` measures, beside
    the programmed deposit; otherwise programmed and actual mm³/mm per arc-ON segment against
    programmed path length. Values above 1.15 × the 99th percentile (ignition standstills) are
    clipped. `s_range` (mm): only that stretch of the path."""
    from ..process.svgplot import Chart, figure

    if "bins" in deposit:
        b = deposit["bins"]
        s0, s1 = np.asarray(b["s_mm"], float), np.asarray(b["s_compensated_mm"], float)
        series = [
            ("constant feed", "#d62828", s0, np.asarray(b["constant_feed"], float)),
            ("compensated", "#2a9d8f", s1, np.asarray(b["compensated"], float)),
        ]
        if "programmed" in b:
            series.insert(0, ("programmed", "#555555", s0, np.asarray(b["programmed"], float)))
        if s_range is not None:
            series = [
                (lb, c, x[(x >= s_range[0]) & (x <= s_range[1])], q[(x >= s_range[0]) & (x <= s_range[1])])
                for lb, c, x, q in series
            ]
        xs = np.concatenate([x for _, _, x, _ in series])
        lo, hi = (float(xs.min()), float(xs.max()) + b["bin_mm"]) if len(xs) else (0.0, 1.0)
        qmax = max(float(np.percentile(q, 99.0)) if len(q) else 1.0 for _, _, _, q in series) * 1.15
        ch = Chart(
            64,
            40,
            800,
            260,
            (lo if s_range is not None else 0.0, hi),
            (0.0, qmax),
            title=title,
            x_label=f"actual arc-on path length, mm ({b['bin_mm']:g} mm bins, as deposit_per_mm_cv)",
            y_label="deposit, mm³/mm",
        )
        for label, color, x, q in series:  # steps: one value per bin
            xx = np.repeat(np.concatenate([x, x[-1:] + b["bin_mm"]]) if len(x) else x, 2)[1:-1]
            ch.line(
                xx,
                np.repeat(q, 2),
                color,
                width=2.2 if label == "programmed" else 1.2,
                dash="6 3" if label == "programmed" else "",
                label=label,
            )
        return figure(900, 350, [ch])

    arc = np.asarray(deposit["arc"], bool)
    if s_range is not None:
        s_all = np.asarray(deposit["s_mm"], float)
        arc = arc & (s_all >= s_range[0]) & (s_all <= s_range[1])
    s = np.asarray(deposit["s_mm"], float)[arc]
    curves = [("programmed", "#555555", np.asarray(deposit["programmed_mm3_per_mm"], float)[arc])]
    if "uncompensated_mm3_per_mm" in deposit:
        curves.append(("constant feed", "#d62828", np.asarray(deposit["uncompensated_mm3_per_mm"], float)[arc]))
        curves.append(("compensated", "#2a9d8f", np.asarray(deposit["actual_mm3_per_mm"], float)[arc]))
    else:
        curves.append(("actual", "#d62828", np.asarray(deposit["actual_mm3_per_mm"], float)[arc]))
    smax = max(float(s.max()) if len(s) else 1.0, 1.0)
    smin = float(s.min()) if len(s) and s_range is not None else 0.0
    qmax = max(float(np.percentile(q, 99.0)) if len(q) else 1.0 for _, _, q in curves) * 1.15
    ch = Chart(
        64,
        40,
        800,
        260,
        (smin, smax),
        (0.0, qmax),
        title=title,
        x_label="programmed path length (arc on), mm",
        y_label="deposit, mm³/mm",
    )
    for k, (label, color, q) in enumerate(curves):
        ch.line(s, q, color, width=2.2 if k == 0 else 1.2, dash="6 3" if k == 0 else "", label=label)
    return figure(900, 350, [ch])
