"""KUKA KRL read back: the .src files in call order, E6POS points from each .dat, the arc by the
header's digital output or ArcTech calls, weld values from $ANOUT statements or weld data sets."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from ...program.common import parse_weld_tag
from .core import NUM, ProgramRead, RunBuilder, circle_through
from .orient import axes_euler, tool_column

_E6 = re.compile(r"DECL\s+E6POS\s+(\w+)\s*=\s*\{([^}]*)\}", re.IGNORECASE)
_FIELD = re.compile(r"([A-Z]\w*)\s+(" + NUM + ")", re.IGNORECASE)
_WDAT = re.compile(r"DECL\s+stArcDat_T\s+(\w+)\s*=\s*\{(.*)\}\s*$", re.IGNORECASE)
_CHANNELS = re.compile(r"channels\s+([^)]*?)\)")
_ANOUT_TAG = re.compile(r"\$ANOUT\[(\d+)\]")


_E_AXES = tuple(f"E{k}" for k in range(1, 7))


def _krl_targets(
    dat: str, column: int
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict[str, tuple[float, ...]]]:
    """E6POS name → position; → tool axis (unit, base frame) of the points that state A, B, C;
    → external axes E1..E6 (nan where not stated) of the points that state one."""
    pts, names, abc, ext = {}, [], [], {}
    for name, body in _E6.findall(dat):
        f = {k.upper(): float(v) for k, v in _FIELD.findall(body)}
        pts[name.upper()] = np.array([f.get("X", 0.0), f.get("Y", 0.0), f.get("Z", 0.0)])
        if {"A", "B", "C"} <= f.keys():
            names.append(name.upper())
            abc.append((f["A"], f["B"], f["C"]))
        if "E1" in f:
            ext[name.upper()] = tuple(f.get(e, math.nan) for e in _E_AXES)
    return pts, (dict(zip(names, axes_euler(np.array(abc), "ZYX", column))) if names else {}), ext


def _krl_wdat(dat: str, channels: dict[int, str]) -> tuple[dict[str, dict[str, float]], dict[str, tuple[float, float]]]:
    """The ArcTech weld data sets (`stArcDat_T`) of a .dat, in one pass: set → the non-zero
    weld values of its `Weld` block (channel → parameter), and set → (`Strike.StartTime` s: the
    dwell after ignition, the Strike wire feed m/min or nan) of the sets with a start time."""
    welds, strikes = {}, {}
    for line in dat.splitlines():
        m = _WDAT.search(line)
        if not m:
            continue
        name = m.group(1).upper()
        weld = re.search(r"Weld\s*\{([^}]*)\}", m.group(2))
        if weld:
            f = dict(_FIELD.findall(weld.group(1)))
            vals = {}
            for ch, param in channels.items():
                v = f.get(f"Channel{ch}")
                if v is not None and float(v) != 0.0:
                    vals[param] = float(v)
            welds[name] = vals
        strike = re.search(r"Strike\s*\{([^}]*)\}", m.group(2))
        f = dict(_FIELD.findall(strike.group(1))) if strike else {}
        if "StartTime" in f:
            wfs = next((f.get(f"Channel{ch}") for ch, param in channels.items() if param == "wire_feed_speed"), None)
            strikes[name] = (float(f["StartTime"]), float(wfs) if wfs is not None else math.nan)
    return welds, strikes


@dataclass
class _KrlState:
    """What a KRL program has set so far: $VEL.CP (mm/s), the analog outputs' weld values
    (parameter → value) and the ArcTech weld data set in force."""

    vel: float = math.nan
    values: dict[str, float] = field(default_factory=dict)
    wdat: str | None = None


@dataclass(frozen=True)
class _KrlHeader:
    """What the main program's header says: its file, the ArcTech channels (number → parameter),
    the `$ANOUT[n]` weld outputs (n → parameter) and the arc's digital output number (None: ArcTech)."""

    main: str
    channels: dict[int, str]
    anout: dict[str, str]
    out_no: str | None
    column: int  # the tool frame's column along the torch (`tool direction X`, KUKA's default)


