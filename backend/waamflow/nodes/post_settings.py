"""What the post-process node makes of its params before writing: the machine profile's preset
merged in (`with_profile`), the program name, the weld values written into the toolpath, the
work frame of a cell and each format's writer settings (`_writer_settings`), and the warnings
for weld data the program lacks and for a program larger than its controller's memory.

Split from `nodes.post` (issue 27): that module declares the node (its params schema and run);
every name stays importable from there.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from ..core.errors import RecipeError
from ..program import GcodeSettings, InformSettings, KrlSettings, Program, RapidSettings, TpSettings, WriterSettings
from ..program.common import KRL_RESERVED, RAPID_RESERVED, TOOL_COMMANDS, program_identifier
from ..program.gcode import GCODE_WELD_CODES
from ..program.krl import KRL_WELD_CODES
from ..program.profiles import profile as machine_profile

# The program memory (MB, 10^6 bytes) a format's usual controller runs a program from, when the
# recipe states none (`controller_memory_mb`). KRL: a KR C4 runs programs from its RAM drive, about
# 4 MB under KSS 8.3 in field reports (robot-forum.com, "KRC4 program capacity", 2024); all of a
# program's subprograms live there at once. Others: no sourced figure, checked only when stated.
PROGRAM_MEMORY_MB = {"krl": 4.0}

if TYPE_CHECKING:  # the node's module imports this one
    from .post import PostProcess


def with_profile(params: PostProcess.Params) -> PostProcess.Params:
    """The params with the machine profile's values for every field the recipe did not set."""
    from .post import PostProcess as _Post  # the node's module imports this one

    if not params.profile:
        return params
    try:
        preset = machine_profile(params.profile)["post"]
    except ValueError as err:
        raise RecipeError(str(err)) from err
    unknown = sorted(set(preset) - set(_Post.Params.model_fields))
    if unknown:
        raise RecipeError(f"machine profile {params.profile!r} sets unknown post-process params: {', '.join(unknown)}")
    merged = {
        **{k: v for k, v in preset.items() if k not in params.model_fields_set},
        **params.model_dump(include=params.model_fields_set),
    }
    return _Post.Params.model_validate(merged)


def _with_weld_values(toolpath, values: dict[str, float]):
    """The toolpath with `values` in every welded zone's parameters that lacks them."""
    from dataclasses import replace as _replace

    from ..core.model import Layered
    from ..zoning.zones import with_weld_defaults

    layers: list[Any] = []
    for lp in toolpath.items:
        if lp is None:
            layers.append(lp)
            continue
        layers.append(_replace(lp, sections=tuple(with_weld_defaults(sp, values) for sp in lp.sections)))
    return Layered(tuple(layers))


def _warn_weld_data(ctx, program: Program, what: str) -> None:
    """One warning per zone and problem (empty / zero / missing weld data), located at the first
    section and layer where it is welded, with the number of sections affected."""
    groups: dict[tuple[str, str], list] = {}
    for issue in program.weld_issues:
        groups.setdefault((issue.zone, issue.message), []).append(issue)
    for (zone, message), issues in groups.items():
        first = issues[0]
        more = f"; {len(issues)} sections in all" if len(issues) > 1 else ""
        where = f"zone {zone}" if zone and zone != "-" else "the unzoned paths"  # no zone node: no zone id
        ctx.warn(
            f"{what} of {where} (section {first.section}, layer {first.layer}{more}): {message}",
            layer=first.layer,
            section=first.section,
        )


def _program_name(ctx, p: PostProcess.Params) -> str:
    """The program name: `program_name`, else the node id made a controller identifier (KRL ≤ 24
    characters, ≤ 16 when split so `<name>_L003_1` fits; RAPID ≤ 32, ≤ 27 so `<name>_M001`
    fits); the KRL / RAPID files are named after it (`Program.file_names`)."""
    if p.format == "krl":
        limit, reserved = (16 if p.split_per_layer or p.max_points_per_file else 24), KRL_RESERVED
    elif p.format == "rapid":  # ≤ 27 so `<name>_M001` fits when split into modules
        limit, reserved = (27 if p.max_module_bytes else 32), RAPID_RESERVED
    elif p.format == "inform":  # ≤ 24 so `<NAME>_L003_1` fits INFORM's 32
        limit, reserved = 24, frozenset()
    elif p.format == "tp":  # ≤ 24 so `<NAME>_L0003_12` and `<NAME>_SCHED` fit TP's 36
        limit, reserved = 24, frozenset()
    else:
        limit, reserved = 64, frozenset()
    if p.program_name:
        if len(p.program_name) > limit:
            raise RecipeError(
                f"program_name {p.program_name!r} is longer than {limit} characters ({p.format}"
                + (", split into subprograms" if limit == 16 else "")
                + ")"
            )
        return p.program_name
    return program_identifier(getattr(ctx, "node_id", "") or "waamflow", limit, reserved)


