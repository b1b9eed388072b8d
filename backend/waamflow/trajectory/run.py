"""One call from a flat move list to a full simulation: kinematics → controller → estimate → report.

`simulate_program` is what the simulate-robot node calls; `simulation_json` and `deposit_csv`
build its artifacts (the contract's `<node>.simulation.json`, `<node>.trace.csv` via
`calibrate.trace_csv`, and `<node>.deposit.csv`).
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ..core.moves import Moves
from .estimate import estimate_moves
from .kinematics import CellFrames, find_issues, load_arm, solve_path
from .profile import RobotProfile
from .simulate import METRIC_UNITS, SimOptions, SimulationResult, simulate

MAX_WARNINGS_PER_KIND = 20


@dataclass(frozen=True)
class KinematicsOptions:
    """description: URDF name in data/robots ("" = the profile's) or None with urdf_text given.
    step_mm: IK sample spacing along the programmed path. frames: cell frames (mm, deg)."""

    description: str = ""
    urdf_text: str | None = None
    tcp_offset_mm: tuple[float, float, float] | None = None
    frames: CellFrames = CellFrames()
    step_mm: float = 5.0
    cell: object | None = None           # trajectory.cell.Cell: when set, frames come from it and the policy
    positioner_policy: str = "fixed"
    max_tilt_deg: float = 30.0           # min-motion: torch lean from vertical tolerated before the positioner moves
    collisions: bool = True              # with a cell: coal collision checks along the path (trajectory.collide)
    collision_step_mm: float = 20.0      # programmed path between two checked samples


def simulate_program(moves: Moves, profile: RobotProfile, opt: SimOptions = SimOptions(),
                     kin: KinematicsOptions | None = None,
                     progress: Callable[[float, str], None] | None = None) -> SimulationResult:
    """Kinematics (optional: speed caps + warnings), controller simulation, closed-form estimate."""
    warnings: list[tuple[str, int | None, str | None]] = []
    kin_metrics: dict[str, float] = {}
    collision_list: tuple = ()
    if kin is not None and len(moves.points) >= 2:
        if progress:
            progress(0.02, "inverse kinematics")
        desc = kin.description or profile.description
        home = getattr(kin.cell, "robot_home_deg", None) if kin.cell is not None else None
        arm = load_arm(desc or "robot.urdf", kin.tcp_offset_mm or profile.tcp_offset_mm, urdf_text=kin.urdf_text,
                       home_deg=home)
        points, axes, frames = moves.points, moves.tool_axis, kin.frames
        if kin.cell is not None:       # the part on the positioner: every point in world at its own angles
            from .cell import positioner_angles, to_world

            ang = positioner_angles(kin.cell, moves, kin.positioner_policy, kin.max_tilt_deg)
            points, axes = to_world(kin.cell, moves.points, moves.tool_axis, ang)
            base = kin.cell.robot_base
            frames = CellFrames(base_xyz_mm=tuple(base.xyz_mm), base_yaw_deg=base.yaw_deg)
            pos_metrics = ({"positioner_e1_min_deg": float(ang[:, 0].min()),
                                "positioner_e1_max_deg": float(ang[:, 0].max()),
                                "positioner_e2_min_deg": float(ang[:, 1].min()),
                                "positioner_e2_max_deg": float(ang[:, 1].max()),
                                "positioner_max_step_deg": float(np.abs(np.diff(ang, axis=0)).max(initial=0.0))})
        else:
            pos_metrics = {}
        ks = solve_path(arm, points, axes, frames, step_mm=kin.step_mm,
                        progress=(lambda f: progress(0.02 + 0.3 * f, "inverse kinematics")) if progress else None)
        if kin.cell is not None and kin.collisions:
            if progress:
                progress(0.33, "collision checks")
            collisions = _cell_collisions(kin, arm, ks, moves, ang)
            pos_metrics.update({"collision_count": float(collisions[0]),
                                "collision_samples_checked": float(collisions[2]),
                                "collision_step_mm": float(kin.collision_step_mm)})
            collision_list = tuple(collisions[1])
            for c in collision_list[:MAX_WARNINGS_PER_KIND]:
                warnings.append((f"collision {c.bodies[0]} / {c.bodies[1]} at s = {c.s_mm:.1f} mm "
                                 f"(point {c.point_mm[0]:.1f}, {c.point_mm[1]:.1f}, {c.point_mm[2]:.1f} mm)",
                                 c.layer, c.section))
        speed = np.where(np.isnan(moves.speed), opt.travel_speed or profile.travel_speed, moves.speed)
        if opt.speed_override is not None:
            speed = np.where(moves.arc, opt.speed_override, speed)
        issues = find_issues(ks, arm, moves.layer, moves.section, moves.section_keys, speed)
        counts: dict[str, int] = {}
        for it in issues:
            counts[it["kind"]] = counts.get(it["kind"], 0) + 1
            if counts[it["kind"]] > MAX_WARNINGS_PER_KIND:
                continue
            msg = {"unreachable": "target unreachable", "joint_limit": "joint limit reached",
                   "near_singular": "near-singular arm configuration",
                   "joint_speed": "joint speed limit"}[it["kind"]]
            detail = f"; {it['detail']}" if it["detail"] else ""
            warnings.append((f"{msg} over s = {it['s_from']:.1f}..{it['s_to']:.1f} mm "
                             f"({it['count']} IK samples){detail}", it["layer"], it["section"]))
        for kind, c in counts.items():
            if c > MAX_WARNINGS_PER_KIND:
                warnings.append((f"{c - MAX_WARNINGS_PER_KIND} more '{kind}' stretches not listed", None, None))
        opt = replace(opt, segment_cap=ks.segment_cap)
        finite = np.isfinite(ks.segment_cap)
        kin_metrics = {
            "ik_samples": float(len(ks.s)),
            "ik_max_position_error_mm": float(ks.reach_err.max()),
            "ik_min_singular_value": float(ks.sigma_min.min()),
            "joint_speed_capped_segments": float(np.count_nonzero(ks.segment_cap < speed)),
            "min_joint_speed_cap_mm_s": float(ks.segment_cap[finite].min()) if finite.any() else math.inf,
        }
        for kind in ("unreachable", "joint_limit", "near_singular", "joint_speed"):
            kin_metrics[f"{kind}_stretches"] = float(counts.get(kind, 0))
        kin_metrics.update(pos_metrics)
    res = simulate(moves, profile, opt,
                   progress=(lambda f, m: progress(0.35 + 0.65 * f, m)) if progress and kin is not None else progress)
    est = estimate_moves(moves, profile.time_model, opt.travel_speed or profile.travel_speed) if profile.time_model else None
    estimate = {}
    if est is not None:
        estimate = {"total_time_s": est.total_time_s, "passes": float(est.passes),
                    "error_vs_simulation_pct": 100.0 * (est.total_time_s - res.metrics["total_time_s"])
                    / max(res.metrics["total_time_s"], 1e-9)}
    metrics = dict(res.metrics)
    metrics.update(kin_metrics)
    return replace(res, metrics=metrics, warnings=tuple(warnings), estimate=estimate, collisions=collision_list)


def _cell_collisions(kin: KinematicsOptions, arm, ks, moves: Moves, ang: np.ndarray):
    """coal checks of the solved path in the cell (see trajectory.collide); each sample's work frame
    and positioner flange are the ones at its segment's start angles."""
    from .collide import check_path

    cell = kin.cell
    cache: dict[tuple, tuple] = {}

    def work_frame(i):
        a = tuple(np.round(ang[ks.seg[i]], 9))
        if a not in cache:
            f = cell.frames(list(a))
            cache[a] = (np.asarray(f.work_rot, float), np.asarray(f.work_xyz_mm, float), *cell.positioner_pose(list(a)))
        return cache[a]
    yaw = np.radians(cell.robot_base.yaw_deg)
    Rb = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    return check_path(arm, ks.q, ks.s, ks.seg, moves, cell, work_frame, Rb, np.asarray(cell.robot_base.xyz_mm, float),
                      step_mm=kin.collision_step_mm)


def _clean(v):
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return round(v, 6) if isinstance(v, float) else v


def simulation_json(res: SimulationResult, opt: SimOptions) -> dict:
    """The contract's `<node>.simulation.json`: metrics at top level plus units, estimate, warnings."""
    out = {k: _clean(float(v)) for k, v in res.metrics.items()}
    out["units"] = {k: METRIC_UNITS.get(k, "") for k in res.metrics}
    out["estimate"] = {k: _clean(float(v)) for k, v in res.estimate.items()}
    out["estimate_total_time_s"] = out["estimate"].get("total_time_s")
    out["warnings"] = [{"message": m, "layer": l, "section": s} for m, l, s in res.warnings]
    if "collision_count" in res.metrics:
        out["collision_count"] = int(res.metrics["collision_count"])
        out["collisions"] = [{"layer": c.layer, "section": c.section, "bodies": list(c.bodies),
                              "point_mm": list(c.point_mm), "s_mm": round(c.s_mm, 3)} for c in res.collisions]
    out["robot_profile"] = res.profile.get("name")
    out["settings"] = {"cdis_mm": opt.cdis, "blend": opt.blend, "wire_feed_mm3_s": opt.wire_feed_mm3_s,
                       "speed_override_mm_s": opt.speed_override,
                       "interpolation_cycle_s": opt.interpolation_cycle_s or res.profile.get("interpolation_cycle_s")}
    c = res.corners
    out["corners"] = [{"vertex": int(v), "interior_deg": round(float(a), 3), "error_mm": round(float(e), 4),
                       "min_speed_mm_s": _clean(float(sp)), "mean_speed_mm_s": _clean(float(mv))}
                      for v, a, e, sp, mv in zip(c.get("vertex", []), c.get("interior_deg", []), c.get("error_mm", []),
                                                 c.get("min_speed_mm_s", []), c.get("mean_speed_mm_s", []))][:5000]
    return out


def deposit_csv(res: SimulationResult) -> str:
    """Per programmed segment: where too much or too little metal lands (mm³ per mm of path)."""
    d = res.deposit
    keys = res.section_keys
    buf = io.StringIO()
    buf.write("segment,layer,section,s_mm,length_mm,arc,programmed_mm3_per_mm,actual_mm3_per_mm,ratio\n")
    for i in range(len(d["length_mm"])):
        prog = float(d["programmed_mm3_per_mm"][i])
        act = float(d["actual_mm3_per_mm"][i])
        sec = int(d["section"][i])
        ratio = f"{act / prog:.4f}" if prog > 0 else ""
        buf.write(f"{i},{int(d['layer'][i])},{keys[sec] if 0 <= sec < len(keys) else ''},{d['s_mm'][i]:.3f},"
                  f"{d['length_mm'][i]:.3f},{int(bool(d['arc'][i]))},{prog:.4f},{act:.4f},{ratio}\n")
    return buf.getvalue()
