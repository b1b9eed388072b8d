"""Read an emitted program back into welded runs — from the text as written, not the planner's objects.

One reader per format, a module each over the shared `core`: `gcode` (G-code), `krl` (KUKA KRL),
`rapid` (ABB RAPID), `inform` (Yaskawa INFORM), `tp` (Fanuc TP) and `tables` (cutter-location CSV,
compas print points, and a toolpath JSON for recipes that write no program). Each gives the same `ProgramRead`: the arc-ON runs
in program order, each with its points (mm, part frame), the programmed speed and the commanded wire
feed of every segment, and the layer/section the program's own comments put it in (for messages).

What counts as weld data is what the controller executes: a G-code command matched by the program's
`waamflow-weld:` header (`name=TEMPLATE` pairs), a KRL ArcTech weld data set's channel, an `$ANOUT`
named in the KRL header, RAPID welddata/arcdata values, a TP Arc Start's schedule in the program's
schedule table. Comments never count.
"""

from __future__ import annotations

from ...core.gcpause import paused_gc
from .core import NUM, ProgramRead, Run, RunBuilder
from .gcode import read_gcode
from .inform import read_inform
from .krl import read_krl
from .rapid import rapid_in_call_order, read_rapid
from .tables import read_cl_csv, read_printpoints, read_toolpath
from .tp import read_tp

__all__ = [
    "NUM",
    "ProgramRead",
    "Run",
    "RunBuilder",
    "rapid_in_call_order",
    "read_cl_csv",
    "read_gcode",
    "read_inform",
    "read_krl",
    "read_printpoints",
    "read_program",
    "read_rapid",
    "read_toolpath",
    "read_tp",
]


def read_program(fmt: str, files: dict[str, str]) -> ProgramRead:
    """fmt: the post-process format; files: artifact name → text. The cyclic GC is paused while
    the points are read (core/gcpause.py)."""
    with paused_gc():
        return _read_program(fmt, files)


def _read_program(fmt: str, files: dict[str, str]) -> ProgramRead:
    if fmt == "gcode":
        return read_gcode(next(iter(files.values())))
    if fmt == "krl":
        return read_krl(files)
    if fmt == "rapid":
        return read_rapid(rapid_in_call_order(files))
    if fmt == "inform":
        return read_inform(files)
    if fmt == "tp":
        return read_tp(files)
    if fmt == "csv":
        return read_cl_csv(next(iter(files.values())))
    if fmt == "printpoints":
        return read_printpoints(next(iter(files.values())))
    raise ValueError(f"preflight cannot read format {fmt!r}")
