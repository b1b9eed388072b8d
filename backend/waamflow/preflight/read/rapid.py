"""ABB RAPID read back: robtargets, speeddata and ArcWare welddata/arcdata; a program of several
modules in the order main() loads and calls them."""

from __future__ import annotations

import math
import re
from typing import Iterator, NamedTuple

import numpy as np

from ...program.common import WELD_COMMANDED
from .core import NUM, ProgramRead, RunBuilder, circle_through
from .orient import axes_quaternion, tool_column

_Q = r")\s*,\s*("  # between two numbers of a list
_ROBT = re.compile(  # name, x, y, z and, when they follow, the orientation q1..q4 and the extax list
    r"robtarget\s+(\w+)\s*:=\s*\[\s*\[\s*(" + NUM + _Q + NUM + _Q + NUM + r")\s*\]"
    r"(?:\s*,\s*\[\s*(" + NUM + _Q + NUM + _Q + NUM + _Q + NUM + r")\s*\]"
    r"(?:\s*,\s*\[[^\]]*\]\s*,\s*\[([^\]]*)\])?)?",
    re.IGNORECASE,
)
_UNUSED_AXIS = 8.9e9  # RAPID's 9E9: an external axis the robtarget does not use
_SEAM = re.compile(  # name, purge, preflow, ign_arc (an arcdata), ign_move_delay (s: the dwell after ignition)
    r"seamdata\s+(\w+)\s*:=\s*\[\s*(" + NUM + _Q + NUM + r")\s*,\s*\[([^\]]*)\]\s*,\s*(" + NUM + ")",
    re.IGNORECASE,
)
_WAIT = re.compile(r"^\s*WaitTime\b(?:\\InPos)?\s*,?\s*(" + NUM + r")\s*;", re.IGNORECASE)
_SPEED = re.compile(r"speeddata\s+(\w+)\s*:=\s*\[\s*(" + NUM + ")", re.IGNORECASE)
_WELD = re.compile(
    r"welddata\s+(\w+)\s*:=\s*\[\s*(" + NUM + r")\s*,\s*(" + NUM + r")\s*,\s*\[([^\]]*)\]", re.IGNORECASE
)
_RAPID_MOVE = re.compile(
    r"^\s*(MoveL|MoveJ|MoveC|ArcLStart|ArcL|ArcLEnd|ArcC|ArcCStart|ArcCEnd)\s+(.*?);", re.IGNORECASE
)
_ARCDATA_DEFAULT = ("job", "mode", "voltage", "wire_feed_speed", "control", "current")


class _RapidWeld(NamedTuple):
    """A welddata declaration: its weld speed (mm/s) and the non-zero weld values of its arcdata."""

    speed: float
    values: dict[str, float]


def read_rapid(text: str) -> ProgramRead:
    low = text.lower()  # declarations found by a plain search: a 10 MB program's regex scans cost 0.1-0.2 s each
    found = [m.groups() for k in _starts(low, "robtarget") if (m := _ROBT.match(text, k))]
    pts = {f[0].lower(): np.array([float(f[1]), float(f[2]), float(f[3])]) for f in found}
    quats = [f for f in found if f[4]]
    axes = dict(
        zip(
            (q[0].lower() for q in quats),
            axes_quaternion(np.array([q[4:8] for q in quats], float), tool_column(text[:4000], "z")),
        )
    )
    ext = _extaxes(found)
    speeds = {n.lower(): float(v) for n, v in _SPEED.findall(text)}
    builtin = {f"v{v}": float(v) for v in (5, 10, 20, 30, 40, 50, 60, 80, 100, 150, 200, 300, 400, 500, 600, 800, 1000)}
    fields: tuple[str, ...] = _ARCDATA_DEFAULT
    m = re.search(r"arcdata\s*=\s*\[([^\]]*)\]", text)
    if m:
        fields = tuple(
            (
                "wire_feed_speed"
                if "wirefeed" in f
                else "current"
                if "current" in f
                else "voltage"
                if "voltage" in f and "2" not in f
                else "job"
                if "job" in f
                else f.strip()
            )
            for f in m.group(1).split(",")
        )
    welds: dict[str, _RapidWeld] = {}
    for name, speed, _org, main in _WELD.findall(text):
        numbers = [float(v) for v in re.findall(NUM, main)]
        welds[name.lower()] = _RapidWeld(
            float(speed), {f: v for f, v in zip(fields, numbers) if f in WELD_COMMANDED and v != 0.0}
        )
    seams = {}  # seamdata → (ign_move_delay s, the ignition arcdata's wire feed m/min or nan)
    found_seams = (m.groups() for k in _starts(low, "seamdata") if (m := _SEAM.match(text, k)))
    for name, _purge, _pre, ign, delay in found_seams:
        ign_vals = {f: float(v) for f, v in zip(fields, re.findall(NUM, ign)) if float(v) != 0.0}  # as welddata's
        seams[name.lower()] = (float(delay), ign_vals.get("wire_feed_speed", math.nan))
    b = RunBuilder("rapid")
    wfs = math.nan  # the wire feed of the last weld motion (a WaitTime with the arc on feeds it)
    tail = None  # the last motion's last argument (tool and work object)
    for ln, raw in enumerate(text.splitlines(), start=1):
        code, _, comment = raw.partition("!")
        if comment.strip():
            b.comment(comment.strip())
        m = _RAPID_MOVE.match(code)
        if not m:
            w = _WAIT.match(code)
            if w:
                b.dwell(float(w.group(1)), wfs)
            continue
        instr = m.group(1).lower()
        split = _SPLIT_CALL if "(" in m.group(2) else _SPLIT  # commas outside [...] (and (...) of Offs etc.)
        args = [a.strip() for a in split.split(m.group(2))]
        names = [a.split("\\")[0].lower() for a in args]
        circ = instr in ("movec", "arcc", "arccstart", "arccend")
        if args and args[-1] != tail:  # the tool and work object: the same on most motions, parsed once
            tail = args[-1]
            wobj = re.search(r"\\WObj\s*:=\s*(\w+)", tail, re.IGNORECASE)
            b.frame("work object", wobj.group(1).lower() if wobj else "wobj0", f"line {ln}")
            b.frame("tool", tail.split("\\")[0].strip().lower(), f"line {ln}")
        at = [pts[t] if t in pts else _target(t, pts) for t in (names[:2] if circ else names[:1])]
        if any(p is None for p in at):
            b.unplaced(
                f"line {ln}: {code.strip()}: a target the preflight cannot place ({', '.join(args[: 2 if circ else 1])})"
            )
            continue
        seg = np.vstack([p for p in at if p is not None])
        if circ and b.pos is not None:  # the circle from where the robot is, through the first target, to the second
            seg = circle_through(b.pos, seg[0], seg[1])
        last = names[1 if circ else 0]
        b.axis = axes.get(last if last in axes else _base_name(last))
        target_ext = ext.get(last if last in ext else _base_name(last))
        if target_ext is not None:
            b.positioner(target_ext)
        sp = names[2 if circ else 1] if len(names) > (2 if circ else 1) else ""
        weld = next((welds[n] for n in names if n in welds), None)
        speed = speeds.get(sp, builtin.get(sp, math.nan))
        if weld is not None and weld.speed:
            speed = weld.speed  # ArcWare: the weld speed of welddata governs the weld
        vals = dict(weld.values) if weld is not None else {}
        if instr in ("arclstart", "arccstart"):
            b.move(seg, math.nan, math.nan, False)  # moves to the start, the arc strikes there
            b.arc_on(ln)
            b.dwell(*next((seams[n] for n in names if n in seams), (0.0, math.nan)))  # ign_move_delay, arc on
            continue
        wfs = vals.get("wire_feed_speed", math.nan)
        b.move(seg, speed, wfs, bool(vals))
        if instr in ("arclend", "arccend"):
            b.close()
    b.close()
    return b.out


