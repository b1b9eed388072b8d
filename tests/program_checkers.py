"""Independent readers of our programs, one per format, for the program matrix
(`tests/program/test_program_matrix.py`) and any test that wants a second opinion.

`PROGRAM_CHECKERS[format](files, post_params)` checks the program files of one post-process node
(artifact suffix → text) and returns what it measured: at least `points` (motions read) and, where
the format says so, `deposition_length_mm`, `travel_length_mm`, `dwell_total_s`,
`estimated_time_s`, `rotary` (letter → values per motion). KRL and RAPID use the parsers in
`tests/program/krl_check.py` / `rapid_check.py`; the matrix calls whatever is registered.

G-code goes through pygcode (an independent G-code parser and machine-state interpreter, not our
`gcode_parse`): every line must parse, every word must belong to a code pygcode knows except the
machine's own arc ON/OFF words, and the interpreted motions give lengths, dwell and time.
"""

from __future__ import annotations

import math
import re

import numpy as np
from pygcode import GCodeArcMove, GCodeDwell, GCodeFeedRate, GCodeLinearMove, GCodeRapidMove, Line, Machine

_TAG = re.compile(
    r"waamflow-post:\s*arc_on=(\S+)\s+arc_off=(\S+)\s+dwell_units=(ms|s)\s+"
    r"feed_units=(mm/min|mm/s)\s+end=([^\s)]+)"
)
_WELD_ITEM = re.compile(r'\w+\[[^\]]*\](?:\*[-+\d.eE]+)?(?:@start)?="([^"]*)"')


def weld_command_patterns(text: str) -> list[re.Pattern]:
    """The weld commands the program's `waamflow-weld:` lines declare, as whole-line patterns
    (each {…} field a number): lines matching one set a power-source value, no motion."""
    line = " ".join(ln for ln in text.splitlines() if "waamflow-weld:" in ln)
    pats = []
    for tpl in _WELD_ITEM.findall(line):
        if "{" in tpl:
            pieces = re.split(r"\{[^}]*\}", tpl)
            pats.append(re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)".join(re.escape(x) for x in pieces) + "$"))
    return pats


class _Machine(Machine):
    axes = set("XYZABCUVW")


def _assigned_words(block) -> set[str]:
    out = set()
    for gc in block.gcodes:
        out.add(str(gc.word))
        out.update(str(w) for w in gc.params.values())
    out.update(str(w) for w in block.modal_params)
    return out


def check_gcode(files: dict[str, str], post: dict) -> dict:
    """Parse and interpret a G-code program with pygcode; see module doc."""
    (text,) = files.values()
    tag = _TAG.search(text)
    assert tag, "no waamflow-post header line"
    arc_on, arc_off, end = (tag.group(i).replace("_", " ") for i in (1, 2, 5))
    dwell_scale = 1e-3 if tag.group(3) == "ms" else 1.0
    feed_per_s = 1.0 / 60.0 if tag.group(4) == "mm/min" else 1.0
    travel_speed = float(post.get("travel_speed", 100.0))
    own_lines = [
        arc_on,
        arc_off,
        end,
        *post.get("start_code", ()),
        *post.get("end_code", ()),
        *(tpl.split()[0] for tpl in (post.get("process_codes") or {}).values() if tpl.split()),
    ]
    own = {str(w) for code in own_lines for w in Line(code).block.words}
    from waamflow.program.common import TOOL_COMMANDS  # a rolling/peening tool's own codes (M110 P… Q…)

    tool_heads = {
        ln.split()[0]
        for key, default in zip(("tool_on", "tool_off"), TOOL_COMMANDS["gcode"])
        for ln in (post.get(key) or default).splitlines()
        if ln.split()
    }
    weld_cmds = weld_command_patterns(text)
    m = _Machine()
    pos = np.zeros(3)
    arc = False
    feed = None
    dep = trav = dwell = t = 0.0
    points = 0
    rotary: dict[str, list[float]] = {}
    ended = False
    for ln, raw in enumerate(text.splitlines(), 1):
        line = Line(raw)  # raises on anything pygcode cannot read
        code = re.sub(r"\([^)]*\)", " ", raw).split(";")[0].strip()
        if code == end:  # the profile's program end (M30, M2, Marlin's M84)
            ended = True
            continue
        if code in (arc_on, arc_off):
            arc = code == arc_on
            continue
        if code.split() and code.split()[0] in tool_heads:
            continue  # the tool's engage/lift codes: no motion
        if any(p.match(code) for p in weld_cmds):
            continue  # a weld value (M67/M68, M106 P1 S…, G65 P9100 …): no motion
        block = line.block
        unknown = {str(w) for w in block.words} - _assigned_words(block)
        assert unknown <= own, f"line {ln}: words pygcode does not know: {sorted(unknown)} in {raw!r}"
        words = {str(w) for w in block.words}
        if words and words <= own and not any(w[0] in "XYZ" for w in words):
            continue  # the machine's own codes (e.g. Marlin's M107, M84): no motion
        for gc in block.gcodes:
            if isinstance(gc, GCodeFeedRate):
                feed = float(gc.word.value)
            if isinstance(gc, GCodeDwell):
                d = float(gc.P) * dwell_scale
                dwell += d
                t += d
        if any(str(gc.word) in ("M30", "M02", "M2") for gc in block.gcodes):
            ended = True
        m.process_block(block)
        motion = next(
            (gc for gc in block.gcodes if isinstance(gc, (GCodeLinearMove, GCodeRapidMove, GCodeArcMove))), None
        )
        if motion is None:
            continue
        new = np.array([m.pos.X, m.pos.Y, m.pos.Z], float)
        if isinstance(motion, GCodeArcMove):
            c = pos[:2] + np.array([float(motion.I or 0.0), float(motion.J or 0.0)])
            a0 = math.atan2(pos[1] - c[1], pos[0] - c[0])
            a1 = math.atan2(new[1] - c[1], new[0] - c[0])
            sweep = (a1 - a0) % (2 * math.pi)
            if str(motion.word) in ("G02", "G2"):
                sweep = (a0 - a1) % (2 * math.pi)
            r = float(np.hypot(*(pos[:2] - c)))
            length = math.hypot(r * sweep, new[2] - pos[2])
        else:
            length = float(np.linalg.norm(new - pos))
        if points == 0:  # the move to the start point: from wherever the machine is
            length = 0.0
        if isinstance(motion, GCodeRapidMove):
            speed = travel_speed
        else:
            assert feed, f"line {ln}: motion without a feed"
            speed = feed * feed_per_s
        t += length / speed
        if arc:
            dep += length
        else:
            trav += length
        for letter in sorted(m.axes - set("XYZ")):
            if any(w.letter == letter for w in block.words):
                rotary.setdefault(letter, [])
        for letter in rotary:
            rotary[letter].append(float(getattr(m.pos, letter)))
        pos = new
        points += 1
    assert ended, "no M30/M2 at the end"
    assert not arc, "the program ends with the arc on"
    return {
        "points": points,
        "deposition_length_mm": dep,
        "travel_length_mm": trav,
        "dwell_total_s": dwell,
        "estimated_time_s": t,
        "rotary": rotary,
        "final_z": float(pos[2]),
    }


