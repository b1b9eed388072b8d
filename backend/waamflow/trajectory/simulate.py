"""Controller model: what the robot really does with a programmed polyline (GitHub issue 5).

Pipeline (each step a pure function on numpy data):

1. Exact stops at every arc ON/OFF switch, at dwells (ignition, interlayer) and at the ends — the
   study's full stops (robot-study.md, "What the robot did"): I/O between motions stops the
   advance run.
2. Corner blending between stops (`blend.blend_path`): d = min(CDIS, (CDIS/5 mm)·(d_min +
   v·apo_time), L_prev/2, L_next/2), tangent arc (KUKA) or parabola (ABB zone); corner caps from a_n, j_n and the turn
   rate (direction turns no faster than v/ρ, `profile.turn_radius_mm`); harder cuts
   on the arc-OFF travel after an arc-OFF stop (the catch-up, `profile.catchup`).
3. Path speed along arc length (`speedplan`): junction speeds, backward (slow-down limits) and
   forward (speed-up limits, per programmed speed: `RobotProfile.ramp_limits`) passes, one
   closed-form jerk-limited profile per span (one DOF).
4. Controller smoothing: the interpolated Cartesian set-points pass a moving-average (FIR) filter
   of length `smoothing_s` within each stop-to-stop block. This is the ramp smoothing / servo lag
   that makes the KRC2's acceleration take 0.144 s at 10 mm/s and 0.204 s at 40 mm/s
   (robot-study.md, identified T_init_accel) and makes corner errors grow with speed (0.8 mm at
   10 mm/s vs 1.8 mm at 40 mm/s on the 2.95° swiping corner): a block still starts and ends
   exactly at its programmed points, but corners are cut harder the faster they are taken.
5. Arc timing: the switch command is issued when the motion has stopped; the arc really turns ON
   / OFF `arc_on_delay_s` / `arc_off_delay_s` later; the next motion starts after
   `arc_switch_dwell_s` (+ ignition dwell). Wire feed is constant (or per zone, from its wire
   feed speed), so deposited volume accrues with time while the arc is ON (robot-study.md,
   "Set-up measured") and every slow-down puts more metal per mm.

Samples are computed on a fine grid (interpolation cycle / 3; the cycle itself beyond
MAX_FINE_SAMPLES, ≈ 2.8 h) for lengths and volumes and reported at the interpolation cycle (`fine`).
Units: mm, s, mm/s, mm³.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..core.errors import PlanningError
from ..core.moves import Moves
from .blend import BlendedPath, blend_path
from .fine import Timeline, arc_clock, corner_errors, row_norms, sample_blocks, timeline
from .profile import RobotProfile
from .simsamples import _attribute, _metrics, _trace
from .speedplan import SpanProfiles, Spans, plan_spans, profile_spans


@dataclass(frozen=True)
class SimOptions:
    """Run settings of one simulation (node params). Lengths mm, speeds mm/s, times s.

    cdis: blend distance ($APO.CDIS, or the zone radius with blend="zone"); 0 = exact stops.
    blend: "cdis" (KUKA arc), "zone" (ABB parabola) or "junction" (a G-code planner: exact path,
        junction speeds from the profile's junction_deviation_mm; a profile with one is always run so).
    speed_override: replaces the programmed speed of arc-ON segments when set.
    travel_speed: speed of arc-OFF moves that carry no speed (None = the profile's).
    segment_cap: (n_moves_points - 1,) extra speed cap per move segment (from kinematics), or None.
    ignition_dwell_s: standstill after each arc ignition when the zone has no `dwell` parameter.
    ignition_dwells_s: the dwell at every arc ignition in program order, as a program writes them
        (`run.program_settings`), or None (then `ignition_dwell_s` and the zones' `dwell`).
    controller: the controller family simulated ("kuka_krc", "abb_irc5", ...: reported only).
    wire_diameter_mm: when set, zones with a `wire_feed_speed` parameter (m/min) feed
        WFS·π·d²/4 instead of the constant wire_feed_mm3_s (volume still accrues with time).
    """

    cdis: float = 5.0
    blend: str = "cdis"
    wire_feed_mm3_s: float = 94.25
    speed_override: float | None = None
    interpolation_cycle_s: float | None = None
    travel_speed: float | None = None
    segment_cap: np.ndarray | None = None
    ignition_dwell_s: float = 0.0
    ignition_dwells_s: tuple[float, ...] | None = None
    controller: str = ""
    wire_diameter_mm: float | None = None


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """Simulated robot motion.

    metrics: name → value (see `METRIC_UNITS` for units).
    trace: sampled every interpolation cycle; keys t (s), x, y, z (mm), speed (mm/s), arc (bool),
        deviation (mm, actual point to programmed polyline), s (mm, actual arc length travelled),
        layer (int), section (int index into section_keys), inside (bool), volume (mm³, deposited
        since the start: cumulative), segment (int index into `deposit`'s per-segment arrays).
    programmed: (n, 3) programmed polyline, mm. programmed_arc: (n-1,) bool.
    blended: (m, 3) the blended geometric path (before controller smoothing), mm.
    deposit: per programmed segment (n-1,): length_mm, s_mm (programmed arc length at the segment
        start), programmed_mm3_per_mm, actual_mm3_per_mm, layer, section, arc.
    section_keys: section key of each section index. warnings: (message, layer, section) tuples.
    estimate: the closed-form cycle-time estimate beside the simulation (see `estimate`).
    corners: per blended vertex (k,): vertex index, interior_deg, error_mm (closest approach of
        the actual path to the vertex), min_speed_mm_s.
    profile: the robot profile used (JSON form; a fitted one from calibrate-robot).
    """

    metrics: dict[str, float]
    trace: dict[str, np.ndarray]
    programmed: np.ndarray
    programmed_arc: np.ndarray
    blended: np.ndarray
    deposit: dict[str, np.ndarray]
    section_keys: tuple[str, ...] = ()
    warnings: tuple[tuple[str, int | None, str | None], ...] = ()
    estimate: dict[str, float] = field(default_factory=dict)
    corners: dict[str, np.ndarray] = field(default_factory=dict)
    profile: dict = field(default_factory=dict)
    collisions: tuple = ()  # trajectory.collide.Collision, the first ones found (cell simulations)
    kinematics: dict = field(default_factory=dict)  # per-axis report, kinematics issues, the solved motion (run.py)
    options: "SimOptions | None" = None  # the settings simulated (simulate-robot: as read from the program)


METRIC_UNITS = {
    "total_time_s": "s",
    "programmed_length_mm": "mm",
    "actual_length_mm": "mm",
    "length_ratio": "",
    "arc_on_time_s": "s",
    "arc_off_lag_after_end_s": "s",
    "arc_on_length_mm": "mm",
    "deposited_volume_mm3": "mm³",
    "programmed_volume_mm3": "mm³",
    "max_deviation_mm": "mm",
    "mean_deviation_mm": "mm",
    "time_inside_s": "s",
    "time_outside_s": "s",
    "arc_off_time_inside_s": "s",
    "arc_on_time_outside_s": "s",
    "actual_length_outside_mm": "mm",
    "average_speed_mm_s": "mm/s",
    "stops": "",
    "blended_corners": "",
    "max_corner_error_mm": "mm",
    "min_corner_speed_mm_s": "mm/s",
    "positioner_e1_min_deg": "deg",
    "positioner_e1_max_deg": "deg",
    "positioner_e2_min_deg": "deg",
    "positioner_e2_max_deg": "deg",
    "positioner_max_step_deg": "deg",
    "collision_count": "",
    "collision_samples_checked": "",
    "collision_step_mm": "mm",
    "positioner_min_speed_cap_mm_s": "mm/s",
    "positioner_speed_capped_segments": "",
    "positioner_turn_in_place_s": "s",
    "axis_limit_stretches": "",
    "axis_speed_stretches": "",
    "max_wrist_step_deg": "deg",
}


@dataclass(frozen=True, eq=False)
class _Program:
    """Moves without zero-length segments, with resolved speeds, stops and standstill times."""

    points: np.ndarray
    speed: np.ndarray
    arc: np.ndarray
    inside: np.ndarray
    kind: np.ndarray
    layer: np.ndarray
    section: np.ndarray
    stop: np.ndarray  # (n,) exact stop at vertex
    standstill: np.ndarray  # (n,) dwell at vertex before moving on (s): waits + ignition, arc-switch dwell excluded
    switch: np.ndarray  # (n,) arc switches at vertex (incl. ON at the start, OFF at the end)
    src: np.ndarray  # (n-1,) index of each segment in the original Moves
    wire_rate: np.ndarray  # (n-1,) wire volume feed while the arc is ON, mm³/s
    pause: np.ndarray  # (n,) arc OFF and ON again at the vertex (zero-length arc-OFF move)
    ignite: np.ndarray  # (n,) part of the standstill after the arc ON command (ignition dwell), s


def blend_mode(profile: RobotProfile, opt: SimOptions) -> str:
    """The corner model simulated: "junction" for a G-code planner profile (junction deviation
    set: the planner's setting, the node's cdis / blend do not apply) or when the options ask for
    it (δ = the profile's; 0 = an exact stop at every corner), else the options' blend."""
    return "junction" if profile.junction_deviation_mm > 0 else opt.blend


def _ignition_dwell(moves: Moves, default_s: float, sequence: tuple[float, ...] | None = None) -> np.ndarray:
    """(n,) dwell (s) before moving on at each point: at every arc ignition the zone's `dwell`
    parameter (or `default_s` when the zone has none) — or, with `sequence`, the program's own
    dwell at each ignition in order; at the start of any other zone run its `dwell` parameter if
    it has one. A sequence whose length is not the toolpath's ignition count is a PlanningError."""
    n = len(moves.points)
    out = np.zeros(n)
    if n < 2:
        return out
    arc = np.asarray(moves.arc, bool)
    ignite = arc & ~np.concatenate([[False], arc[:-1]])
    zstart = np.ones(n - 1, dtype=bool)
    zstart[1:] = (moves.zone[1:] != moves.zone[:-1]) | (moves.section[1:] != moves.section[:-1])
    if sequence is not None and len(sequence) != int(ignite.sum()):
        raise PlanningError(
            f"the program writes {len(sequence)} ignition dwells but the toolpath has "
            f"{int(ignite.sum())} arc ignitions: connect the program made from this toolpath"
        )
    k = 0
    for i in np.flatnonzero((ignite | (zstart & arc))):
        params = moves.zone_params.get((int(moves.section[i]), int(moves.zone[i])), {})
        dw = params.get("dwell")
        if ignite[i] and sequence is not None:
            dw = sequence[k]
            k += 1
        elif dw is None and ignite[i]:
            dw = default_s
        out[i] += float(dw or 0.0)
    return out


def _prepare(moves: Moves, profile: RobotProfile, opt: SimOptions) -> _Program:
    P = np.asarray(moves.points, dtype=float)
    L = np.linalg.norm(np.diff(P, axis=0), axis=1)
    keep = L > 1e-6
    # fold dwells of dropped (zero-length) segments onto the kept start point
    kept_pts = np.concatenate([[0], np.flatnonzero(keep) + 1])
    owner = np.maximum.accumulate(np.where(np.concatenate([[True], keep]), np.arange(len(P)), 0))
    wait = np.zeros(len(P))
    np.add.at(wait, owner, np.asarray(moves.dwell_before, dtype=float))
    ignite = np.zeros(len(P))
    np.add.at(ignite, owner, _ignition_dwell(moves, opt.ignition_dwell_s, opt.ignition_dwells_s))
    wait, ignite = wait[kept_pts], ignite[kept_pts]
    standstill = wait + ignite
    src = np.flatnonzero(keep)
    pts = P[kept_pts]
    arc = np.asarray(moves.arc, dtype=bool)[src]
    speed = _speeds(moves, profile, opt, src)
    n = len(pts)
    switch = np.zeros(n, dtype=bool)
    if n >= 2:
        switch[1:-1] = arc[1:] != arc[:-1]
        switch[0] = arc[0]
        switch[-1] = arc[-1]
    # an arc-OFF move of zero length between two arc-ON moves (e.g. a layer change in place):
    # the arc goes OFF and ON again at that point (two switches, arc off during the standstill)
    dropped_off = np.flatnonzero(~keep & ~np.asarray(moves.arc, bool))
    pause_raw = np.zeros(len(P), dtype=bool)
    pause_raw[owner[dropped_off]] = True
    pause = pause_raw[kept_pts]
    if n >= 2:
        pause[1:-1] &= arc[:-1] & arc[1:]
        pause[0] = pause[-1] = False
    switch |= pause
    stop = switch | (standstill > 0)
    if n:
        stop[0] = stop[-1] = True
    rate = _wire_rate(moves, opt)[src]
    return _Program(
        pts,
        speed,
        arc,
        np.asarray(moves.inside, bool)[src],
        np.asarray(moves.kind)[src],
        np.asarray(moves.layer)[src],
        np.asarray(moves.section)[src],
        stop,
        standstill,
        switch,
        src,
        rate,
        pause,
        ignite,
    )


def _speeds(moves: Moves, profile: RobotProfile, opt: SimOptions, src: np.ndarray) -> np.ndarray:
    """The commanded speed of the kept move segments `src`: programmed (travel where none),
    the override on arc-ON ones, `opt.segment_cap`, within the profile's range."""
    travel = opt.travel_speed if opt.travel_speed is not None else profile.travel_speed
    speed = np.asarray(moves.speed, dtype=float)[src].copy()
    arc = np.asarray(moves.arc, dtype=bool)[src]
    speed = np.where(np.isnan(speed) | (speed <= 0), travel, speed)
    if opt.speed_override is not None:
        speed = np.where(arc, float(opt.speed_override), speed)
    if opt.segment_cap is not None:
        speed = np.minimum(speed, np.asarray(opt.segment_cap, dtype=float)[src])
    return np.clip(speed, 1e-3, profile.max_speed)


def program_speeds(moves: Moves, profile: RobotProfile, opt: SimOptions) -> np.ndarray:
    """The speed of every kept (non-zero-length) move segment that `simulate` runs. It is the
    only place `opt.segment_cap` enters a simulation: two options that differ only in their caps
    and give the same program speeds to the bit simulate the same (`run.simulate_program` runs
    the controller in a worker on the positioner's caps while the IK gives the arm's)."""
    P = np.asarray(moves.points, dtype=float)
    src = np.flatnonzero(np.linalg.norm(np.diff(P, axis=0), axis=1) > 1e-6)
    return _speeds(moves, profile, opt, src)


def _wire_rate(moves: Moves, opt: SimOptions) -> np.ndarray:
    """(n-1,) mm³/s per move segment: the zone's `wire_feed_speed` (m/min) × π·d²/4 where the zone
    sets one and `wire_diameter_mm` is given, else the constant `wire_feed_mm3_s`."""
    rate = np.full(len(moves.points) - 1, float(opt.wire_feed_mm3_s))
    if not opt.wire_diameter_mm or not moves.zone_params:
        return rate
    area = np.pi * opt.wire_diameter_mm**2 / 4.0
    for (sec, zone), params in moves.zone_params.items():
        wfs = params.get("wire_feed_speed")
        if wfs:
            m = (moves.section == sec) & (moves.zone == zone)
            rate[m] = float(wfs) * 1000.0 / 60.0 * area  # m/min → mm/s, × wire area
    return rate


def _catchup_vertices(prog: _Program, catchup: float) -> np.ndarray | None:
    """(n,) catch-up fraction per vertex: `catchup` at the interior vertices of arc-OFF blocks that
    start at an arc switch (the travel after an arc-OFF stop), 0 elsewhere; None when off."""
    n = len(prog.points)
    if catchup <= 0 or n < 3:
        return None
    stops = np.flatnonzero(prog.stop)  # stop[0] is always set
    seg_arc = np.concatenate([prog.arc, [True]])  # the segment leaving each vertex
    starts_off = prog.switch & ~seg_arc  # arc-OFF stop: the block after it travels arc OFF
    owner = stops[np.cumsum(prog.stop) - 1]  # last stop at or before each vertex
    out = np.where(starts_off[owner] & ~prog.stop, float(min(catchup, 1.0)), 0.0)
    return out


def _check_points(prog: _Program, moves: Moves) -> None:
    n = len(prog.points)
    if n < 2:
        raise PlanningError("the program has no motion to simulate (fewer than two distinct points)")
    if not np.all(np.isfinite(prog.points)):
        bad = int(np.flatnonzero(~np.isfinite(prog.points).all(axis=1))[0])
        seg_i = min(bad, n - 2)
        sec = int(prog.section[seg_i])
        raise PlanningError(
            "toolpath point is not finite",
            layer=int(prog.layer[seg_i]),
            section=moves.section_keys[sec] if 0 <= sec < len(moves.section_keys) else None,
        )


def _plan_motion(
    prog: _Program, profile: RobotProfile, opt: SimOptions, mode: str, progress: Callable[[float, str], None] | None
) -> tuple[BlendedPath, np.ndarray, Spans, SpanProfiles]:
    """Steps 2-3 of the model: the blended path, the exact stops, the spans and their speed profiles."""
    a, j = profile.path_acc, profile.path_jerk
    a_dec, j_dec = profile.dec
    if mode == "junction":  # a G-code planner: exact path, junction speeds from δ and the acceleration
        path = blend_path(
            prog.points,
            prog.speed,
            prog.stop,
            mode=mode,
            distance=profile.junction_deviation_mm,
            normal_acc=profile.path_acc,
        )
    else:
        path = blend_path(
            prog.points,
            prog.speed,
            prog.stop,
            mode=mode,
            distance=opt.cdis,
            apo_time_s=profile.apo_time_s,
            apo_min_mm=profile.apo_min_mm,
            normal_acc=profile.normal_acc,
            normal_jerk=profile.normal_jerk,
            turn_radius=profile.turn_radius_mm,
            catchup=_catchup_vertices(prog, profile.catchup),
        )
    stop = prog.stop | (path.cap <= 0.0)  # a corner that cannot be blended (CDIS 0) is an exact stop
    spans = plan_spans(
        path,
        prog.speed,
        stop,
        a,
        j,
        a_dec,
        j_dec,
        limits=profile.ramp_limits,
        lookahead=profile.lookahead_blocks if mode == "junction" else 0,
    )
    if progress:
        progress(0.1, f"{len(spans.s0)} spans planned")
    prof = profile_spans(spans)
    if progress:
        progress(0.5, "speed profiles done")
    return path, stop, spans, prof


def simulate(
    moves: Moves,
    profile: RobotProfile,
    opt: SimOptions = SimOptions(),
    progress: Callable[[float, str], None] | None = None,
) -> SimulationResult:
    """Simulate the controller on a flat move list. See the module docstring for the model."""
    prog = _prepare(moves, profile, opt)
    _check_points(prog, moves)
    n = len(prog.points)
    dt = opt.interpolation_cycle_s or profile.interpolation_cycle_s
    mode = blend_mode(profile, opt)
    path, stop, spans, prof = _plan_motion(prog, profile, opt, mode, progress)
    tl = timeline(
        spans,
        prof,
        prog.standstill,
        (prog.switch | prog.pause).astype(float),
        dt,
        profile.smoothing_s,
        profile.arc_switch_dwell_s,
    )
    t, xyz, s_f, blk = sample_blocks(tl, spans, prof, path, progress)
    # path length and speed along the path come from the motion itself; the transverse backlash
    # transient (a fraction of a mm that decays in ~0.1 s) shows in positions and deviation only
    # — the study's measured raster length (386.97 mm for 387.91 programmed) has no such excess
    step = row_norms(np.diff(xyz, axis=0))
    if mode == "cdis" and (profile.backlash_start_mm or profile.backlash_end_mm):
        xyz = _backlash(xyz, t, blk, tl, prog, spans, profile)
    arc_time = arc_clock(_arc_intervals(prog, tl, profile))
    sm = _attribute(prog, path, tl, t, xyz, s_f, blk, step, arc_time)
    # the arc-OFF lag after the last motion: metal still lands at the end point (volume), but the
    # cycle (total_time_s) ends with the motion, so it is reported apart, not as arc-on time
    burnback = arc_time(np.inf) - arc_time(tl.t_end)
    rate = prog.wire_rate  # (n-1,) mm³/s while the arc burns on each segment
    vol_samples = rate[sm.seg] * sm.arc_w
    vol_samples[-1] += rate[sm.seg[-1]] * burnback
    seg_len = row_norms(np.diff(prog.points, axis=0))
    total_time = float(tl.t_end)
    metrics = _metrics(prog, path, stop, sm, total_time, burnback, vol_samples, seg_len)
    dtf = np.diff(t)
    spd = np.concatenate([sm.step / np.where(dtf > 0, dtf, 1.0), [0.0]])  # fine-grid speed, mm/s
    corners = corner_errors(prog.points, path, sm.xyz, sm.seg, spd, prog.speed, blk)
    err = corners["error_mm"]
    metrics["max_corner_error_mm"] = float(np.nanmax(err)) if np.isfinite(err).any() else 0.0
    vol = np.zeros(n - 1)
    np.add.at(vol, sm.seg, vol_samples)
    deposit = {
        "length_mm": seg_len,
        "s_mm": np.concatenate([[0.0], np.cumsum(seg_len)[:-1]]),
        "programmed_mm3_per_mm": np.where(prog.arc, rate / prog.speed, 0.0),
        "actual_mm3_per_mm": vol / seg_len,
        "layer": prog.layer,
        "section": prog.section,
        "arc": prog.arc,
    }
    trace = _trace(prog, sm, spd, vol_samples, total_time, dt, arc_time)
    if progress:
        progress(1.0, "simulation done")
    return SimulationResult(
        metrics,
        trace,
        prog.points,
        prog.arc,
        path.points,
        deposit,
        tuple(moves.section_keys),
        corners=corners,
        profile=profile.to_json(),
    )


def _arc_intervals(prog: _Program, tl: Timeline, profile: RobotProfile) -> list[tuple[float, float]]:
    """[(t_on, t_off)] when the arc is really burning. At a stop the standstill runs: arc OFF
    command (as soon as the motion has stopped) → waits (interlayer dwell) → arc ON command →
    switch dwell → ignition dwell → motion."""
    iv = []
    on_at = None
    for b in range(tl.nb):
        v = tl.start_vertex[b]
        off_cmd = tl.T0[b] - tl.gap_before[b]  # motion stopped
        on_cmd = tl.T0[b] - prog.ignite[v] - profile.arc_switch_dwell_s
        if prog.pause[v] and on_at is not None:
            iv.append((on_at, off_cmd + profile.arc_off_delay_s))
            on_at = on_cmd + profile.arc_on_delay_s
        elif prog.switch[v]:
            seg_arc = prog.arc[min(v, len(prog.arc) - 1)]
            if seg_arc and on_at is None:
                on_at = on_cmd + profile.arc_on_delay_s
            elif not seg_arc and on_at is not None:
                iv.append((on_at, off_cmd + profile.arc_off_delay_s))
                on_at = None
    if on_at is not None:
        end = tl.T0[-1] + tl.block_len[-1]
        iv.append((on_at, end + profile.arc_off_delay_s))
    return iv


def _backlash(
    xyz: np.ndarray, t: np.ndarray, blk: np.ndarray, tl: Timeline, prog: _Program, spans: Spans, profile: RobotProfile
) -> np.ndarray:
    """Transverse offset at block starts/ends (study: +0.2 / −0.1 mm on a line at 40 mm/s),
    decaying exponentially with time constant smoothing_s/2 (horizontal normal of the segment)."""
    tau_c = max(profile.smoothing_s / 2, 1e-3)
    nseg = len(prog.points) - 1
    end_vertex = spans.vertex_after[tl.block_end]
    first_seg = np.minimum(tl.start_vertex, nseg - 1)
    last_seg = np.maximum(end_vertex - 1, 0)

    def normals(seg):
        u = prog.points[seg + 1] - prog.points[seg]
        nrm = np.column_stack([-u[:, 1], u[:, 0], np.zeros(len(u))])
        ln = np.linalg.norm(nrm, axis=1, keepdims=True)
        return np.where(ln > 1e-12, nrm / np.where(ln > 1e-12, ln, 1.0), 0.0)

    tloc = t - tl.T0[blk]
    age_end = tl.block_len[blk] - tloc
    out = xyz.copy()
    n_first, n_last = normals(first_seg), normals(last_seg)
    for amp, age, nrm in ((profile.backlash_start_mm, tloc, n_first), (profile.backlash_end_mm, age_end, n_last)):
        m = np.flatnonzero(age < 8 * tau_c)  # e^-8 < 0.04 %: the transient is over
        out[m] += (amp * np.exp(-np.clip(age[m], 0, None) / tau_c))[:, None] * nrm[blk[m]]
    return out
