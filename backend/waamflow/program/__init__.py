"""Post-processing: the zoned toolpath → machine/robot programs (pure writers, no engine imports).

    toolpath ─flatten→ Moves ─plan_program→ Plan ─write_gcode / write_krl / write_rapid→ text
                            │                    └─write_print_points→ compas_slicer print points JSON
                            └──────────────write_cl_csv→ CSV

`post_process` is the one entry point the `post-process` node calls. `gcode_parse.parse_gcode`
reads our G-code back (tests, program preview).
"""

from __future__ import annotations

from ..core.model import LayerPaths, Layered
from ..core.moves import Moves, flatten
from .cl import write_cl_csv
from .common import WELD_COMMANDED, weld_data_issues
from .gcode import GcodeSettings, write_gcode
from .gcode_parse import ParsedProgram, parse_gcode
from .inform import INFORM_WELD_CODES, InformSettings, write_inform
from .krl import KrlSettings, write_krl
from .plan import Plan, PlanSettings, plan_program
from .printpoints import point_layer_heights, write_print_points
from .program import Program
from .rapid import RapidSettings, write_rapid, write_rapid_modules
from .tp import TpSettings, tp_schedule_issues, write_tp

FORMATS = ("gcode", "krl", "rapid", "inform", "tp", "csv", "printpoints")

__all__ = [
    "FORMATS", "GcodeSettings", "InformSettings", "KrlSettings", "ParsedProgram", "Plan", "PlanSettings", "Program",
    "RapidSettings", "TpSettings", "parse_gcode", "plan_program", "post_process", "write_cl_csv", "write_gcode",
    "write_inform", "write_krl", "write_print_points", "write_rapid", "write_rapid_modules", "write_tp",
]


def post_process(
    toolpath: Layered[LayerPaths] | Moves,
    fmt: str,
    plan_settings: PlanSettings = PlanSettings(),
    writer_settings: GcodeSettings | KrlSettings | RapidSettings | None = None,
) -> Program:
    """Write a toolpath (or an already flattened move list) as a `Program` in format `fmt`.

    For "gcode", fitted arcs are restricted to the XY plane (G17) whatever `plan_settings` says.
    "printpoints" (one entry per toolpath point) never fits arcs; `writer_settings` there is the
    blend distance in mm (float, default 1).
    """
    if fmt not in FORMATS:
        raise ValueError(f"unknown program format {fmt!r} (one of {', '.join(FORMATS)})")
    moves = toolpath if isinstance(toolpath, Moves) else flatten(toolpath)
    if fmt == "gcode":
        from dataclasses import replace

        plan_settings = replace(plan_settings, arc_plane_normal=(0.0, 0.0, 1.0))
    if fmt in ("printpoints", "inform", "tp"):        # one entry per point / INFORM, TP: lines only
        from dataclasses import replace

        plan_settings = replace(plan_settings, arc_tolerance=0.0)
    plan = plan_program(moves, plan_settings)
    stats = dict(plan.stats, format=fmt)
    if fmt == "gcode":
        gs = writer_settings or GcodeSettings()
        files = {"gcode": write_gcode(plan, gs)}
        if gs.final_lift > 0 and len(moves.points):
            stats["motions"] += 1                      # the final lift is a motion of this program
            stats["travel_length_mm"] = round(stats["travel_length_mm"] + gs.final_lift, 3)
            stats["estimated_time_s"] = round(stats["estimated_time_s"] + gs.final_lift / plan_settings.travel_speed, 3)
    elif fmt == "krl":
        files = write_krl(plan, writer_settings or KrlSettings())
    elif fmt == "rapid":
        files = write_rapid_modules(plan, writer_settings or RapidSettings())
        if len(files) > 1:
            stats["modules"] = len(files) - 1           # part modules loaded by the main module
    elif fmt == "inform":
        files = write_inform(plan, writer_settings or InformSettings())
        stats["jobs"] = len(files) - 1                  # per-layer jobs called by the main job
    elif fmt == "tp":
        files = write_tp(plan, writer_settings or TpSettings())
        stats["subprograms"] = len(files) - 2           # per-layer programs called by the main program
        stats["weld_schedules"] = files["SCHED.CSV"].count("\n") - 1
    elif fmt == "printpoints":
        heights = point_layer_heights(None if isinstance(toolpath, Moves) else toolpath, moves)
        blend = 1.0 if writer_settings is None else float(writer_settings)
        files = {"printpoints.json": write_print_points(plan, heights, plan_settings.travel_speed, blend)}
    else:
        files = {"csv": write_cl_csv(moves)}
    stats["files"] = len(files)
    issues: tuple = ()
    if fmt == "rapid":                        # welddata carries job, voltage, wire feed, current
        issues = tuple(weld_data_issues(plan))
    elif fmt == "krl" and (writer_settings or KrlSettings()).arc_control == "arctech":
        ks = writer_settings or KrlSettings()
        issues = tuple(weld_data_issues(plan, tuple(ks.arctech_channels), tuple(ks.arctech_channels),
                                        "map it to a channel in arctech_channels"))
    elif fmt == "krl":
        ks = writer_settings or KrlSettings()
        issues = tuple(weld_data_issues(plan, commanded=tuple(k for k, v in ks.process_codes.items() if v),
                                        hint="give it a KRL statement in process_codes", empty=False))
    elif fmt == "gcode":
        gs = writer_settings or GcodeSettings()
        issues = tuple(weld_data_issues(plan, commanded=tuple(k for k, v in gs.process_codes.items() if v),
                                        hint="give it a command template in process_codes", empty=False))
    elif fmt == "inform":
        issues = tuple(weld_data_issues(plan, commanded=tuple(INFORM_WELD_CODES),
                                        hint="INFORM commands current (AC=) and voltage (AV=) inline; wire feed and "
                                             "job live in the arc start condition file / synergic line", empty=False))
    elif fmt == "tp":                         # weld schedules carry every weld value; they live on the controller
        issues = tuple(weld_data_issues(plan, commanded=WELD_COMMANDED, empty=False)) + \
            tp_schedule_issues(plan, (writer_settings or TpSettings()).program_name.upper())
    settings_cls = {"krl": KrlSettings, "rapid": RapidSettings, "inform": InformSettings, "tp": TpSettings}
    name = (writer_settings or settings_cls[fmt]()).program_name \
        if fmt in settings_cls else ""                     # the files are named after the program
    if fmt in ("inform", "tp"):
        name = name.upper()                                # job / program names are upper case on the pendant
    return Program(fmt, files, stats, issues, name)
