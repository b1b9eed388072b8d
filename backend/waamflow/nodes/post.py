"""post-process: the zoned toolpath → a G-code / KUKA KRL / ABB RAPID program or a CL file.

A thin adapter over `waamflow.program`; every number and code of the output is a parameter here.
"""

from __future__ import annotations

from dataclasses import replace
import math
from typing import Any, Literal

import numpy as np
from pydantic import Field, field_validator

from ..core.errors import RecipeError
from ..core.files import ShippedName, shipped
from ..core.moves import flatten
from ..engine.node import Node, NodeParams, register, unit
from ..engine.ports import Port
from ..program import PlanSettings, Program, RapidSettings, post_process
from ..program.common import check_templates, check_tool_template, stamp_trace
from ..program.gcode import check_arc_code
from ..program.krl import ARCTECH_CHANNELS, check_channels
from ..trajectory.cell import cell_schema, positioner_and_torch, to_world
from .post_settings import CONTROLLER_SETTINGS as CONTROLLER_SETTINGS
from .post_settings import _program_name as _program_name
from .post_settings import PROGRAM_MEMORY_MB as PROGRAM_MEMORY_MB
from .post_settings import _warn_memory as _warn_memory
from .post_settings import _warn_weld_data as _warn_weld_data
from .post_settings import _with_weld_values as _with_weld_values
from .post_settings import _work_frame as _work_frame
from .post_settings import _writer_settings as _writer_settings
from .post_settings import with_profile as with_profile
from .robotparams import (  # not .robot: a recipe without robot nodes does not import the simulation
    POSITIONER_PLAN_KEYS,
    cell_files,
    cell_from_param,
    check_cell_param,
    flat_tol_field,
    max_lean_field,
    max_tilt_field,
)

_NAME = r"^[A-Za-z][A-Za-z0-9_]*$"
TILT_WARN_DEG = 0.5  # a torch tilt below this is numerical noise of the tool-axis computation


