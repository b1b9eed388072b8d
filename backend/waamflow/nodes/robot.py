"""Robot nodes: simulate-robot, calibrate-robot, estimate-time — thin adapters over waamflow.trajectory."""

from __future__ import annotations

from dataclasses import replace
import json
from typing import Literal

from pydantic import Field, field_validator

from ..core.errors import RecipeError
from ..core.files import ShippedName, shipped
from ..engine.node import FileRef, Node, NodeParams, register, unit
from ..engine.ports import Port
from ..trajectory.calibrate import fit_trace, identify_time_model, read_trace_csv
from ..trajectory.cell import cell_schema
from ..trajectory.compensate import deposit_cv, deposit_ratio_cv, simulate_compensated
from ..trajectory.estimate import estimate_moves, estimate_result, section_strategies
from ..trajectory.kinematics import CellFrames
from ..trajectory.profile import RobotProfile, load_profile
from ..trajectory.run import KinematicsOptions, program_settings, simulate_program, simulation_json
from ..trajectory.runreport import start_deposit_files
from ..trajectory.trace import start_trace_csv
from .robotparams import POSITIONER_PLAN_KEYS as POSITIONER_PLAN_KEYS
from .robotparams import RobotParams as RobotParams
from .robotparams import _beside as _beside
from .robotparams import _profile as _profile
from .robotparams import _toolpath_moves as _toolpath_moves
from .robotparams import cell_files as cell_files
from .robotparams import cell_from_param as cell_from_param
from .robotparams import check_cell_param as check_cell_param
from .robotparams import flat_tol_field as flat_tol_field
from .robotparams import max_lean_field as max_lean_field
from .robotparams import max_tilt_field as max_tilt_field

Vec3 = tuple[float, float, float]


# CPU seconds per path point of the controller simulation (and trace.csv's rows) that simulate-robot
# hands to the run's workers: curved-bracket, 39,274 points, 0.87 s of simulation (2026-11-26)
SIM_SHARED_S_PER_POINT = 2.2e-5


