"""Post-processing: the zoned toolpath → machine/robot programs (pure writers, no engine imports).

    toolpath ─flatten→ Moves ─plan_program→ Plan ─write_gcode / write_krl / write_rapid→ text
                            │                    └─write_print_points→ compas_slicer print points JSON
                            └──────────────write_cl_csv→ CSV

`post_process` is the one entry point the `post-process` node calls. `gcode_parse.parse_gcode`
reads our G-code back (tests, program preview).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TypeVar, Union

from ..core.gcpause import paused_gc
from ..core.model import LayerPaths, Layered
from ..core.moves import Moves, flatten
from .cl import write_cl_csv
from .common import WELD_COMMANDED, WeldDataIssue, weld_data_issues
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
    "FORMATS",
    "GcodeSettings",
    "InformSettings",
    "KrlSettings",
    "ParsedProgram",
    "Plan",
    "PlanSettings",
    "Program",
    "RapidSettings",
    "TpSettings",
    "parse_gcode",
    "plan_program",
    "post_process",
    "write_cl_csv",
    "write_gcode",
    "write_inform",
    "write_krl",
    "write_print_points",
    "write_rapid",
    "write_rapid_modules",
    "write_tp",
]

#: the settings of a program writer (post_process: the one of the format)
WriterSettings = Union[GcodeSettings, KrlSettings, RapidSettings, InformSettings, TpSettings]
_S = TypeVar("_S", GcodeSettings, KrlSettings, RapidSettings, InformSettings, TpSettings)


def post_process(
    toolpath: Layered[LayerPaths] | Moves,
    fmt: str,
    plan_settings: PlanSettings = PlanSettings(),
    writer_settings: WriterSettings | float | None = None,
) -> Program:
    """Write a toolpath (or an already flattened move list) as a `Program` in format `fmt`.

    `writer_settings` is the format's settings class (GcodeSettings for "gcode", ...; None: its
    defaults; another class is a TypeError naming the one expected). For "gcode", fitted arcs
    are restricted to the XY plane (G17) whatever `plan_settings` says. "printpoints" (one entry
    per toolpath point) never fits arcs; `writer_settings` there is the blend distance in mm
    (float, default 1). "csv" takes no writer settings.
    """
    if fmt not in FORMATS:
        raise ValueError(f"unknown program format {fmt!r} (one of {', '.join(FORMATS)})")
    with paused_gc():  # a Motion per point, a line per motion: no cycles (core/gcpause.py)
        return _post_process(toolpath, fmt, plan_settings, writer_settings)


def _post_process(
    toolpath: Layered[LayerPaths] | Moves,
    fmt: str,
    plan_settings: PlanSettings,
    writer_settings: WriterSettings | float | None,
) -> Program:
    moves = toolpath if isinstance(toolpath, Moves) else flatten(toolpath)
    if fmt == "gcode":
        plan_settings = replace(plan_settings, arc_plane_normal=(0.0, 0.0, 1.0))
    if fmt in ("printpoints", "inform", "tp"):  # one entry per point / INFORM, TP: lines only
        plan_settings = replace(plan_settings, arc_tolerance=0.0)
    plan = plan_program(moves, plan_settings)
    stats = dict(plan.stats, format=fmt)
    issues: tuple[WeldDataIssue, ...] = ()
    name = ""  # the files are named after the program
    if fmt == "gcode":
        gs = _writer(fmt, GcodeSettings, writer_settings)
        files = {"gcode": write_gcode(plan, gs)}
        if gs.final_lift > 0 and len(moves.points):
            stats["motions"] += 1  # the final lift is a motion of this program
            stats["travel_length_mm"] = round(stats["travel_length_mm"] + gs.final_lift, 3)
            stats["estimated_time_s"] = round(stats["estimated_time_s"] + gs.final_lift / plan_settings.travel_speed, 3)
        issues = tuple(
            weld_data_issues(
                plan,
                commanded=tuple(k for k, v in gs.process_codes.items() if v),
                hint="give it a command template in process_codes",
                empty=False,
            )
        )
    elif fmt == "krl":
        ks = _writer(fmt, KrlSettings, writer_settings)
        files = write_krl(plan, ks)
        issues = _krl_issues(plan, ks)
        name = ks.program_name
    elif fmt == "rapid":
        rs = _writer(fmt, RapidSettings, writer_settings)
        files = write_rapid_modules(plan, rs)
        if len(files) > 1:
            stats["modules"] = len(files) - 1  # part modules loaded by the main module
        issues = tuple(weld_data_issues(plan))  # welddata carries job, voltage, wire feed, current
        name = rs.program_name
    elif fmt == "inform":
        js = _writer(fmt, InformSettings, writer_settings)
        files = write_inform(plan, js)
        stats["jobs"] = len(files) - 1  # per-layer jobs called by the main job
        issues = tuple(
            weld_data_issues(
                plan,
                commanded=tuple(INFORM_WELD_CODES),
                hint="INFORM commands current (AC=) and voltage (AV=) inline; wire feed and "
                "job live in the arc start condition file / synergic line",
                empty=False,
            )
        )
        name = js.program_name.upper()  # job names are upper case on the pendant
    elif fmt == "tp":
        ts = _writer(fmt, TpSettings, writer_settings)
        files = write_tp(plan, ts)
        stats["subprograms"] = len(files) - 2  # per-layer programs called by the main program
        stats["weld_schedules"] = files["SCHED.CSV"].count("\n") - 1
        # weld schedules carry every weld value; they live on the controller
        issues = tuple(weld_data_issues(plan, commanded=WELD_COMMANDED, empty=False)) + tp_schedule_issues(
            plan, ts.program_name.upper()
        )
        name = ts.program_name.upper()  # program names are upper case on the pendant
    elif fmt == "printpoints":
        heights = point_layer_heights(None if isinstance(toolpath, Moves) else toolpath, moves)
        files = {
            "printpoints.json": write_print_points(plan, heights, plan_settings.travel_speed, _blend(writer_settings))
        }
    else:
        files = {"csv": write_cl_csv(moves)}
    stats["files"] = len(files)
    return Program(fmt, files, stats, issues, name)


def _writer(fmt: str, cls: type[_S], given: object) -> _S:
    """The writer settings of format `fmt`: `given`, or the class's defaults when None."""
    if given is None:
        return cls()
    if not isinstance(given, cls):
        raise TypeError(f"post_process({fmt!r}): writer_settings must be {cls.__name__}, not {type(given).__name__}")
    return given


def _blend(given: object) -> float:
    """The print points' blend distance (mm): `given`, 1 when None."""
    if given is None:
        return 1.0
    if not isinstance(given, (int, float)):
        raise TypeError(
            f"post_process('printpoints'): writer_settings is the blend distance in mm, not {type(given).__name__}"
        )
    return float(given)


def _krl_issues(plan: Plan, ks: KrlSettings) -> tuple[WeldDataIssue, ...]:
    """ArcTech: every mapped channel must carry a value; output mode: the weld values without a
    KRL statement in process_codes."""
    if ks.arc_control == "arctech":
        return tuple(
            weld_data_issues(
                plan, tuple(ks.arctech_channels), tuple(ks.arctech_channels), "map it to a channel in arctech_channels"
            )
        )
    return tuple(
        weld_data_issues(
            plan,
            commanded=tuple(k for k, v in ks.process_codes.items() if v),
            hint="give it a KRL statement in process_codes",
            empty=False,
        )
    )
