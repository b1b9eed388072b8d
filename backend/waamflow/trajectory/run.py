"""One call from a flat move list to a full simulation: kinematics → controller → estimate → report.

`simulate_program` is what the simulate-robot node calls; `simulation_json` and `deposit_csv`
build its artifacts (the contract's `<node>.simulation.json`, `<node>.trace.csv` via
`calibrate.trace_csv`, and `<node>.deposit.csv`): they live in `trajectory.runreport` (the
reporting, split from this module's solving for issue 27) and are importable from here.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from ..core.moves import Moves
from .kinematics import REACH_TOL_MM, CellFrames, find_issues, load_arm, solve_path, solve_samples
from .profile import RobotProfile
from .runreport import _axes_report as _axes_report
from .runreport import _clean as _clean
from .runreport import _positioner_report as _positioner_report
from .runreport import deposit_csv as deposit_csv
from .runreport import simulation_json as simulation_json
from .simulate import SimOptions, SimulationResult, simulate
from .simworkers import estimate_result, estimate_task, simulate_task, speculative

if TYPE_CHECKING:  # cell.py imports coal and pinocchio where used
    from .cell import Cell

MAX_WARNINGS_PER_KIND = 20

# Controller family of each program dialect: how its blend setting is read and which corner
# curve it runs (blend.blend_path modes), and the robot profile simulated when the recipe names none.
# A KRL program written for KUKA.ArcTech Basic 3.x (ArcMainNG, a KSS 8.x package) runs on a KR C4.
CONTROLLER_FAMILIES = {
    "krl": {"controller": "kuka_krc", "blend": "cdis", "robot_profile": "kuka_kr100ha_krc2"},
    "krl_krc4": {"controller": "kuka_krc4", "blend": "cdis", "robot_profile": "kuka_kr100ha_krc4"},
    "rapid": {"controller": "abb_irc5", "blend": "zone", "robot_profile": "abb_irb4600_irc5"},
    "gcode": {"controller": "gcode_planner", "blend": "junction", "robot_profile": "gcode_planner"},
}
_KRC4_ARCTECH = re.compile(r"\bArcMainNG\b|\bstArcDat_T\b", re.I)
_GCODE_MOTION = re.compile(r"^\s*(G0?[01])(?![0-9])([^;(\n]*)", re.I | re.M)

_KRL_CDIS = re.compile(r"^\s*\$APO\.CDIS\s*=\s*([0-9.]+)", re.I | re.M)
_RAPID_ZONE = re.compile(r"zonedata\s+zw\s*:=\s*\[\s*FALSE\s*,\s*([0-9.]+)", re.I)
_RAPID_ZW_USED = re.compile(r"^\s*(?:MoveL|MoveC|ArcL|ArcC)\b[^;]*,\s*zw\s*,", re.I | re.M)
_DWELL_COMMENT = re.compile(r"^\s*(?:;-?|!)\s*ignition dwell\s+([0-9.]+)\s*s\b", re.I)
_DWELL_HIT = re.compile("ignition dwell", re.I)
_ASCII_BREAKS = "\n\r\x0b\x0c\x1c\x1d\x1e"  # where str.splitlines cuts an ASCII text
_ASCII_BREAK = re.compile(f"[{_ASCII_BREAKS}]")
_DWELL_CODE = re.compile(
    r"^\s*(WAIT\s+SEC\s+([0-9.]+)|G4\s+P([0-9.]+))\s*(?:;|\()\s*ignition dwell(?:\s+([0-9.]+)\s*s)?", re.I
)


def program_settings(fmt: str, files: dict[str, str]) -> dict:
    """What a program as written declares about its motion: the controller family (from the
    dialect), the blend distance (KRL `$APO.CDIS=d`; RAPID the `zw` zonedata radius, 0 when no
    motion uses it — every point `fine`; G-code: none, a G-code controller's blending is a machine
    setting) and the dwell at every arc ignition in program order (KRL `WAIT SEC t ; ignition
    dwell`, ArcTech `;- ignition dwell t s (Strike.StartTime)`, RAPID `! ignition dwell t s
    (seamdata ign_move_delay)`, G-code `G4 P… ; ignition dwell t s`). Files are read in the
    program's own order (main program first, then its parts).

    Returns {"controller", "blend" (mode or None), "blend_distance_mm" (or None), "robot_profile"
    (or None), "ignition_dwells_s" (tuple)}. A dialect without a family is a ValueError.
    """
    if fmt not in CONTROLLER_FAMILIES or fmt == "krl_krc4":
        raise ValueError(f"no controller family for {fmt!r} programs (known: krl, rapid, gcode)")
    texts = list(files.values())
    fam = CONTROLLER_FAMILIES[fmt]
    if fmt == "krl" and any(_KRC4_ARCTECH.search(t) for t in texts):
        fam = CONTROLLER_FAMILIES["krl_krc4"]
    dist = None
    if fmt == "krl":
        vals = [float(m) for t in texts for m in _KRL_CDIS.findall(t)]
        if len(set(vals)) > 1:
            raise ValueError(
                f"the KRL program sets $APO.CDIS to several values {sorted(set(vals))}: one per program is simulated"
            )
        dist = vals[0] if vals else 0.0
    elif fmt == "rapid":
        zone = next((float(m.group(1)) for t in texts if (m := _RAPID_ZONE.search(t))), None)  # the first
        used = any(_RAPID_ZW_USED.search(t) for t in texts)
        dist = zone if (zone is not None and used) else 0.0
    ms = fmt == "gcode" and any("dwell G4 P in milliseconds" in t or "dwell_units=ms" in t for t in texts)
    dwells = []
    for t in texts:
        for line in _dwell_lines(t):
            m = _DWELL_COMMENT.match(line)
            if m:
                dwells.append(float(m.group(1)))
                continue
            m = _DWELL_CODE.match(line)
            if m:
                if m.group(4):
                    dwells.append(float(m.group(4)))
                elif m.group(2):
                    dwells.append(float(m.group(2)))
                else:
                    dwells.append(float(m.group(3)) / (1000.0 if ms else 1.0))
    out = {
        "controller": fam["controller"],
        "blend": fam["blend"],
        "blend_distance_mm": dist,
        "robot_profile": fam["robot_profile"],
        "ignition_dwells_s": tuple(dwells),
    }
    if fmt == "gcode":
        out["travel_speed_mm_s"], out["rapid_travel"] = _gcode_travel(texts)
    return out


def _dwell_lines(text: str) -> list[str]:
    """The lines of `text` (as str.splitlines cuts them) that say "ignition dwell" (any case): the
    only ones the dwell patterns can match. A program has one per ignition among up to hundreds
    of thousands of lines, so an ASCII text is searched as a whole, not line by line."""
    if not text.isascii():  # lower() could change lengths: line by line
        return [line for line in text.splitlines() if _DWELL_HIT.search(line)]
    low = text.lower()
    out = []
    lo = 0
    pos = low.find("ignition dwell")
    while pos >= 0:
        start = max(text.rfind(c, lo, pos) for c in _ASCII_BREAKS) + 1
        m = _ASCII_BREAK.search(text, pos)
        lo = m.start() if m else len(text)
        out.append(text[start:lo])
        pos = low.find("ignition dwell", lo)
    return out


def _gcode_travel(texts: list[str]) -> tuple[float | None, bool]:
    """(travel feed mm/s or None, travel by G0 without F): the F the program writes on its G0
    lines (Marlin-style travel, F in force), else whether its travel is G0 at the machine's rapid
    rate (LinuxCNC, generic: G0 carries no F). Feeds in mm/min unless the `waamflow-post` header
    says feed_units=mm/s."""
    per_s = any("feed_units=mm/s" in t for t in texts)
    feeds, bare = [], False
    for t in texts:
        for m in _GCODE_MOTION.finditer(t):
            if m.group(1).upper() not in ("G0", "G00"):
                continue
            f = re.search(r"\bF\s*([0-9.]+)", m.group(2), re.I)
            if f:
                feeds.append(float(f.group(1)))
            else:
                bare = True
    if feeds:
        return float(np.median(feeds)) / (1.0 if per_s else 60.0), False
    return None, bare


MAX_ISSUES = 1000  # stretches listed in simulation.json's kinematics_issues
SPECULATE_MIN_POINTS = 2000  # moves from which the controller simulation is worth a worker (`simulate_program`)


@dataclass(frozen=True)
class KinematicsOptions:
    """description: URDF name in data/robots ("" = the profile's) or None with urdf_text given.
    step_mm: IK sample spacing along the programmed path. frames: cell frames (mm, deg)."""

    description: str = ""
    urdf_text: str | None = None
    tcp_offset_mm: tuple[float, float, float] | None = None
    frames: CellFrames = CellFrames()
    step_mm: float = 5.0
    cell: Cell | None = None  # when set, frames come from it and the policy
    positioner_policy: str = "fixed"
    max_tilt_deg: float = 30.0  # min-motion: torch lean from vertical tolerated before the positioner moves
    collisions: bool = True  # with a cell: coal collision checks along the path (trajectory.collide)
    collision_step_mm: float = 20.0  # programmed path between two checked samples
    step_deg: float = 1.0  # with a cell: most positioner / torch-axis turn between two IK samples
    max_lean_deg: float = 15.0  # auto: torch lean from the layer normal allowed
    flat_tol_deg: float = 5.0  # auto: layer normal off vertical allowed (flat-position tolerance)


@dataclass
class _Kin:
    """What the kinematics add to a simulation (`_kinematics`)."""

    cap: np.ndarray  # (n-1,) path speed cap per segment, mm/s
    metrics: dict[str, float]
    report: dict
    warnings: list[tuple[str, int | None, str | None]]
    collisions: tuple = ()
    moves: Moves | None = None  # the moves simulated (turns in place added as dwells)


@dataclass
class _Solved:
    """The IK along the path (`_solve`) and, with a cell, the positioner's angles and caps."""

    arm: Any
    ks: Any
    speed: np.ndarray
    warnings: list[tuple[str, int | None, str | None]]
    sim_moves: Moves
    ang: np.ndarray | None = None  # (n, axes) positioner angles at the programmed points
    ang_c: np.ndarray | None = None  # (k, axes) at the IK samples
    pos_cap: np.ndarray | None = None
    pos_metrics: dict[str, float] = field(default_factory=dict)
    pos_issues: list[dict] = field(default_factory=list)
    plan_report: dict | None = None


def _solve(
    moves: Moves,
    profile: RobotProfile,
    opt: SimOptions,
    kin: KinematicsOptions,
    progress: Callable[[float, str], None] | None,
    before_ik: Callable[[Moves, np.ndarray | None], None] | None = None,
) -> _Solved:
    """IK along the path: on the programmed polyline (arm only), or with a cell on coordinated
    samples in the world, the positioner planned by its policy first. before_ik(moves simulated,
    positioner speed caps or None): called once both are known, before the IK."""
    if progress:
        progress(0.02, "inverse kinematics")
    desc = kin.description or profile.description
    home = getattr(kin.cell, "robot_home_deg", None) if kin.cell is not None else None
    arm = load_arm(
        desc or "robot.urdf", kin.tcp_offset_mm or profile.tcp_offset_mm, urdf_text=kin.urdf_text, home_deg=home
    )
    speed = np.where(np.isnan(moves.speed), opt.travel_speed or profile.travel_speed, moves.speed)
    if opt.speed_override is not None:
        speed = np.where(moves.arc, opt.speed_override, speed)
    ik_progress = (lambda f: progress(0.02 + 0.3 * f, "inverse kinematics")) if progress else None
    if kin.cell is None:
        if before_ik is not None:
            before_ik(moves, None)
        ks = solve_path(arm, moves.points, moves.tool_axis, kin.frames, step_mm=kin.step_mm, progress=ik_progress)
        return _Solved(arm, ks, speed, [], moves)
    from .cell import coordinated_samples, plan_positioner, positioner_caps

    cell: Any = kin.cell
    warnings: list[tuple[str, int | None, str | None]] = []
    axes = moves.tool_axis
    if kin.positioner_policy == "auto":
        if progress:
            progress(0.01, "planning the positioner and torch (auto)")
        plan = _auto_plan(kin, arm, moves)
        ang, clipped = plan.angles, np.zeros(len(moves.points), bool)
        axes = plan.tool_axis
        plan_report = plan.report(_auto_limits(kin))
    else:
        ang, clipped = plan_positioner(cell, moves, kin.positioner_policy, kin.max_tilt_deg)
        plan_report = None
        warnings.extend(
            _flat_warnings(cell, moves, kin.flat_tol_deg, ang if kin.positioner_policy == "gravity" else None)
        )
    s_c, xyz_c, ax_c, seg_c, ang_c = coordinated_samples(
        cell, moves.points, axes, ang, step_mm=kin.step_mm, step_deg=kin.step_deg
    )
    base = cell.robot_base
    frames = CellFrames(base_xyz_mm=tuple(base.xyz_mm), base_yaw_deg=base.yaw_deg)
    pos_cap, turn_s = positioner_caps(cell, moves.points, ang)
    # a turn on a zero-length move (in place) is a standstill the positioner needs
    sim_moves = moves
    still = (moves.segment_lengths <= 1e-6) & (turn_s > 0)
    if still.any():
        dwell = np.asarray(moves.dwell_before, float).copy()
        dwell[np.flatnonzero(still)] += turn_s[still]
        sim_moves = replace(moves, dwell_before=dwell)
    if before_ik is not None:
        before_ik(sim_moves, pos_cap)
    ks = solve_samples(arm, s_c, xyz_c, seg_c, ax_c, len(moves.points) - 1, frames, progress=ik_progress)
    pos_metrics, pos_issues = _positioner_report(cell, moves, ang, clipped, pos_cap, turn_s, speed)
    return _Solved(arm, ks, speed, warnings, sim_moves, ang, ang_c, pos_cap, pos_metrics, pos_issues, plan_report)


_ISSUE_TEXT = {
    "unreachable": "target unreachable",
    "joint_limit": "joint limit reached",
    "near_singular": "near-singular arm configuration",
    "joint_speed": "joint speed limit",
    "axis_limit": "positioner axis limit",
    "axis_speed": "positioner axis speed limit",
}


def _issue_warnings(issues: list[dict]) -> tuple[list[tuple[str, int | None, str | None]], dict[str, int]]:
    """One warning per stretch (MAX_WARNINGS_PER_KIND of each kind, then how many more) and the
    number of stretches of each kind."""
    warnings: list[tuple[str, int | None, str | None]] = []
    counts: dict[str, int] = {}
    for it in issues:
        counts[it["kind"]] = counts.get(it["kind"], 0) + 1
        if counts[it["kind"]] > MAX_WARNINGS_PER_KIND:
            continue
        detail = f"; {it['detail']}" if it["detail"] else ""
        warnings.append(
            (
                f"{_ISSUE_TEXT[it['kind']]} over s = {it['s_from']:.1f}..{it['s_to']:.1f} mm "
                f"({it['count']} IK samples){detail}",
                it["layer"],
                it["section"],
            )
        )
    for kind, c in counts.items():
        if c > MAX_WARNINGS_PER_KIND:
            warnings.append((f"{c - MAX_WARNINGS_PER_KIND} more '{kind}' stretches not listed", None, None))
    return warnings, counts


def _kinematics(
    moves: Moves,
    profile: RobotProfile,
    opt: SimOptions,
    kin: KinematicsOptions,
    progress: Callable[[float, str], None] | None,
    before_ik: Callable[[Moves, np.ndarray | None], None] | None = None,
) -> _Kin:
    """IK, positioner, collisions: the speed caps, figures, report and warnings they add
    (before_ik: see `_solve`)."""
    sv = _solve(moves, profile, opt, kin, progress, before_ik)
    ks, arm, speed = sv.ks, sv.arm, sv.speed
    cell: Any = kin.cell
    warnings = list(sv.warnings)
    pos_metrics = dict(sv.pos_metrics)
    collision_list: tuple = ()
    if cell is not None and kin.collisions and sv.ang_c is not None:
        if progress:
            progress(0.33, "collision checks")
        collisions = _cell_collisions(kin, arm, ks, moves, sv.ang_c)
        pos_metrics.update(
            {
                "collision_count": float(collisions[0]),
                "collision_samples_checked": float(collisions[2]),
                "collision_step_mm": float(kin.collision_step_mm),
            }
        )
        collision_list = tuple(collisions[1])
        for c in collision_list[:MAX_WARNINGS_PER_KIND]:
            warnings.append(
                (
                    f"collision {c.bodies[0]} / {c.bodies[1]} at s = {c.s_mm:.1f} mm "
                    f"(point {c.point_mm[0]:.1f}, {c.point_mm[1]:.1f}, {c.point_mm[2]:.1f} mm)",
                    c.layer,
                    c.section,
                )
            )
    issues = find_issues(ks, arm, moves.layer, moves.section, moves.section_keys, speed) + sv.pos_issues
    issue_warnings, counts = _issue_warnings(issues)
    warnings.extend(issue_warnings)
    cap = ks.segment_cap if sv.pos_cap is None else np.minimum(ks.segment_cap, sv.pos_cap)
    finite = np.isfinite(ks.segment_cap)
    metrics = {
        "ik_samples": float(len(ks.s)),
        "ik_max_position_error_mm": float(ks.reach_err.max()),
        "ik_min_singular_value": float(ks.sigma_min.min()),
        "joint_speed_capped_segments": float(np.count_nonzero(ks.segment_cap < speed)),
        "min_joint_speed_cap_mm_s": float(ks.segment_cap[finite].min()) if finite.any() else math.inf,
    }
    for kind in ("unreachable", "joint_limit", "near_singular", "joint_speed") + (
        ("axis_limit", "axis_speed") if cell is not None else ()
    ):
        metrics[f"{kind}_stretches"] = float(counts.get(kind, 0))
    metrics.update(pos_metrics)
    dq = np.abs(np.diff(ks.q, axis=0))
    if len(dq):
        metrics["max_wrist_step_deg"] = float(np.degrees(dq[:, 3:].max(initial=0.0)))
    report: dict = {"axes": _axes_report(arm, ks, cap, speed, cell, sv.ang, moves), "issues": issues[:MAX_ISSUES]}
    if cell is not None:
        if sv.plan_report is not None:
            report["positioner_plan"] = sv.plan_report
            warnings.extend(_plan_warnings(sv.plan_report))
        report["motion"] = {
            "s": ks.s,
            "q": ks.q,
            "positioner_deg": sv.ang_c,
            "cell": cell.model_dump(mode="json"),
            "unreachable": ks.reach_err > REACH_TOL_MM,
        }
    return _Kin(cap, metrics, report, warnings, collision_list, sv.sim_moves)


def _plan_warnings(plan_report: dict) -> list[tuple[str, int | None, str | None]]:
    """A warning for each layer the `auto` plan could not take at its gravity angles."""
    return [
        (
            f"auto positioner plan: {row['stage']} ({row['why']}); E = "
            f"{', '.join(f'{v:.1f}' for v in row['e_deg'])}°, torch lean "
            f"{row['lean_deg']:g}°, layer {row['tilt_deg']:.1f}° off flat",
            row["layer"],
            None,
        )
        for row in plan_report["layers"]
        if row["stage"] != "gravity"
    ]


def simulate_program(
    moves: Moves,
    profile: RobotProfile,
    opt: SimOptions = SimOptions(),
    kin: KinematicsOptions | None = None,
    progress: Callable[[float, str], None] | None = None,
    strategies: tuple[str, ...] | None = None,
    submit: Callable[[Callable[[Any], Any], Any], Any] | None = None,
) -> SimulationResult:
    """Kinematics (optional: speed caps + warnings), controller simulation, closed-form estimate
    (strategies: each section's strategy, `estimate.section_strategies`, for the time model's
    per-family entries; None = the generic ones).

    submit: `Context.submit` (fn, item) → Future | None. With it, the controller simulation is
    started in a worker as soon as the moves and the positioner's speed caps are known, while
    this process solves the IK (`simworkers.speculative`); it is taken when the arm's joint speed caps
    leave every program speed as it was (a WAAM path at weld speed is far from them), else
    simulated again here on the capped speeds. The result is the same either way."""
    k = None
    sim_moves = moves
    started: list[tuple[Moves, SimOptions, Any]] = []
    travel = opt.travel_speed or profile.travel_speed
    est_task = (moves, profile.time_model, travel, strategies)
    est_fut: list[Any] = []

    def before_ik(ik_moves: Moves, pos_cap: np.ndarray | None) -> None:
        if submit is None:
            return
        spec_opt = replace(opt, segment_cap=pos_cap)
        fut = submit(simulate_task, (ik_moves, profile, spec_opt))
        if fut is not None:
            started.append((ik_moves, spec_opt, fut))
            if profile.time_model:  # the closed-form estimate needs no kinematics either
                est_fut.append(submit(estimate_task, est_task))

    if kin is not None and len(moves.points) >= 2:
        speculate = submit is not None and len(moves.points) >= SPECULATE_MIN_POINTS
        k = _kinematics(moves, profile, opt, kin, progress, before_ik if speculate else None)
        opt = replace(opt, segment_cap=k.cap)
        sim_moves = k.moves or moves
    res = speculative(started, sim_moves, profile, opt)
    if res is None:
        res = simulate(
            sim_moves,
            profile,
            opt,
            progress=(lambda f, m: progress(0.35 + 0.65 * f, m)) if progress and kin is not None else progress,
        )
    est = estimate_result(est_fut[0] if est_fut else None, est_task) if profile.time_model else None
    estimate = {}
    if est is not None:
        estimate = {
            "total_time_s": est.total_time_s,
            "passes": float(est.passes),
            "error_vs_simulation_pct": 100.0
            * (est.total_time_s - res.metrics["total_time_s"])
            / max(res.metrics["total_time_s"], 1e-9),
        }
    metrics = dict(res.metrics)
    if k is not None:
        metrics.update(k.metrics)
    return replace(
        res,
        metrics=metrics,
        warnings=tuple(k.warnings if k else ()),
        estimate=estimate,
        collisions=k.collisions if k else (),
        kinematics=k.report if k else {},
    )


def _auto_limits(kin: KinematicsOptions):
    from .cellplan import AutoLimits

    return AutoLimits(max_lean_deg=kin.max_lean_deg, flat_tol_deg=kin.flat_tol_deg)


def _auto_plan(kin: KinematicsOptions, arm, moves: Moves):
    """The `auto` plan (trajectory.cellplan); a plan that fails is a PlanningError naming the
    layer, the best compromise and the cell changes verified to work."""
    from ..core.errors import PlanningError
    from .cellplan import plan_auto

    cell = kin.cell
    if cell is None:
        raise ValueError("the auto positioner policy needs a cell")
    plan = plan_auto(
        cell,
        moves,
        arm,
        _auto_limits(kin),
        step_mm=kin.step_mm,
        step_deg=kin.step_deg,
        collision_step_mm=kin.collision_step_mm,
        collisions=kin.collisions,
    )
    if not plan.ok:
        raise PlanningError(auto_failure_text(cell, plan), layer=(plan.failed or {}).get("layer"))
    return plan


def auto_failure_text(cell, plan) -> str:
    """The `auto` failure in one message: what fails where, and what would work (verified)."""
    msg = f"cell {cell.name}, positioner policy auto: {plan.failed['message']}"
    if plan.suggestions:
        msg += "; verified to work: " + "; or ".join(s["text"] for s in plan.suggestions)
    else:
        msg += "; no riser, longer torch, base move or 2-axis positioner tried made every layer work"
    return msg


def _flat_warnings(
    cell, moves: Moves, tol_deg: float = 5.0, gravity: np.ndarray | None = None
) -> list[tuple[str, int | None, str | None]]:
    """Layers that even the gravity angles leave leaning more than tol_deg off flat (the lean this
    positioner cannot remove: a 1-axis positioner and a part leaning about the other axis, or an
    axis limit): one warning with the layers and the largest lean. gravity: the `gravity` policy's
    angles when the caller has them (None: planned here)."""
    from .cell import plan_positioner, to_world

    if cell.axes == 0 or len(moves.points) < 2:
        return []
    ang = plan_positioner(cell, moves, "gravity")[0] if gravity is None else gravity
    _, w = to_world(cell, moves.points, moves.tool_axis, ang)
    lean = np.degrees(np.arccos(np.clip(-w[:, 2] / np.maximum(np.linalg.norm(w, axis=1), 1e-12), -1.0, 1.0)))
    arc = np.asarray(moves.arc, bool)
    seg_lean = np.maximum(lean[:-1], lean[1:])
    uniq, inv = np.unique(np.asarray(moves.layer)[arc], return_inverse=True)
    most = np.zeros(len(uniq))
    np.fmax.at(most, inv.ravel(), seg_lean[arc])  # per layer the largest lean (0 at least)
    per: dict[int, float] = dict(zip(uniq.tolist(), most.tolist()))
    steep = sorted(L for L, v in per.items() if v > tol_deg + 1e-6)
    if not steep:
        return []
    from .cellplan import _ranges

    worst = max(steep, key=lambda L: per[L])
    return [
        (
            f"the positioner leaves layers {_ranges(steep)} up to {per[worst]:.1f}° off flat (layer {worst}): "
            f"this cell's {cell.axes}-axis positioner cannot turn them flat (policy auto names a change that would)",
            worst,
            None,
        )
    ]


def _cell_collisions(kin: KinematicsOptions, arm, ks, moves: Moves, ang: np.ndarray):
    """coal checks of the solved path in the cell (see trajectory.collide); each IK sample with its
    own (interpolated) positioner angles."""
    from .collide import check_path

    cell: Any = kin.cell
    cache: dict[tuple, tuple] = {}

    def work_frame(i):
        a = tuple(np.round(ang[i], 9))
        if a not in cache:
            cache[a] = (*cell.work_pose(np.asarray(a)), np.asarray(a))
        return cache[a]

    yaw = np.radians(cell.robot_base.yaw_deg)
    Rb = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    return check_path(
        arm,
        ks.q,
        ks.s,
        ks.seg,
        moves,
        cell,
        work_frame,
        Rb,
        np.asarray(cell.robot_base.xyz_mm, float),
        step_mm=kin.collision_step_mm,
    )