@register
class SimulateRobot(Node):
    """Predict what the robot really does with the toolpath: full stops at every arc ON/OFF switch,
    blended (cut) corners, jerk-limited speed that never reaches the programmed value on short
    moves, the controller's smoothing, arc-switch lags — and with a constant wire feed, where too
    much or too little metal lands. Optional Pinocchio kinematics caps the speed where joints
    would exceed their limits and warns (by layer and section) about unreachable targets, joint
    limits and near-singular stretches. Writes `<node>.simulation.json` (time, lengths, ratio,
    arc-on time/length, volume, deviation, time inside/outside, the closed-form estimate beside),
    `<node>.trace.csv` (t,x,y,z,speed,arc,deviation every cycle) and `<node>.deposit.csv`
    (mm³/mm actual vs programmed per segment).

    With the `program` input connected (the post-process that writes the program for this same
    toolpath) the program is the one declaration of how the controller moves: its dialect gives
    the controller family (KRL → KUKA KR C2, C_DIS arc blend, profile kuka_kr100ha_krc2; KRL for
    ArcTech Basic 3.x (ArcMainNG, KSS 8.x) → KUKA KR C4, profile kuka_kr100ha_krc4; RAPID → ABB
    IRC5, zone parabola, profile abb_irb4600_irc5; G-code → a G-code motion planner, profile
    gcode_planner: exact path, junction speeds from the junction deviation and acceleration,
    trapezoidal ramps, a 16-block look-ahead, travel at the program's G0 feed or the machine's
    rapid rate — unless the recipe sets robot_profile, profile_file, cdis or blend here: then the
    G-code runs on that robot controller with its blending, e.g. a robot's CNC option), its
    `$APO.CDIS` / `zw` zonedata the blend distance, and its ignition dwells
    (WAIT SEC, seamdata, G4) the standstill at every ignition. Setting `cdis`, `blend`,
    `ignition_dwell_s` (or, for G-code, `travel_speed`) here as well is a RecipeError (two
    declarations); `robot_profile` / `profile_file` still choose the robot's dynamics when set."""

    type = "simulate-robot"
    title = "Simulate robot"
    category = "trajectory"
    inputs = (
        Port("toolpath", "toolpath", "Zoned, sequenced toolpath"),
        Port(
            "program",
            "program",
            "The program post-processed from this toolpath: its blend distance, "
            "ignition dwells and controller family are simulated",
            optional=True,
        ),
    )
    outputs = (Port("simulation", "simulation", "Simulated motion, trace and deposit (SimulationResult)"),)
    version = "17"  # 17: positioner policy and limits from a connected program; 16: positioner_policy auto (default), max_lean_deg, flat_tol_deg; 10: deposit_per_mm_cv, compensate; 11: cell + positioner_policy; 12: collisions; 13: coordinated
    # 15: G-code programs run the G-code planner family (junction deviation, look-ahead, travel as written);
    #     ArcTech KRL -> KR C4 profile
    # 14: program input (blend, dwells, controller as written); C_DIS scales the blend law; arc-on ≤ total

    class Params(RobotParams):
        kinematics: bool = Field(
            True,
            description="Solve the arm's inverse kinematics along the path (Pinocchio)",
            title="Solve inverse kinematics",
        )
        cell: str = Field(
            "",
            max_length=256,
            json_schema_extra={"x-cell-schema": cell_schema(), "x-shipped": "cells", "x-file-suffix": ".json"},
            description="Robot cell: a shipped cell name (data/cells) or a cell JSON path; when set it "
            "gives the arm, base, TCP and the work frame on the positioner flange at its "
            "`fixed_deg` angles, replacing the base/work/TCP parameters below",
            title="Robot cell",
        )
        max_tilt_deg: float = max_tilt_field()
        positioner_policy: Literal["auto", "fixed", "gravity", "min-motion"] = Field(
            "auto",
            description="With a cell: `auto` plans each layer's positioner angles and torch lean with the "
            "arm's IK and the collision checks (gravity angles first, then turntable turns, "
            "a torch lean up to max_lean_deg, the tilt relaxed within flat_tol_deg, then the "
            "angles varied along the layer: each point flat at its own normal, or the turntable "
            "following the layer) and fails "
            "naming the layer and the cell changes verified to work when nothing does; `fixed` "
            "keeps the positioner at the cell's fixed_deg; `gravity` turns each layer so its "
            "torch axis points straight down (flat-position welding); `min-motion` holds the "
            "angles while the torch may lean max_tilt_deg. Limits and axis speeds from the "
            "positioner URDF cap and are reported per layer",
            title="Positioner policy",
        )
        max_lean_deg: float = max_lean_field()
        flat_tol_deg: float = flat_tol_field()
        collision_step_mm: float = Field(
            20.0,
            gt=0.5,
            le=1000,
            json_schema_extra=unit("mm"),
            description="With a cell: coal collision checks (arm links, torch, table, "
            "fixtures, layers built so far) every this much programmed path "
            "and at every layer change",
            title="Collision check spacing",
        )
        collisions: bool = Field(
            True, description="With a cell: check collisions along the path", title="Check collisions"
        )
        robot_description: ShippedName = shipped(
            "robot-descriptions",
            default="",
            max_length=128,
            description="Arm URDF in data/robots (empty = the profile's description)",
            title="Robot description (URDF)",
        )
        ik_step_mm: float = Field(
            5.0,
            gt=0.1,
            le=100,
            json_schema_extra=unit("mm"),
            description="IK sample spacing along the path (vertices always included)",
            title="IK sample spacing",
        )
        base_xyz_mm: Vec3 | None = Field(
            None,
            json_schema_extra=unit("mm"),
            description="Robot base position in the world frame (empty = the profile's)",
            title="Robot base position",
        )
        base_yaw_deg: float = Field(
            0.0,
            ge=-360,
            le=360,
            json_schema_extra=unit("deg"),
            description="Robot base rotation about world z",
            title="Robot base yaw",
        )
        work_xyz_mm: Vec3 = Field(
            (0.0, 0.0, 0.0),
            json_schema_extra=unit("mm"),
            description="Work frame (part origin) in the world frame",
            title="Work frame position",
        )
        tcp_offset_mm: Vec3 | None = Field(
            None,
            json_schema_extra=unit("mm"),
            description="TCP (torch tip) in the flange frame (tool0; z along the torch; empty = the profile's)",
            title="TCP offset",
        )
        compensate: Literal["off", "on"] = Field(
            "off",
            description="Modulate the wire feed per ≤1 mm piece so deposit per mm stays at its programmed "
            "value through stops and corners (waamflow.trajectory.compensate); reports "
            "deposit_per_mm_cv before and after and writes deposit.svg",
            title="Compensate deposit",
        )

        @field_validator("cell")
        @classmethod
        def _cell_name(cls, v: str) -> str:
            return check_cell_param(v)

    def read_files(self, params, read_bytes) -> list[str]:
        return cell_files(params.cell, read_bytes) if params.kinematics else []

    def shared_work_s(self, params, points: int) -> float:
        """With kinematics the controller simulation runs in a worker beside the IK
        (`run.simulate_program`)."""
        return SIM_SHARED_S_PER_POINT * points if params.kinematics else 0.0

    def _kin(self, ctx, params, profile: RobotProfile) -> KinematicsOptions | None:
        if not params.kinematics:
            return None
        if not (params.cell or params.robot_description or profile.description):
            return None  # no arm to solve (a gantry's G-code planner profile)
        if params.cell:
            cell = cell_from_param(ctx, params.cell)
            return KinematicsOptions(
                description=cell.robot_urdf,
                tcp_offset_mm=tuple(cell.tool.tcp_mm),
                frames=cell.frames(),
                step_mm=params.ik_step_mm,
                cell=cell,
                positioner_policy=params.positioner_policy,
                collisions=params.collisions,
                max_tilt_deg=params.max_tilt_deg,
                max_lean_deg=params.max_lean_deg,
                flat_tol_deg=params.flat_tol_deg,
                collision_step_mm=params.collision_step_mm,
            )
        base = params.base_xyz_mm if params.base_xyz_mm is not None else profile.base_xyz_mm
        tcp = params.tcp_offset_mm if params.tcp_offset_mm is not None else profile.tcp_offset_mm
        frames = CellFrames(
            base_xyz_mm=tuple(base), base_yaw_deg=params.base_yaw_deg, work_xyz_mm=tuple(params.work_xyz_mm)
        )
        return KinematicsOptions(
            description=params.robot_description, tcp_offset_mm=tuple(tcp), frames=frames, step_mm=params.ik_step_mm
        )

    def _positioner_from_program(self, ctx, params, program):
        """With a cell, the program was written for a cell with positioner angles (and, under
        `auto`, torch axes) planned by post-process: the simulation plans with the same cell,
        policy and limits (taken from the program where simulate-robot leaves them unset), or it
        would simulate another program than the one written."""
        pos = program.stats.get("positioner") if isinstance(program.stats, dict) else None
        if not pos or not params.cell:
            return params
        if pos.get("cell") != params.cell:
            raise RecipeError(
                f"simulate-robot's cell {params.cell!r} is not the cell its `program` input was "
                f"written for ({pos.get('cell')!r}): set the same cell on both nodes",
                node=ctx.node_id,
            )
        twice = [k for k in POSITIONER_PLAN_KEYS if k in params.model_fields_set and getattr(params, k) != pos[k]]
        if twice:
            raise RecipeError(
                "simulate-robot sets "
                + ", ".join(f"{k}={getattr(params, k)!r}" for k in twice)
                + " and its `program` input was written with "
                + ", ".join(f"{k}={pos[k]!r}" for k in twice)
                + ": one declaration — set them on the post-process (or the same on both)",
                node=ctx.node_id,
            )
        return params.model_copy(update={k: pos[k] for k in POSITIONER_PLAN_KEYS})

    def _from_program(self, ctx, params, program, profile: RobotProfile):
        """The options and robot profile the connected program declares (see the class doc)."""
        opt = params.sim_options()
        try:
            st = program_settings(program.format, program.files)
        except ValueError as e:
            raise RecipeError(
                f"simulate-robot cannot simulate its `program` input: {e}; connect a KRL, RAPID or G-code post-process",
                node=ctx.node_id,
            ) from None
        own_robot = bool(params.profile_file) or bool({"robot_profile", "cdis", "blend"} & set(params.model_fields_set))
        planner = program.format == "gcode" and not own_robot
        declared = {"ignition_dwell_s": f"{len(st['ignition_dwells_s'])} ignition dwells"}
        if st["blend_distance_mm"] is not None:
            declared["cdis"] = f"blend distance {st['blend_distance_mm']:g} mm"
            declared["blend"] = f"{st['controller']} blending ({st['blend']})"
        if planner and (st.get("travel_speed_mm_s") is not None or st.get("rapid_travel")):
            declared["travel_speed"] = (
                "its travel feed"
                if st.get("travel_speed_mm_s") is not None
                else "G0 travel at the machine's rapid rate"
            )
        twice = sorted(set(declared) & set(params.model_fields_set))
        if twice:
            raise RecipeError(
                f"simulate-robot sets {', '.join(twice)} and its `program` input declares "
                f"{'; '.join(declared[k] for k in twice)}: one declaration — remove {', '.join(twice)} "
                f"from simulate-robot (the post-process's blend_distance / ignition_dwell / machine "
                f"profile decide)",
                node=ctx.node_id,
            )
        opt = replace(opt, ignition_dwells_s=st["ignition_dwells_s"], controller=st["controller"])
        if st["blend_distance_mm"] is not None:
            opt = replace(opt, cdis=st["blend_distance_mm"], blend=st["blend"])
        if program.format == "gcode" and own_robot:
            # the recipe says which controller runs this G-code (a robot's CNC option, e.g. KUKA.CNC):
            # its robot and blending, as before the planner family existed
            opt = replace(opt, controller=profile.controller or profile.name)
        elif st["robot_profile"] and not params.profile_file and "robot_profile" not in params.model_fields_set:
            profile = load_profile(st["robot_profile"])
        if planner:
            opt = replace(opt, blend="junction")
            if st.get("travel_speed_mm_s") is not None:
                opt = replace(opt, travel_speed=st["travel_speed_mm_s"])
            elif st.get("rapid_travel"):
                opt = replace(opt, travel_speed=profile.max_speed)
        return opt, profile

    def run(self, ctx, params, inputs):
        moves = _toolpath_moves(inputs)
        profile = _profile(ctx, params)
        opt = params.sim_options()
        if inputs.get("program") is not None:
            opt, profile = self._from_program(ctx, params, inputs["program"], profile)
            params = self._positioner_from_program(ctx, params, inputs["program"])

        def progress(fraction: float, message: str = "") -> None:
            ctx.check_cancelled()
            ctx.progress(fraction, message)

        if params.compensate == "on":
            res = simulate_compensated(
                inputs["toolpath"], profile, opt, self._kin(ctx, params, profile), progress=progress
            )
        else:
            res = simulate_program(
                moves,
                profile,
                opt,
                self._kin(ctx, params, profile),
                progress=progress,
                strategies=section_strategies(inputs["toolpath"]),
                submit=ctx.submit,
            )
            res = replace(
                res,
                metrics={
                    **res.metrics,
                    "deposit_per_mm_cv": deposit_cv(res.trace),
                    "deposit_ratio_cv": deposit_ratio_cv(res),
                },
            )
        res = replace(res, options=opt)
        plan = (res.kinematics or {}).get("positioner_plan")
        if plan:
            stages: dict[str, int] = {}
            for row in plan["layers"]:
                stages[row["stage"]] = stages.get(row["stage"], 0) + 1
            ctx.report({"positioner_plan": plan})
            ctx.progress(0.99, "auto positioner plan: " + ", ".join(f"{v} layers {k}" for k, v in stages.items()))
        for msg, layer, section in res.warnings:
            ctx.warn(msg, layer=layer, section=section)
        return {"simulation": res}

    def artifacts(self, ctx, params, outputs):
        res = outputs["simulation"]
        trace = start_trace_csv(res, ctx.submit)  # part of the rows in a worker while the rest is written
        deposit = start_deposit_files(res, ctx.submit)  # in another worker
        sim_json = json.dumps(simulation_json(res, res.options or params.sim_options()), indent=1)
        dep_csv, dep_svg = deposit()
        return {"simulation.json": sim_json, "trace.csv": trace(), "deposit.csv": dep_csv, "deposit.svg": dep_svg}