def _krl_header(srcs: dict[str, str], by_def: dict[str, str]) -> _KrlHeader:
    """The main program (the DEF no other file calls) and what its header declares."""
    called = set()
    for t in srcs.values():
        called |= {c.upper() for c in re.findall(r"^\s*(\w+)\(\s*\)\s*$", t, re.MULTILINE)}
    mains = [n for d, n in by_def.items() if d not in called]
    main = mains[0] if mains else next(iter(srcs))
    header = srcs[main]
    channels: dict[int, str] = {}
    m = _CHANNELS.search(header)
    if m:
        for ch, name in re.findall(r"(\d+)\s+(\w+)", m.group(1)):
            channels[int(ch)] = name
    anout: dict[str, str] = {}  # `$ANOUT[n]` → parameter, from the header's waamflow-weld tag
    for name, e in parse_weld_tag(header).items():
        for tpl in e["commands"]:
            a = _ANOUT_TAG.search(tpl)
            if a:
                anout[a.group(1)] = name
    out_m = re.search(r"digital output \$OUT\[(\d+)\]", header)
    return _KrlHeader(main, channels, anout, out_m.group(1) if out_m else None, tool_column(header, "x"))


class _KrlReader:
    """Walks the .src files from the main program through its subprogram calls, statement by
    statement, into a `RunBuilder`."""

    def __init__(self, srcs: dict[str, str], dats: dict[str, str], by_def: dict[str, str], head: _KrlHeader) -> None:
        self.srcs, self.dats, self.by_def, self.head = srcs, dats, by_def, head
        self.b = RunBuilder("krl")
        self.state = _KrlState()
        self.axes: dict[str, np.ndarray] = {}  # the file being walked: E6POS name → tool axis
        self.ext: dict[str, tuple[float, ...]] = {}  # the file being walked: E6POS name → E1..E6
        self.strikes: dict[str, tuple[float, float]] = {}  # ArcTech set → (Strike.StartTime, its wire feed)

    def walk(self, name: str, depth: int = 0) -> None:
        if depth > 4:
            return
        text = self.srcs[name]
        stem = name[:-4]
        pts, axes, ext = _krl_targets(self.dats.get(stem, ""), self.head.column)
        wdats, strikes = _krl_wdat(self.dats.get(stem, ""), self.head.channels)
        self.strikes.update(strikes)
        caller, self.axes = self.axes, axes
        caller_ext, self.ext = self.ext, ext
        for ln, raw in enumerate(text.splitlines(), start=1):
            code, _, comment = raw.partition(";")
            if comment.strip():
                self.b.comment(comment.strip())
            code = code.strip()
            if code:
                self.statement(name, depth, ln, code, pts, wdats)
        self.axes, self.ext = caller, caller_ext

    def statement(
        self, name: str, depth: int, ln: int, code: str, pts: dict[str, np.ndarray], wdats: dict[str, dict[str, float]]
    ) -> None:
        """One statement of file `name` (line ln): a call, a setting, an arc switch or a motion."""
        b, state, by_def, out_no = self.b, self.state, self.by_def, self.head.out_no
        up = code.upper()
        call = re.fullmatch(r"(\w+)\(\s*\)", code)
        if call and call.group(1).upper() in by_def and by_def[call.group(1).upper()] != name:
            self.walk(by_def[call.group(1).upper()], depth + 1)
            return
        w = re.match(r"WAIT\s+SEC\s+(" + NUM + ")", up)
        if w:  # with the arc on, the wire feeds in one spot
            b.dwell(float(w.group(1)), state.values.get("wire_feed_speed", math.nan))
            return
        v = re.match(r"\$VEL\.CP\s*=\s*(" + NUM + ")", up)
        if v:
            state.vel = float(v.group(1)) * 1000.0
            return
        a = re.match(r"(?:TRIGGER\s+WHEN\s+DISTANCE\s*=\s*0\b.*\bDO\s+)?\$ANOUT\[(\d+)\]\s*=\s*(" + NUM + ")", up)
        if a and a.group(1) in self.head.anout:  # a statement, or path-triggered at the next motion's start
            state.values[self.head.anout[a.group(1)]] = float(a.group(2))
            return
        trig = re.match(r"TRIGGER\s+WHEN\s+DISTANCE\s*=\s*([01])\b.*\bDO\s+\$OUT\[(\d+)\]\s*=\s*(TRUE|FALSE)", up)
        if out_no and trig and trig.group(2) == out_no:
            if trig.group(1) == "0":  # at the start of the next motion
                (b.arc_on(ln) if trig.group(3) == "TRUE" else b.close())
            else:  # at its end
                b.line = ln
                b.pending = "on" if trig.group(3) == "TRUE" else "off"
            return
        if out_no and re.match(r"\$OUT\[" + out_no + r"\]\s*=\s*TRUE", up):
            b.arc_on(ln)
            return
        if out_no and re.match(r"\$OUT\[" + out_no + r"\]\s*=\s*FALSE", up):
            b.close()
            return
        arc = re.match(r"ARCMAINNG\(#(\w+)\s*,\s*(\w+)", up)
        if arc:
            action, wdat = arc.group(1), arc.group(2)
            if action == "ARCONAFTERMOVESTD":
                b.arc_on(ln)
                state.wdat = wdat
                b.dwell(*self.strikes.get(wdat.upper(), (0.0, math.nan)))  # the ignition dwell, arc on
            elif action in ("ARCSWIBEFOREMOVESTD", "ARCOFFBEFOREMOVESTD"):
                state.wdat = wdat
            elif action == "ARCOFFAFTERMOVESTD":
                b.close()
            return
        fr = re.match(r"(?:\$(BASE|TOOL)\s*=\s*(.+)|BAS\s*\(\s*#(BASE|TOOL)\s*,\s*(\w+)\s*\))", up)
        if fr:
            kind = (fr.group(1) or fr.group(3)).lower()
            b.frame(kind, (fr.group(2) or fr.group(4)).strip(), f"{name} line {ln}: {code}")
            return
        mv = re.match(r"(LIN|PTP|CIRC)\s+(\w+)(?:\s*,\s*(\w+))?", up)
        if mv:
            self.motion(name, ln, mv.group(1), mv.group(2), mv.group(3), pts, wdats)
        elif re.match(r"S?PTP\s+\$(AXIS|POS)_ACT\b", up):
            return  # the BCO run to where the robot stands: no motion to place
        elif re.match(r"(S?LIN|S?PTP|S?CIRC|SPLINE|SPL)(_REL)?\b", up):  # a motion of another kind, or to an aggregate
            b.unplaced(f"{name} line {ln}: {code}: a motion the preflight cannot place (relative or inline target)")

    def motion(
        self,
        name: str,
        ln: int,
        kind: str,
        p1: str,
        p2: str | None,
        pts: dict[str, np.ndarray],
        wdats: dict[str, dict[str, float]],
    ) -> None:
        """LIN/PTP to p1, or CIRC through p1 to p2, with the weld values in force."""
        if p1 not in pts or (kind == "CIRC" and p2 not in pts):
            self.b.unplaced(f"{name} line {ln}: target {p1} not declared in the .dat")
            return
        if kind == "CIRC" and p2 is not None:  # the circle from where the robot is, through p1, to p2
            here = self.b.pos
            seg = circle_through(here, pts[p1], pts[p2]) if here is not None else np.vstack([pts[p1], pts[p2]])
        else:
            seg = pts[p1][None]
        vals = dict(self.state.values)
        if self.state.wdat is not None:
            vals.update(wdats.get(self.state.wdat, {}))
        speed = self.state.vel if kind != "PTP" else math.nan
        end = p2 if kind == "CIRC" and p2 is not None else p1
        self.b.axis = self.axes.get(end)
        if end in self.ext:  # an E6POS states them; a POS or FRAME leaves them where they are
            self.b.positioner(self.ext[end])
        self.b.move(seg, speed, vals.get("wire_feed_speed", math.nan), bool(vals))


def read_krl(files: dict[str, str]) -> ProgramRead:
    """files: artifact name → text of every .src/.dat of one program. Follows the main program's
    subprogram calls in order."""
    srcs = {n: t for n, t in files.items() if n.lower().endswith(".src")}
    dats = {n[:-4]: t for n, t in files.items() if n.lower().endswith(".dat")}
    by_def: dict[str, str] = {}
    for n, t in srcs.items():
        m = re.search(r"^\s*DEF\s+(\w+)\s*\(", t, re.MULTILINE | re.IGNORECASE)
        if m:
            by_def[m.group(1).upper()] = n
    head = _krl_header(srcs, by_def)
    reader = _KrlReader(srcs, dats, by_def, head)
    reader.walk(head.main)
    reader.b.close()
    if not head.channels and not head.anout:
        reader.b.out.notes.append(
            "no weld channels or analog outputs named in the header: the program commands no weld parameter"
        )
    return reader.b.out