@register
class PostProcess(Node):
    """Write the toolpath as a machine/robot program, chosen by `format`.

    - `gcode` (gantry/CNC WAAM): absolute mm, G0 travel, G1 deposition with F in mm/min from each
      zone's speed, optional G2/G3 arc fitting, `arc_on`/`arc_off` codes (default M3/M5, the ORNL
      Slicer 2 wire-arc convention), G4 dwell after every ignition and between layers, per-zone
      process commands from `process_codes` templates, M30. Artifact `<node>.gcode`.
    - `krl` (KUKA): `<name>.src` + `<name>.dat` — LIN/CIRC, $VEL.CP per zone (m/s), $APO.CDIS +
      C_DIS blending, arc by digital output (TRIGGER) or ArcTech-style calls, E6POS from the tool
      axis; split into subprograms per layer / per N points (`<name>_L003.src`, ...).
    - `rapid` (ABB): `<name>.mod` — MoveL travel, ArcLStart/ArcL/ArcLEnd with seamdata/welddata
      per zone, zonedata from the blend distance, WaitTime for dwell; above `max_module_bytes` a
      main module that loads part modules `<name>_M001.mod`, ... (layer ranges) one by one.
    - `inform` (Yaskawa): `<NAME>.JBI` calling one job per layer, ARCON/ARCSET/ARCOF; with a
      cell's positioner, coordinated jobs (GROUP2 ST1, EC positions in pulses, SMOVL … +MOVJ EC).
    - `tp` (Fanuc R-30iB ArcTool): `<NAME>.LS` calling one program per layer `<NAME>_L003.LS`,
      `L P[i] mm/sec CNT/FINE`, `Arc Start[k]`/`Arc End[k]` with weld schedules numbered from
      the zones' weld values and tabled in `<NAME>_SCHED.CSV` (to enter on the controller).
    KRL and RAPID files are named after the program (`<name>` = `program_name`, else the node id
    made an identifier: node `duct-post` writes `duct_post.src` holding `DEF duct_post`), since
    the controller needs file name = DEF / module name; G-code and CSV are `<node>.<suffix>`.
    - `csv`: cutter-location file `<node>.csv`, one row per point (x, y, z, tool axis, speed,
      arc, layer, section, zone, dwell).
    - `printpoints`: compas_slicer's print-points JSON `<node>.printpoints.json`, one entry per
      toolpath point (point, layer_height, up_vector, mesh_normal, frame, extruder_toggle,
      velocity, wait_time, blend_radius, plus layer and section) for compas_rrc/compas_fab drivers;
      as compas_slicer means them: the toggle is the arc of the motion leaving the point, the
      velocity the motion's to it, a wait is spent with the arc as the point's toggle says.
    Ignition dwell: the zone's `dwell` parameter when it has one, else `ignition_dwell`.
    Interlayer dwells carry their reason (e.g. the interpass rule) in a comment. Rolling/peening
    strokes (a `treatment` node's sections) are engaged and lifted by `tool_on`/`tool_off`
    (force, width, speed filled in) around each stroke's contact motions.
    """

    type = "post-process"
    title = "Post-process"
    category = "program"
    inputs = (Port("toolpath", "toolpath", "Zoned, sequenced toolpath"),)
    outputs = (Port("program", "program", "Program text files and statistics"),)
    version = "6"  # 6: the program carries its cell (preflight weld_position); 5: max_tilt/max_lean/flat_tol; 4: a cell file like simulate-robot's; the torch lean `auto` chose is written
    uses_node_id = True  # the program is named after the node (its artifact names)

    class Params(NodeParams):
        profile: ShippedName = shipped(
            "machines",
            default="",
            max_length=64,
            description="Machine profile (data/machines: generic, linuxcnc, marlin, kuka_krc4 (ArcTech), kuka_krc4_io, "
            "abb_irc5, yaskawa_yrc1000, fanuc_r30ib_arctool): presets for every param this recipe does not set; empty = none",
            title="Machine profile",
        )
        format: Literal["gcode", "krl", "rapid", "inform", "tp", "csv", "printpoints"] = Field(
            "gcode",
            description="Program format; inform = Yaskawa Motoman INFORM jobs (.JBI); tp = Fanuc TP "
            "programs (.LS, ArcTool) with a weld schedule table; printpoints = "
            "compas_slicer print-points JSON",
            title="Program format",
        )
        program_name: str = Field(
            "",
            pattern=r"^([A-Za-z][A-Za-z0-9_]*)?$",
            max_length=32,
            description="Program / module name (KRL DEF, RAPID MODULE); empty = the node id made an "
            "identifier, so the program is named like its files (KRL requires "
            "DEF name = file name; ≤ 24 characters, ≤ 16 when split; RAPID ≤ 32, ≤ 27 "
            "with a module size limit); the KRL / RAPID files are named after it",
            title="Program name",
        )
        ignition_dwell: float = Field(
            0.5,
            ge=0,
            le=60,
            json_schema_extra=unit("s"),
            description="Dwell after each arc ignition when the zone has no `dwell` parameter",
            title="Ignition dwell",
        )
        arc_tolerance: float = Field(
            0.0,
            ge=0,
            le=5,
            json_schema_extra=unit("mm"),
            description="Arc fitting tolerance (G2/G3, CIRC, ArcC); 0 = off, every point a linear move",
            title="Arc fitting tolerance",
        )
        travel_speed: float = Field(
            100.0,
            gt=0,
            le=2000,
            json_schema_extra=unit("mm/s"),
            description="Arc-off travel speed (robots; G-code when rapid_travel is off) and time estimate",
            title="Travel speed",
        )
        blend_distance: float = Field(
            1.0,
            ge=0,
            le=100,
            json_schema_extra=unit("mm"),
            description="Corner blending: KRL $APO.CDIS, RAPID zonedata radius, print points "
            "blend_radius; 0 = exact stops",
            title="Corner blend distance",
        )
        position_level: int = Field(
            1,
            ge=0,
            le=8,
            title="Position level (INFORM PL)",
            description="INFORM: PL of blended motions (0 = exact stop everywhere; the "
            "controller's position level table sets the distance of 1..8)",
        )
        cnt: int = Field(
            100,
            ge=0,
            le=100,
            title="Blending CNT (TP)",
            description="Fanuc TP: CNT of blended motions (0..100; exact stops are FINE; "
            "blend_distance 0 = FINE everywhere)",
        )
        station_pulses_per_deg: list[float] = Field(
            default_factory=list,
            max_length=3,
            title="Station pulses per degree (INFORM)",
            description="INFORM with a cell's positioner: encoder pulses per degree of each station axis (E1 tilt, "
            "E2 turn) as the controller's parameters give them; the EC positions are written in pulses",
        )
        # G-code
        arc_on: str = Field(
            "M3",
            min_length=1,
            max_length=64,
            description="G-code: line that switches the arc on: an M code and its parameters (M3, M101 P1)",
            title="Arc on code",
        )
        arc_off: str = Field(
            "M5",
            min_length=1,
            max_length=64,
            description="G-code: line that switches the arc off: an M code and its parameters (M5, M103)",
            title="Arc off code",
        )
        dwell_units: Literal["s", "ms"] = Field(
            "s", description="G-code: unit of the G4 P word on this controller", title="Dwell units"
        )
        rapid_travel: bool = Field(
            True, description="G-code: G0 for arc-off travel (else G1 at travel_speed)", title="Rapid travel (G0)"
        )
        comment_style: Literal["semicolon", "parentheses"] = Field(
            "semicolon",
            description="G-code: comments as `; text` or `(text)` (controllers without `;`)",
            title="Comment style",
        )
        feed_units: Literal["mm/min", "mm/s"] = Field(
            "mm/min", description="G-code: unit of the F word", title="Feed units"
        )
        start_code: list[str] = Field(
            default_factory=list,
            max_length=50,
            description="G-code: lines written after the header (e.g. homing, gas on)",
            title="Start code",
        )
        layer_code: list[str] = Field(
            default_factory=list,
            max_length=20,
            description="G-code: lines written at every layer change; templates with "
            '{layer} and {z} (mm), e.g. ";LAYER:{layer}"',
            title="Layer change code",
        )
        end_code: list[str] = Field(
            default_factory=list,
            max_length=50,
            description="G-code: lines written after the last motion and the final lift",
            title="End code",
        )
        final_lift: float = Field(
            0.0,
            ge=0,
            le=500,
            json_schema_extra=unit("mm"),
            description="G-code: G0 up by this much at the end, after the arc is off; 0 = none",
            title="Final lift",
        )
        preamble: list[str] = Field(
            default_factory=list,
            max_length=10,
            description='G-code: lines before everything else (e.g. "%", "O0001")',
            title="Preamble",
        )
        postamble: list[str] = Field(
            default_factory=list,
            max_length=10,
            description='G-code: lines after the program end (e.g. "%")',
            title="Postamble",
        )
        program_end: str = Field(
            "M30",
            min_length=1,
            max_length=32,
            description="G-code: the last line (M30, M2; Marlin: M84, since its M30 deletes a file)",
            title="Program end",
        )
        process_codes: dict[str, str] = Field(
            default_factory=dict,
            description="G-code / KRL output mode: zone weld value (wire_feed_speed m/min, current A, voltage V, "
            'job) → the command that sets it, a template using {value}, e.g. {"wire_feed_speed": '
            '"M100 S{value:.1f}"}; written at every zone change (inside a run: the changes). Empty = '
            "the format's default: G-code LinuxCNC analog outputs M67 E0 (WFS) / E1 (current) / E2 "
            "(voltage) Q<value>, job M120 P<job>; KRL $ANOUT[1] = WFS/20, [2] = current/500, [3] = "
            'voltage/50. A value without a command ("") is reported as a weld issue',
            title="Process codes",
        )
        process_codes_start: dict[str, str] = Field(
            default_factory=dict,
            description="G-code: the form of a process_codes command written before an ignition (arc off); empty = "
            "LinuxCNC's immediate M68 E<n> Q<value> with the default process_codes, else process_codes",
            title="Process code before ignition",
        )
        process_scale: dict[str, float] = Field(
            default_factory=dict,
            description="G-code: zone weld value → factor applied before it fills {value} (e.g. Marlin PWM: "
            '{"wire_feed_speed": 12.75} for S0-255 = 0-20 m/min); default 1',
            title="Process value scale",
        )
        weld_values: dict[str, float] = Field(
            default_factory=dict,
            description="Weld values (current A, voltage V, wire_feed_speed m/min, job) for every welded zone that "
            "does not state them itself: the power-source setting the plan was made for (e.g. a recipe "
            "without a parameter file), so the program commands it; empty = none",
            title="Weld values",
        )
        tcp_control: bool = Field(
            True,
            description="G-code with a positioner: the controller has tool centre point "
            "control (LinuxCNC TCP kinematics, TRAORI, G43.4); Marlin has none",
            title="TCP control",
        )
        travel_feed: bool = Field(
            False,
            description="G-code: F at travel_speed on every G0 travel line (controllers "
            "whose G0 moves at the modal feed, e.g. Marlin)",
            title="Feed on rapid moves",
        )
        rotary_axes: list[str] = Field(
            default_factory=lambda: ["A", "C"],
            min_length=1,
            max_length=6,
            json_schema_extra={"items": {"type": "string", "enum": ["A", "B", "C", "U", "V", "W"]}},
            description="G-code with a cell: letters of the positioner axes E1 (tilt), E2 (turn) as rotary "
            "axes (the machine profile's, e.g. A/C or B/C)",
            title="Rotary axis letters",
        )
        rotary_units: Literal["deg", "rad"] = Field(
            "deg", description="G-code with a cell: unit of the rotary-axis words", title="Rotary axis units"
        )
        # post-deposition tools (rolling, peening: sections from a treatment node)
        tool_on: str = Field(
            "",
            max_length=200,
            description="Line(s) that engage a rolling/peening tool before each contact stroke, with "
            "fields {force_n} N, {tool_width_mm} mm, {speed_mm_s} mm/s, {tool}; empty = "
            "the format's default: G-code `M110 P{force_n:.0f} Q{tool_width_mm:g}` "
            "(LinuxCNC user M-code), KRL `TOOL_ON(force, width, speed)`, RAPID "
            "`ToolOn force, width, speed;`",
            title="Tool on code",
        )
        tool_off: str = Field(
            "",
            max_length=200,
            description="Line(s) that lift the tool after each stroke; empty = G-code `M111`, KRL "
            "`TOOL_OFF()`, RAPID `ToolOff;`",
            title="Tool off code",
        )
        # KUKA KRL
        tool_number: int = Field(
            1,
            ge=1,
            le=32,
            description="KRL: TOOL_DATA number; INFORM: the job's tool (///TOOL); TP: UT (1..10)",
            title="Tool number (KRL)",
        )
        base_number: int = Field(
            1,
            ge=0,
            le=32,
            description="KRL: BASE_DATA number; INFORM: the user frame (///USER, at least 1); TP: UF (0..9)",
            title="Base number (KRL)",
        )
        arc_control: Literal["output", "arctech"] = Field(
            "output",
            description="KRL: arc by digital output (TRIGGER ... $OUT[n]) or ArcTech-style ARC_ON/ARC_SWI/ARC_OFF",
            title="Arc control (KRL)",
        )
        arc_output: int = Field(
            1, ge=1, le=4096, description="KRL: digital output number of the arc", title="Arc output number (KRL)"
        )
        arctech_routine: str = Field(
            "ArcMainNG",
            pattern=_NAME,
            max_length=24,
            description="KRL ArcTech: main routine the ARC ON/SWI/OFF calls go through",
            title="ArcTech routine",
        )
        arctech_channels: dict[str, int] = Field(
            default_factory=lambda: dict(ARCTECH_CHANNELS),
            description="KRL ArcTech: zone parameter → power-source channel 1..8 of the weld data sets "
            '(e.g. {"job": 1, "wire_feed_speed": 2, "voltage": 3})',
            title="ArcTech channels",
        )
        arctech_velocity_unit: Literal["m/min", "m/s"] = Field(
            "m/min",
            description="KRL ArcTech: unit of Weld.Velocity in the weld data sets",
            title="ArcTech velocity unit",
        )
        max_points_per_file: int = Field(
            0,
            ge=0,
            le=1_000_000,
            description="KRL: most motions per file, 0 = no limit (main program calls subprograms)",
            title="Most motions per file (KRL)",
        )
        split_per_layer: bool = Field(False, description="KRL: one subprogram per layer", title="Subprogram per layer")
        controller_memory_mb: float | None = Field(
            None,
            ge=0,
            le=1e6,
            description="The controller's program memory: a program's files larger than this are warned; "
            "empty = the format's usual (KRL 4 MB, a KR C4's RAM drive; others unchecked), 0 = no check",
            json_schema_extra=unit("MB"),
            title="Controller program memory",
        )
        # ABB RAPID
        tool_name: str = Field(
            "tWeldGun", pattern=_NAME, max_length=32, description="RAPID: tooldata name", title="Tool name (RAPID)"
        )
        wobj_name: str = Field(
            "wobj0",
            pattern=_NAME,
            max_length=32,
            description="RAPID: wobjdata name (with a cell's positioner: a coordinated work "
            "object declared in the module, wobj_<unit> when this is wobj0)",
            title="Work object (RAPID)",
        )
        positioner_unit: str = Field(
            "STN1",
            pattern=r"^([A-Za-z][A-Za-z0-9_]*)?$",
            max_length=32,
            description="RAPID: mechanical unit of the positioner (ActUnit/DeactUnit, ufmec of "
            "the coordinated work object); empty = no coordination",
            title="Positioner unit (RAPID)",
        )
        max_module_bytes: int = Field(
            512_000,
            ge=0,
            le=100_000_000,
            json_schema_extra=unit("B"),
            description="RAPID: most bytes per module file; a larger program is a main "
            "module that loads part modules <name>_M001.mod, ... (layer ranges) "
            "one after the other (StartLoad/WaitLoad/UnLoad); 0 = one module. "
            "At least 16384",
            title="Largest module (RAPID)",
        )
        module_dir: str = Field(
            "HOME:",
            pattern=r'^[^"\\]+$',
            max_length=80,
            description="RAPID: controller folder the main module loads its part modules from",
            title="Module folder (RAPID)",
        )
        # robots
        cell: str = Field(
            "",
            max_length=256,
            json_schema_extra={"x-cell-schema": cell_schema(), "x-shipped": "cells", "x-file-suffix": ".json"},
            description="Robot cell — a shipped cell name (data/cells) or a cell JSON path, as in "
            "simulate-robot — whose positioner angles go into every target as "
            "external axes: KRL E1/E2, RAPID extax eax_a/eax_b, TP group 2 J1/J2 (COORD), G-code rotary axes "
            "(`rotary_axes`); empty = no external axes",
            title="Robot cell",
        )
        positioner_policy: Literal["auto", "fixed", "gravity", "min-motion"] = Field(
            "auto",
            description="With a cell: positioner angles per point, as in simulate-robot (auto within "
            "max_lean_deg and flat_tol_deg, min-motion within max_tilt_deg; a simulate-robot "
            "fed this program plans with the same); auto fails (exit 3) naming the layer when "
            "no angles work",
            title="Positioner policy",
        )
        max_tilt_deg: float = max_tilt_field()
        max_lean_deg: float = max_lean_field()
        flat_tol_deg: float = flat_tol_field()
        tool_direction: Literal["default", "x", "z"] = Field(
            "default",
            description="Tool axis of the robot's tool frame: KRL default x, RAPID default z",
            title="Tool axis",
        )

        @field_validator("rotary_axes")
        @classmethod
        def _rotary(cls, v: list[str]) -> list[str]:
            v = [a.strip().upper() for a in v]
            bad = [a for a in v if a not in ("A", "B", "C", "U", "V", "W")]
            if bad or len(set(v)) != len(v):
                raise ValueError(f"rotary_axes {v}: distinct letters among A, B, C, U, V, W")
            return v

        @field_validator("process_codes", "process_codes_start")
        @classmethod
        def _templates(cls, v: dict[str, str]) -> dict[str, str]:
            return check_templates(v)

        @field_validator("weld_values")
        @classmethod
        def _weld_values(cls, v: dict[str, float]) -> dict[str, float]:
            from ..core.process import PARAMETERS_BY_NAME
            from ..program.common import WELD_COMMANDED

            bad = [k for k in v if k not in WELD_COMMANDED]
            if bad:
                raise ValueError(f"weld_values: {', '.join(bad)} not a weld value (one of {', '.join(WELD_COMMANDED)})")
            for k, x in v.items():
                p = PARAMETERS_BY_NAME[k]
                if not p.minimum <= x <= p.maximum or (k != "job" and x <= 0):
                    raise ValueError(f"weld_values: {k} {x} {p.unit} outside ({p.minimum}, {p.maximum}] {p.unit}")
            return v

        @field_validator("process_scale")
        @classmethod
        def _scale(cls, v: dict[str, float]) -> dict[str, float]:
            check_templates({k: "" for k in v})
            bad = {k: x for k, x in v.items() if not (math.isfinite(x) and x > 0)}
            if bad:
                raise ValueError(f"process_scale factors must be > 0: {bad}")
            return v

        @field_validator("cell")
        @classmethod
        def _cell_name(cls, v: str) -> str:
            return check_cell_param(v)

        @field_validator("arc_on", "arc_off")
        @classmethod
        def _arc_code(cls, v: str, info) -> str:
            return check_arc_code(info.field_name, v)

        @field_validator("tool_on", "tool_off")
        @classmethod
        def _tool_template(cls, v: str) -> str:
            return check_tool_template(v, "tool command") if v else v

        @field_validator("arctech_channels")
        @classmethod
        def _channels(cls, v: dict[str, int]) -> dict[str, int]:
            return check_channels(v)

    def run(self, ctx, params: Params, inputs: dict[str, Any]) -> dict[str, Any]:
        params = with_profile(params)
        plan = PlanSettings(
            ignition_dwell=params.ignition_dwell, arc_tolerance=params.arc_tolerance, travel_speed=params.travel_speed
        )
        name = _program_name(ctx, params)
        try:
            writer = _writer_settings(params, name)
        except ValueError as err:
            raise RecipeError(str(err)) from err
        world_tilt = None
        positioner = None
        if params.weld_values:
            inputs = {**inputs, "toolpath": _with_weld_values(inputs["toolpath"], params.weld_values)}
        if params.cell and isinstance(writer, CONTROLLER_SETTINGS):  # krl, rapid, gcode, tp, inform
            cell = cell_from_param(
                ctx, params.cell, meshes=params.positioner_policy == "auto"
            )  # auto checks collisions
            moves = flatten(inputs["toolpath"])
            from ..trajectory.cellplan import AutoLimits  # lazy: the catalog must not import the arm's kinematics

            angles, torch = positioner_and_torch(
                cell,
                moves,
                params.positioner_policy,
                params.max_tilt_deg,
                AutoLimits(params.max_lean_deg, params.flat_tol_deg),
            )
            positioner = {"cell": params.cell, **{k: getattr(params, k) for k in POSITIONER_PLAN_KEYS}}
            if not np.array_equal(torch, moves.tool_axis):
                # the plan leaned the torch on some layers: the program carries those axes
                moves = replace(moves, tool_axis=torch)
                inputs = {**inputs, "toolpath": moves}
            try:
                writer = replace(writer, external_axes=angles)
            except ValueError as err:
                raise RecipeError(
                    str(err), field="station_pulses_per_deg" if params.format == "inform" else "cell"
                ) from err
            if isinstance(writer, RapidSettings):
                writer = replace(writer, work_frame=_work_frame(cell))
            if params.format == "gcode" and len(moves.points):
                _, axes = to_world(cell, moves.points, moves.tool_axis, angles)
                axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
                world_tilt = float(np.degrees(np.arccos(np.clip(-axes[:, 2], -1.0, 1.0))).max())
        try:
            program = post_process(inputs["toolpath"], params.format, plan, writer)
        except ValueError as err:
            raise RecipeError(str(err)) from err
        if positioner is not None:
            program = replace(program, stats={**program.stats, "positioner": positioner}, cell=cell.model_dump_json())
        if program.stats.get("points", 0) == 0:
            ctx.warn("the toolpath has no points: the program has no motions")
        what = {
            "rapid": "RAPID welddata",
            "gcode": "G-code weld commands",
            "tp": "TP weld schedules",
            "krl": "ArcTech weld data" if params.arc_control == "arctech" else "KRL weld commands",
        }
        _warn_weld_data(ctx, program, what.get(params.format, "weld data"))
        _warn_memory(ctx, program, params)
        tilt = program.stats.get("max_tool_tilt_deg", 0.0) if world_tilt is None else world_tilt
        if params.format == "gcode" and tilt > TILT_WARN_DEG:
            if world_tilt is None:
                ctx.warn(
                    f"the toolpath tilts the torch up to {tilt:.1f}° but G-code here is 3-axis: "
                    "tool axes are ignored (use krl or rapid, or a cell with a positioner)"
                )
            else:
                ctx.warn(
                    f"under the positioner angles the torch still tilts up to {tilt:.1f}° from vertical; "
                    "the G-code torch is vertical: tool axes are ignored (use krl or rapid)"
                )
        return {"program": program}

    def read_files(self, params, read_bytes) -> list[str]:
        return cell_files(params.cell, read_bytes)

    def artifacts(self, ctx, params: Params, outputs: dict[str, Any]) -> dict[str, str | bytes]:
        program: Program = outputs["program"]
        trace = ctx.trace() if hasattr(ctx, "trace") else {}  # minimal test contexts have none
        files: dict[str, str | bytes] = dict(stamp_trace(program.format, dict(program.files), trace))
        nid = getattr(ctx, "node_id", "")
        if not nid:
            return files
        # a file named otherwise than `<node id>.<key>` (after its controller identifier): "/<name>"
        names = program.file_names(nid)
        return {(k if names[k] == f"{nid}.{k}" else "/" + names[k]): v for k, v in files.items()}