def check_krl(files: dict[str, str], post: dict) -> dict:
    """KRL: the token/statement parser `tests/program/krl_check.py` (helper robotprog's) on every
    .src/.dat pair, then the structural checker of the curved tests (E6POS fields X..C E1..E6)."""
    from curved.test_nodes import _krl_structure
    from krl_check import parse_program

    points = motions = 0
    for suffix, src in files.items():
        if not suffix.endswith("src"):
            continue
        dat = files[suffix[:-3] + "dat"]
        prog = parse_program(src, dat)
        motions += len(prog.motions())
        points += len(_krl_structure(src, dat)["X"])
    return {"points_declared": points, "motions": motions}


def check_rapid(files: dict[str, str], post: dict) -> dict:
    """RAPID (files: file name → text, every module of the program): the recursive-descent parser
    `tests/program/rapid_check.py` (modules named like their files, late-bound part modules; declarations, aggregate
    shapes, every motion/ArcWare instruction's argument types)."""
    from rapid_check import NUM, parse_program

    from waamflow.program.common import TOOL_COMMANDS

    units = (post.get("positioner_unit") or "STN1",) if post.get("cell") else ()
    routines = {}  # the rolling/peening tool's routines, declared on the controller
    for key, default in zip(("tool_on", "tool_off"), TOOL_COMMANDS["rapid"]):
        for line in (post.get(key) or default).splitlines():
            name, _, args = line.strip().rstrip(";").partition(" ")
            routines[name] = [NUM] * len([a for a in args.split(",") if a.strip()])
    mods = parse_program(files, tool=post.get("tool_name", "tWeldGun"), units=units, routines=routines)
    robtargets = {n for mod in mods for n, (_st, typ, _v) in mod.data.items() if typ == "robtarget"}
    motions = sum(len(mod.calls("MoveL", "MoveC", "ArcLStart", "ArcL", "ArcLEnd", "ArcC", "ArcCEnd")) for mod in mods)
    return {"points_declared": len(robtargets), "motions": motions, "modules": len(mods)}


def check_inform(files: dict[str, str], post: dict) -> dict:
    """INFORM (files: key → job text): `tests/program/inform_check.py` on every job."""
    from inform_check import check_program

    return check_program(files)


def check_tp(files: dict[str, str], post: dict) -> dict:
    """Fanuc TP (files: key → text, the .LS programs and the schedule table):
    `tests/program/tp_check.py`."""
    from tp_check import check_program

    return check_program(files)


PROGRAM_CHECKERS = {
    "gcode": check_gcode,
    "krl": check_krl,
    "rapid": check_rapid,
    "inform": check_inform,
    "tp": check_tp,
}
