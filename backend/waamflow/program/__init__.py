"""Post-processing: the zoned toolpath → machine/robot programs (pure writers, no engine imports).

    toolpath ─flatten→ Moves ─plan_program→ Plan ─write_gcode / write_krl / write_rapid→ text
                            └──────────────write_cl_csv→ CSV

`post_process` is the one entry point the `post-process` node calls. `gcode_parse.parse_gcode`
reads our G-code back (tests, program preview).
"""

from __future__ import annotations

from ..core.model import LayerPaths, Layered
from ..core.moves import Moves, flatten
from .cl import write_cl_csv
from .common import weld_data_issues
from .gcode import GcodeSettings, write_gcode
from .gcode_parse import ParsedProgram, parse_gcode
from .krl import KrlSettings, write_krl
from .plan import Plan, PlanSettings, plan_program
from .program import Program
from .rapid import RapidSettings, write_rapid

FORMATS = ("gcode", "krl", "rapid", "csv")

__all__ = [
    "FORMATS", "GcodeSettings", "KrlSettings", "ParsedProgram", "Plan", "PlanSettings", "Program",
    "RapidSettings", "parse_gcode", "plan_program", "post_process", "write_cl_csv", "write_gcode",
    "write_krl", "write_rapid",
]


def post_process(
    toolpath: Layered[LayerPaths] | Moves,
    fmt: str,
    plan_settings: PlanSettings = PlanSettings(),
    writer_settings: GcodeSettings | KrlSettings | RapidSettings | None = None,
) -> Program:
    """Write a toolpath (or an already flattened move list) as a `Program` in format `fmt`.

    For "gcode", fitted arcs are restricted to the XY plane (G17) whatever `plan_settings` says.
    """
    if fmt not in FORMATS:
        raise ValueError(f"unknown program format {fmt!r} (one of {', '.join(FORMATS)})")
    moves = toolpath if isinstance(toolpath, Moves) else flatten(toolpath)
    if fmt == "gcode":
        from dataclasses import replace

        plan_settings = replace(plan_settings, arc_plane_normal=(0.0, 0.0, 1.0))
    plan = plan_program(moves, plan_settings)
    stats = dict(plan.stats, format=fmt)
    if fmt == "gcode":
        files = {"gcode": write_gcode(plan, writer_settings or GcodeSettings())}
    elif fmt == "krl":
        files = write_krl(plan, writer_settings or KrlSettings())
    elif fmt == "rapid":
        files = {"mod": write_rapid(plan, writer_settings or RapidSettings())}
    else:
        files = {"csv": write_cl_csv(moves)}
    stats["files"] = len(files)
    issues: tuple = ()
    if fmt == "rapid":
        issues = tuple(weld_data_issues(plan))
    elif fmt == "krl" and isinstance(writer_settings, KrlSettings) and writer_settings.arc_control == "arctech":
        issues = tuple(weld_data_issues(plan, tuple(writer_settings.arctech_channels)))
    return Program(fmt, files, stats, issues)