_SPLIT = re.compile(r",(?![^\[]*\])")
_SPLIT_CALL = re.compile(r",(?![^\[(]*[\])])")
_OFFS = re.compile(
    r"offs\s*\(\s*(\w+)\s*,\s*(" + NUM + r")\s*,\s*(" + NUM + r")\s*,\s*(" + NUM + r")\s*\)", re.IGNORECASE
)


def _extaxes(found: list[tuple]) -> dict[str, tuple[float, ...]]:
    """Robtarget name → its extax values (`_extax`) of the robtargets that use an external axis,
    each distinct list's text parsed once (a layer's targets repeat it)."""
    ext_of: dict[str, tuple[float, ...] | None] = {}
    out = {}
    for f in found:
        if f[8]:
            if f[8] not in ext_of:
                ext_of[f[8]] = _extax(f[8])
            if (values := ext_of[f[8]]) is not None:
                out[f[0].lower()] = values
    return out


def _extax(text: str) -> tuple[float, ...] | None:
    """A robtarget's extax list as values (degrees for a positioner's axes); 9E9 (unused): nan;
    None when it uses none."""
    v = tuple(x if abs(x) < _UNUSED_AXIS else math.nan for x in map(float, re.findall(NUM, text)))
    return v if any(math.isfinite(x) for x in v) else None


def _target(arg: str, pts: dict[str, np.ndarray]) -> np.ndarray | None:
    """Where a motion's target argument lies when it is not a declared robtarget's name (the caller
    looks those up): `Offs(p, dx, dy, dz)` of one (its offset added in the work object); None for
    anything else (RelTool, CRobT, an expression)."""
    m = _OFFS.fullmatch(arg.strip())
    if m and m.group(1).lower() in pts:
        return pts[m.group(1).lower()] + np.array([float(m.group(k)) for k in (2, 3, 4)])
    return None


def _starts(low: str, word: str) -> Iterator[int]:
    """Where `word` (lower case) begins in `low` (the text in lower case)."""
    k = low.find(word)
    while k >= 0:
        yield k
        k = low.find(word, k + len(word))


def _base_name(arg: str) -> str:
    """The robtarget an `Offs(p, ...)` argument offsets (its orientation is p's); else the argument."""
    m = _OFFS.fullmatch(arg.strip())
    return m.group(1).lower() if m else arg


_MODULE = re.compile(r"^\s*MODULE\s+(\w+)", re.IGNORECASE | re.MULTILINE)
_LATE_CALL = re.compile(r'^\s*%"(\w+)"%\s*;', re.MULTILINE)


def rapid_in_call_order(files: dict[str, str]) -> str:
    """The text of a RAPID program of several modules in the order it runs: the main module (the
    one with `PROC main`), then each module whose routine main() calls by late binding
    (`%"name"%;`, the routine named like its module, loaded by StartLoad/WaitLoad), in call
    order; modules not called follow in file-name order."""
    texts = list(files.values())
    if len(texts) == 1:
        return texts[0]
    by_module = {m.group(1).lower(): t for t in texts if (m := _MODULE.search(t))}
    main = next((t for t in texts if re.search(r"^\s*PROC\s+main\s*\(", t, re.IGNORECASE | re.MULTILINE)), texts[0])
    order = [main] + [by_module[c.lower()] for c in _LATE_CALL.findall(main) if c.lower() in by_module]
    order += [t for t in texts if not any(t is o for o in order)]
    return "\n".join(order)