@register
class EstimateTime(Node):
    """Instant cycle-time estimate with the robot study's closed-form model (da Silva Viola et al.
    2023): per section, passes and transitions timed with the identified acceleration/deceleration
    lengths and times in the robot profile's `time_model` (interpolated in speed). The output is
    an estimate-only SimulationResult (metrics, empty trace). Writes `<node>.estimate.json`.
    simulate-robot reports the same estimate beside its own figures.

    A profile from calibrate-robot holds the user's robot's constants per speed, arc protocol and
    strategy family ("40_on_triangular"); each section uses its strategy's entries, else the
    generic ones, else another strategy's; an arc protocol the profile has no entry for is timed
    with the study's (KUKA KR 100) constants, and a note says so (warning and `notes`). The
    shipped KR C2 / KR C4 profiles hold the study's triangular 45° constants as the generic entries
    and per-family entries for raster, semicircular and rectangular read off the controller model
    (trajectory/MODEL.md, "Time model per strategy family")."""

    type = "estimate-time"
    title = "Estimate time"
    category = "trajectory"
    inputs = (Port("toolpath", "toolpath", "Toolpath"),)
    outputs = (Port("estimate", "simulation", "Estimate-only result: metrics, no trace"),)
    version = "10"  # 10: strategy-specific time-model entries; the study's as a noted fallback

    class Params(NodeParams):
        robot_profile: ShippedName = shipped(
            "robots",
            default="kuka_kr100ha_krc2",
            min_length=1,
            max_length=64,
            description="Robot profile whose `time_model` holds the identified parameters",
            title="Robot profile",
        )
        profile_file: FileRef = Field(
            "", description="Optional robot profile JSON file; overrides robot_profile", title="Robot profile file"
        )
        travel_speed: float | None = Field(
            None,
            gt=0,
            le=2000,
            json_schema_extra=unit("mm/s"),
            description="Travel speed between sections (empty = the profile's)",
            title="Travel speed",
        )

    def run(self, ctx, params, inputs):
        moves = _toolpath_moves(inputs)
        profile = _profile(ctx, params)
        est = estimate_moves(
            moves,
            profile.time_model,
            params.travel_speed or profile.travel_speed,
            strategies=section_strategies(inputs["toolpath"]),
        )
        for note in est.notes:
            ctx.warn(note)
        res = estimate_result(moves, est)
        return {"estimate": replace(res, warnings=[(n, None, None) for n in est.notes])}

    def artifacts(self, ctx, params, outputs):
        m = outputs["estimate"].metrics
        return {
            "estimate.json": json.dumps(
                {
                    "total_time_s": round(m["total_time_s"], 6),
                    "passes": int(m["estimate_passes"]),
                    "sections": int(m["estimate_sections"]),
                    "method": "closed-form cycle-time model, da Silva Viola et al. 2023",
                    "notes": [w[0] for w in outputs["estimate"].warnings],
                },
                indent=1,
            )
        }