def _work_frame(cell) -> tuple[float, ...]:
    """The part origin on the positioner flange as (x, y, z mm, q1..q4): translation and yaw."""
    half = math.radians(cell.work_frame.yaw_deg) / 2.0
    return (*(float(v) for v in cell.work_frame.xyz_mm), math.cos(half), 0.0, 0.0, math.sin(half))


# the writer settings of the controller formats (each has tool commands and takes a cell's axes)
CONTROLLER_SETTINGS = (GcodeSettings, KrlSettings, RapidSettings, InformSettings, TpSettings)


def _writer_settings(p: PostProcess.Params, name: str) -> WriterSettings | float | None:
    """The format's writer settings (`post_process`'s): a settings class for the controller
    formats, the blend distance for printpoints, None for csv."""
    if p.format == "printpoints":
        return p.blend_distance
    if p.format not in TOOL_COMMANDS:
        return None
    direction = {"default": None, "x": "x", "z": "z"}[p.tool_direction]
    on, off = TOOL_COMMANDS[p.format]
    tool_on, tool_off = p.tool_on or on, p.tool_off or off
    if p.format == "gcode":
        return GcodeSettings(
            program_name=name,
            arc_on=p.arc_on,
            arc_off=p.arc_off,
            dwell_units=p.dwell_units,
            rapid_travel=p.rapid_travel,
            travel_speed=p.travel_speed,
            process_codes=dict(p.process_codes or GCODE_WELD_CODES),
            process_codes_start=dict(p.process_codes_start) or None,
            process_scale=dict(p.process_scale),
            travel_feed=p.travel_feed,
            rotary_axes=tuple(p.rotary_axes),
            rotary_units=p.rotary_units,
            tcp_control=p.tcp_control,
            comment_style=p.comment_style,
            feed_units=p.feed_units,
            start_code=tuple(p.start_code),
            layer_code=tuple(p.layer_code),
            end_code=tuple(p.end_code),
            final_lift=p.final_lift,
            program_end=p.program_end,
            preamble=tuple(p.preamble),
            postamble=tuple(p.postamble),
            tool_on=tool_on,
            tool_off=tool_off,
        )
    if p.format == "krl":
        return KrlSettings(
            program_name=name,
            tool=p.tool_number,
            base=p.base_number,
            blend_distance=p.blend_distance,
            travel_speed=p.travel_speed,
            arc_control=p.arc_control,
            arc_output=p.arc_output,
            tool_direction=direction or "x",
            max_points_per_file=p.max_points_per_file,
            split_per_layer=p.split_per_layer,
            process_codes=dict(p.process_codes or KRL_WELD_CODES),
            arctech_routine=p.arctech_routine,
            arctech_channels=dict(p.arctech_channels),
            arctech_velocity_unit=p.arctech_velocity_unit,
            tool_on=tool_on,
            tool_off=tool_off,
        )
    if p.format == "rapid":
        return RapidSettings(
            program_name=name,
            tool=p.tool_name,
            wobj=p.wobj_name,
            positioner_unit=p.positioner_unit,
            blend_distance=p.blend_distance,
            travel_speed=p.travel_speed,
            max_module_bytes=p.max_module_bytes,
            module_dir=p.module_dir,
            tool_direction=direction or "z",
            tool_on=tool_on,
            tool_off=tool_off,
        )
    if p.format == "inform":
        return InformSettings(
            program_name=name,
            tool=p.tool_number,
            user_frame=max(1, p.base_number),
            travel_speed=p.travel_speed,
            position_level=p.position_level if p.blend_distance > 0 else 0,
            station_pulses_per_deg=tuple(p.station_pulses_per_deg),
            tool_on=tool_on,
            tool_off=tool_off,
        )
    if p.format == "tp":
        return TpSettings(
            program_name=name,
            tool=p.tool_number,
            user_frame=p.base_number,
            travel_speed=p.travel_speed,
            cnt=p.cnt if p.blend_distance > 0 else 0,
            tool_on=tool_on,
            tool_off=tool_off,
        )
    raise ValueError(f"post-process: no writer settings for format {p.format!r}")  # a new TOOL_COMMANDS format


def _warn_memory(ctx: Any, program: Program, params: PostProcess.Params) -> None:
    """A warning when the program's files exceed the controller's program memory
    (`controller_memory_mb`, else `PROGRAM_MEMORY_MB` of the format)."""
    limit = params.controller_memory_mb
    if limit is None:
        limit = PROGRAM_MEMORY_MB.get(params.format)
    if not limit:
        return
    size = sum(len(t.encode("utf-8")) for t in program.files.values())
    if size <= limit * 1e6:
        return
    n = len(program.files)
    ctx.warn(
        f"the program is {size / 1e6:.2f} MB in {n} file{'s' if n != 1 else ''}, over the controller's "
        f"{limit:g} MB of program memory (controller_memory_mb): it will not load whole. Load it layer by layer "
        "(split_per_layer, and a loader such as KUKA's DirLoader that swaps layers in), stream it (EthernetKRL, "
        "RSI), or build the part in parts"
    )