@register
class CalibrateRobot(Node):
    """Fit the robot profile's constants (path acceleration/jerk, smoothing, blend start, corner
    jerk, arc-switch delays, ...) to a measured trace CSV (columns t, x, y, z[, arc]; s and mm) of
    the known program on the input, with scipy least squares on the simulated positions at the
    measured times. It also reads the study's Table-5 constants of the time model off the trace
    (`identify_time_model`: ramp-up/-down times and lengths at the start/stop, L_decel/L_accel
    and T_trans between passes, per programmed speed, arc protocol and strategy family) and
    writes them as the profile's `time_model` (replacing the study's KR 100 values: estimate-time
    then predicts this robot). `fit` may be empty: time model only. Writes `<node>.profile.json`
    (the fitted profile, usable as simulate-robot's and estimate-time's `profile_file`) and
    `<node>.calibration.json` (cost before/after, RMS position error, identified time model).
    A CSV row that is not numeric, short or out of time order fails with its row number."""

    type = "calibrate-robot"
    title = "Calibrate robot"
    category = "trajectory"
    inputs = (Port("toolpath", "toolpath", "The program that was measured"),)
    outputs = (Port("simulation", "simulation", "Simulation of the program with the fitted profile"),)
    version = "10"  # 10: identifies the time model (Table 5) from the trace; fit may be empty

    class Params(RobotParams):
        trace: FileRef = Field(
            ..., description="Measured trace CSV: t,x,y,z[,arc] (s, mm, 0/1)", title="Measured trace"
        )
        fit: list[Literal[RobotProfile.FITTABLE]] = Field(  # type: ignore[valid-type]
            default_factory=lambda: ["path_acc", "path_jerk", "smoothing_s", "apo_time_s", "normal_jerk"],
            description="Profile constants to fit (empty: identify the time model only)",
            title="Constants to fit",
        )
        time_model: bool = Field(
            True,
            description="Identify the study's time-model constants (Table 5) from the "
            "trace and write them into the profile",
            title="Identify the time model",
        )

    def run(self, ctx, params, inputs):
        moves = _toolpath_moves(inputs)
        base = _profile(ctx, params)
        meas = read_trace_csv(ctx.read_text(params.trace, max_bytes=200_000_000), source=params.trace)
        names = tuple(dict.fromkeys(params.fit))
        tm, tm_info = {}, {}
        if params.time_model:
            tm, tm_info = identify_time_model(moves, meas, section_strategies(inputs["toolpath"]), source=params.trace)
            for msg in tm_info["skipped"]:
                ctx.warn(f"time model: {msg}")
            if not tm:
                ctx.warn(
                    "time model: no section of the program shows passes and transitions in the trace; "
                    f"the profile keeps {base.name!r}'s time_model"
                )
        metrics = {}
        if names:
            ctx.progress(0.05, "fitting")
            fitted, info = fit_trace(base, moves, meas, names, params.sim_options())
            metrics = {
                "fit_rms_position_error_mm": info["rms_position_error_mm"],
                "fit_cost_before": info["cost_before"],
                "fit_cost_after": info["cost_after"],
            }
        else:
            fitted, info = base, {}
        if tm:
            fitted = fitted.with_values(time_model=tm)
            info["time_model"] = tm_info["sections"]
        res = simulate_program(moves, fitted, params.sim_options())
        prof = fitted.to_json()
        prof["fit"] = {"trace": params.trace, **info}
        res = replace(res, profile=prof, metrics={**res.metrics, **metrics})
        return {"simulation": res}

    def artifacts(self, ctx, params, outputs):
        res = outputs["simulation"]
        return {
            "profile.json": json.dumps(res.profile, indent=1, ensure_ascii=False),
            "calibration.json": json.dumps(
                {
                    **{k: v for k, v in res.metrics.items() if k.startswith("fit_")},
                    "time_model": res.profile.get("time_model", {}),
                },
                indent=1,
            ),
        }
