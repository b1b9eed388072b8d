"""Read an emitted program back into welded runs — from the text as written, not the planner's objects.

One reader per format (G-code, KUKA KRL, ABB RAPID, cutter-location CSV, compas print points,
Yaskawa INFORM, Fanuc TP, and a toolpath JSON for recipes that write no program). Each gives the same `ProgramRead`: the arc-ON runs
in program order, each with its points (mm, part frame), the programmed speed and the commanded wire
feed of every segment, and the layer/section the program's own comments put it in (for messages).

What counts as weld data is what the controller executes: a G-code command matched by the program's
`waamflow-weld:` header (`name=TEMPLATE` pairs), a KRL ArcTech weld data set's channel, an `$ANOUT`
named in the KRL header, RAPID welddata/arcdata values, a TP Arc Start's schedule in the program's
schedule table. Comments never count.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..program.common import WELD_COMMANDED, parse_weld_tag, template_regex

NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_LAYER = re.compile(r"\blayer (\d+)\b")
_SECTION = re.compile(r"\bsection (\S+)")


@dataclass
class Run:
    """One arc-ON run: ignition to extinction.

    points: (k, 3) float mm. speed: (k - 1,) float mm/s (nan: not stated). wfs: (k - 1,) float
    m/min (nan: not commanded). weld: (k - 1,) bool, some weld parameter commanded for the segment.
    """

    points: np.ndarray
    speed: np.ndarray
    wfs: np.ndarray
    weld: np.ndarray
    layer: int | None
    section: str | None
    line: int

    @property
    def length(self) -> float:
        return float(np.linalg.norm(np.diff(self.points, axis=0), axis=1).sum()) if len(self.points) > 1 else 0.0


@dataclass
class ProgramRead:
    format: str
    runs: list[Run] = field(default_factory=list)
    travel_mm: float = 0.0
    notes: list[str] = field(default_factory=list)   # what the reader could not interpret
    weld_commanded: bool = True                      # False: the format carries no weld data at all


class _RunBuilder:
    """Collects motions while the arc is on; layer/section from the program's comments."""

    def __init__(self, fmt: str) -> None:
        self.out = ProgramRead(fmt)
        self.layer: int | None = None
        self.section: str | None = None
        self.pts: list | None = None
        self.speed: list[float] = []
        self.wfs: list[float] = []
        self.weld: list[bool] = []
        self.line = 0
        self.run_layer: int | None = None
        self.run_section: str | None = None
        self.pos: np.ndarray | None = None
        self.pending: str | None = None       # KRL TRIGGER ... DISTANCE=1: "on"/"off" at the end of the next motion

    def comment(self, text: str) -> None:
        m = _LAYER.search(text)
        if m and text.lstrip(" -;!#(").startswith("layer"):
            self.layer = int(m.group(1))
        m = _SECTION.search(text)
        if m and text.lstrip(" -;!#(").startswith("section"):
            self.section = m.group(1)

    def arc_on(self, line: int) -> None:
        self.close()
        start = self.pos if self.pos is not None else np.full(3, np.nan)
        self.pts, self.speed, self.wfs, self.weld, self.line = [start.copy()], [], [], [], line
        self.run_layer, self.run_section = self.layer, self.section

    def close(self) -> None:
        if self.pts is not None and len(self.pts) > 1 and np.isfinite(self.pts[0]).all():
            self.out.runs.append(Run(np.asarray(self.pts, float), np.asarray(self.speed, float),
                                     np.asarray(self.wfs, float), np.asarray(self.weld, bool),
                                     self.run_layer, self.run_section, self.line))
        self.pts = None

    def move(self, targets: np.ndarray, speed: float, wfs: float, weld: bool) -> None:
        targets = np.atleast_2d(np.asarray(targets, float))
        if self.pts is not None:
            if not np.isfinite(self.pts[0]).all():    # arc on before any position: start where it first moves
                self.pts = [targets[0]]
                targets = targets[1:]
            for t in targets:
                self.pts.append(t)
                self.speed.append(speed)
                self.wfs.append(wfs)
                self.weld.append(weld)
        elif self.pos is not None:
            seg = np.vstack([self.pos, targets])
            self.out.travel_mm += float(np.linalg.norm(np.diff(seg, axis=0), axis=1).sum())
        self.pos = targets[-1].copy()
        self._after_move()

    def move_to(self, x: float, y: float, z: float, speed: float, wfs: float, weld: bool) -> None:
        """`move` of one straight motion, without the arrays (a G-code program is mostly these)."""
        if self.pts is not None and np.isfinite(self.pts[0]).all():
            self.pts.append((x, y, z))
            self.speed.append(speed)
            self.wfs.append(wfs)
            self.weld.append(weld)
            self.pos = np.array((x, y, z))
            self._after_move()
        elif self.pts is None and self.pos is not None:
            p = self.pos
            self.out.travel_mm += math.sqrt((x - p[0]) ** 2 + (y - p[1]) ** 2 + (z - p[2]) ** 2)
            self.pos = np.array((x, y, z))
            self._after_move()
        else:
            self.move(np.array((x, y, z)), speed, wfs, weld)

    def _after_move(self) -> None:
        if self.pending == "off":
            self.close()
        elif self.pending == "on":
            self.arc_on(self.line)
        self.pending = None


# ---- G-code -------------------------------------------------------------------------------------
_GWORD = re.compile(r"([A-Z])\s*(" + NUM + ")")
_POST_TAG = re.compile(r"waamflow-post:\s*arc_on=(\S+)\s+arc_off=(\S+)\s+dwell_units=(ms|s)\b"
                       r"(?:\s+feed_units=(mm/min|mm/s))?")


def _weld_templates(text: str) -> dict[str, list[tuple[re.Pattern, float, str]]]:
    """parameter → (pattern of a command that sets it, scale the command carries the value at, the
    literal text before its first field: a line without it cannot match), from the program's
    `waamflow-weld:` header lines (the format `program.common` documents: a reader of the declared
    syntax, scales `name[unit]*k=` included)."""
    return {name: [(template_regex(t), e["scale"], t.split("{", 1)[0]) for t in e["commands"] if "{" in t]
            for name, e in parse_weld_tag(text).items()}


def _gcode_arc(p0: np.ndarray, p1: np.ndarray, i: float, j: float, cw: bool) -> np.ndarray:
    c = p0[:2] + (i, j)
    a0 = math.atan2(p0[1] - c[1], p0[0] - c[0])
    a1 = math.atan2(p1[1] - c[1], p1[0] - c[0])
    sweep = a1 - a0
    if cw and sweep >= 0:
        sweep -= 2 * math.pi
    elif not cw and sweep <= 0:
        sweep += 2 * math.pi
    r = float(np.hypot(*(p0[:2] - c)))
    n = max(1, int(math.ceil(abs(sweep) / math.radians(5))))
    t = np.arange(1, n + 1) / n
    a = a0 + sweep * t
    pts = np.column_stack([c[0] + r * np.cos(a), c[1] + r * np.sin(a), p0[2] + (p1[2] - p0[2]) * t])
    pts[-1] = p1
    return pts


def read_gcode(text: str) -> ProgramRead:
    tag = _POST_TAG.search(text)
    arc_on = (tag.group(1) if tag else "M3").replace("_", " ").upper().split()
    arc_off = (tag.group(2) if tag else "M5").replace("_", " ").upper().split()
    per_s = tag is not None and tag.group(4) == "mm/s"
    weld_rx = _weld_templates(text)
    b = _RunBuilder("gcode")
    if not weld_rx:
        b.out.notes.append("no `waamflow-weld:` header: the program commands no weld parameter the reader knows")
    feed = math.nan
    motion = 0
    values: dict[str, float] = {}
    on_words = [f"{w[0]}{float(w[1:]):g}" for w in arc_on]
    off_words = [f"{w[0]}{float(w[1:]):g}" for w in arc_off]
    for ln, raw in enumerate(text.splitlines(), start=1):
        code, _, comment = raw.partition(";")
        parens: list[str] = []
        if "(" in code:
            parens = re.findall(r"\(([^)]*)\)", code)
            code = re.sub(r"\([^)]*\)", " ", code)
        code = code.strip()
        for c in [comment, *parens]:
            if c.strip():
                b.comment(c.strip())
        if not code:
            continue
        upper = code.upper()
        gwords = _GWORD.findall(upper)
        words = [f"{a}{float(v):g}" for a, v in gwords]
        if words == on_words:
            b.arc_on(ln)
            continue
        if words == off_words:
            b.close()
            continue
        matched = False
        for name, pats in weld_rx.items():
            for rx, scale, literal in pats:
                m = rx.search(code) if literal in code else None
                if m:
                    values[name] = float(m.group(1)) / scale
                    matched = True
        if matched:
            continue
        vals: dict[str, float] = {}
        gs: list[float] = []
        for a, v in gwords:
            if a == "G":
                gs.append(float(v))
            else:
                vals[a] = float(v)
        for g in gs:
            if g in (0, 1, 2, 3):
                motion = int(g)
        if "F" in vals:
            feed = vals["F"] * (1.0 if per_s else 1.0 / 60.0)
        if 4 in gs or not any(k in vals for k in "XYZ"):
            continue
        here = b.pos if b.pos is not None else np.zeros(3)
        x, y, z = (vals.get(k, float(here[axis])) for axis, k in enumerate("XYZ"))
        speed = math.nan if motion == 0 else feed
        if motion in (2, 3):
            seg = _gcode_arc(here, np.array((x, y, z)), vals.get("I", 0.0), vals.get("J", 0.0), motion == 2)
            b.move(seg, speed, values.get("wire_feed_speed", math.nan), bool(values))
        else:
            b.move_to(x, y, z, speed, values.get("wire_feed_speed", math.nan), bool(values))
    b.close()
    return b.out


# ---- KUKA KRL -----------------------------------------------------------------------------------
_E6 = re.compile(r"DECL\s+E6POS\s+(\w+)\s*=\s*\{([^}]*)\}", re.IGNORECASE)
_FIELD = re.compile(r"([A-Z]\w*)\s+(" + NUM + ")", re.IGNORECASE)
_WDAT = re.compile(r"DECL\s+stArcDat_T\s+(\w+)\s*=\s*\{(.*)\}\s*$", re.IGNORECASE)
_CHANNELS = re.compile(r"channels\s+([^)]*?)\)")
_ANOUT_TAG = re.compile(r"\$ANOUT\[(\d+)\]")


def _krl_points(dat: str) -> dict[str, np.ndarray]:
    pts = {}
    for name, body in _E6.findall(dat):
        f = {k.upper(): float(v) for k, v in _FIELD.findall(body)}
        pts[name.upper()] = np.array([f.get("X", 0.0), f.get("Y", 0.0), f.get("Z", 0.0)])
    return pts


def _krl_wdat(dat: str, channels: dict[int, str]) -> dict[str, dict[str, float]]:
    out = {}
    for line in dat.splitlines():
        m = _WDAT.search(line)
        if not m:
            continue
        weld = re.search(r"Weld\s*\{([^}]*)\}", m.group(2))
        if not weld:
            continue
        f = dict(_FIELD.findall(weld.group(1)))
        vals = {}
        for ch, name in channels.items():
            v = f.get(f"Channel{ch}")
            if v is not None and float(v) != 0.0:
                vals[name] = float(v)
        out[m.group(1).upper()] = vals
    return out


@dataclass
class _KrlState:
    """What a KRL program has set so far: $VEL.CP (mm/s), the analog outputs' weld values
    (parameter → value) and the ArcTech weld data set in force."""

    vel: float = math.nan
    values: dict[str, float] = field(default_factory=dict)
    wdat: str | None = None


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
    anout: dict[str, str] = {}      # `$ANOUT[n]` → parameter, from the header's waamflow-weld tag
    for name, e in parse_weld_tag(header).items():
        for tpl in e["commands"]:
            a = _ANOUT_TAG.search(tpl)
            if a:
                anout[a.group(1)] = name
    b = _RunBuilder("krl")
    state = _KrlState()
    out_m = re.search(r"digital output \$OUT\[(\d+)\]", header)
    out_no = out_m.group(1) if out_m else None

    def walk(name: str, depth: int = 0) -> None:
        if depth > 4:
            return
        text = srcs[name]
        stem = name[:-4]
        pts = _krl_points(dats.get(stem, ""))
        wdats = _krl_wdat(dats.get(stem, ""), channels)
        for ln, raw in enumerate(text.splitlines(), start=1):
            code, _, comment = raw.partition(";")
            if comment.strip():
                b.comment(comment.strip())
            code = code.strip()
            if not code:
                continue
            up = code.upper()
            call = re.fullmatch(r"(\w+)\(\s*\)", code)
            if call and call.group(1).upper() in by_def and by_def[call.group(1).upper()] != name:
                walk(by_def[call.group(1).upper()], depth + 1)
                continue
            v = re.match(r"\$VEL\.CP\s*=\s*(" + NUM + ")", up)
            if v:
                state.vel = float(v.group(1)) * 1000.0
                continue
            a = re.match(r"(?:TRIGGER\s+WHEN\s+DISTANCE\s*=\s*0\b.*\bDO\s+)?\$ANOUT\[(\d+)\]\s*=\s*(" + NUM + ")", up)
            if a and a.group(1) in anout:   # a statement, or path-triggered at the next motion's start
                state.values[anout[a.group(1)]] = float(a.group(2))
                continue
            trig = re.match(r"TRIGGER\s+WHEN\s+DISTANCE\s*=\s*([01])\b.*\bDO\s+\$OUT\[(\d+)\]\s*=\s*(TRUE|FALSE)", up)
            if out_no and trig and trig.group(2) == out_no:
                if trig.group(1) == "0":          # at the start of the next motion
                    (b.arc_on(ln) if trig.group(3) == "TRUE" else b.close())
                else:                             # at its end
                    b.line = ln
                    b.pending = "on" if trig.group(3) == "TRUE" else "off"
                continue
            if out_no and re.match(r"\$OUT\[" + out_no + r"\]\s*=\s*TRUE", up):
                b.arc_on(ln)
                continue
            if out_no and re.match(r"\$OUT\[" + out_no + r"\]\s*=\s*FALSE", up):
                b.close()
                continue
            arc = re.match(r"ARCMAINNG\(#(\w+)\s*,\s*(\w+)", up)
            if arc:
                action, wdat = arc.group(1), arc.group(2)
                if action == "ARCONAFTERMOVESTD":
                    b.arc_on(ln)
                    state.wdat = wdat
                elif action in ("ARCSWIBEFOREMOVESTD",):
                    state.wdat = wdat
                elif action == "ARCOFFBEFOREMOVESTD":
                    state.wdat = wdat
                elif action == "ARCOFFAFTERMOVESTD":
                    b.close()
                continue
            mv = re.match(r"(LIN|PTP|CIRC)\s+(\w+)(?:\s*,\s*(\w+))?", up)
            if mv:
                kind, p1, p2 = mv.group(1), mv.group(2), mv.group(3)
                if p1 not in pts or (kind == "CIRC" and p2 not in pts):
                    b.out.notes.append(f"{name} line {ln}: target {p1} not declared in the .dat")
                    continue
                target = pts[p2] if kind == "CIRC" else pts[p1]
                seg = np.vstack([pts[p1], target]) if kind == "CIRC" else target[None]
                vals = dict(state.values)
                if state.wdat is not None:
                    vals.update(wdats.get(state.wdat, {}))
                speed = state.vel if kind != "PTP" else math.nan
                b.move(seg, speed, vals.get("wire_feed_speed", math.nan), bool(vals))
        return

    walk(main)
    b.close()
    if not channels and not anout:
        b.out.notes.append("no weld channels or analog outputs named in the header: the program commands no weld parameter")
    return b.out


# ---- ABB RAPID ----------------------------------------------------------------------------------
_ROBT = re.compile(r"robtarget\s+(\w+)\s*:=\s*\[\s*\[\s*(" + NUM + r")\s*,\s*(" + NUM + r")\s*,\s*(" + NUM + r")\s*\]",
                   re.IGNORECASE)
_SPEED = re.compile(r"speeddata\s+(\w+)\s*:=\s*\[\s*(" + NUM + ")", re.IGNORECASE)
_WELD = re.compile(r"welddata\s+(\w+)\s*:=\s*\[\s*(" + NUM + r")\s*,\s*(" + NUM + r")\s*,\s*\[([^\]]*)\]", re.IGNORECASE)
_RAPID_MOVE = re.compile(r"^\s*(MoveL|MoveJ|MoveC|ArcLStart|ArcL|ArcLEnd|ArcC|ArcCStart|ArcCEnd)\s+(.*?);", re.IGNORECASE)
_ARCDATA_DEFAULT = ("job", "mode", "voltage", "wire_feed_speed", "control", "current")


class _RapidWeld(NamedTuple):
    """A welddata declaration: its weld speed (mm/s) and the non-zero weld values of its arcdata."""

    speed: float
    values: dict[str, float]


def read_rapid(text: str) -> ProgramRead:
    pts = {n.lower(): np.array([float(x), float(y), float(z)]) for n, x, y, z in _ROBT.findall(text)}
    speeds = {n.lower(): float(v) for n, v in _SPEED.findall(text)}
    builtin = {f"v{v}": float(v) for v in (5, 10, 20, 30, 40, 50, 60, 80, 100, 150, 200, 300, 400, 500, 600, 800, 1000)}
    fields: tuple[str, ...] = _ARCDATA_DEFAULT
    m = re.search(r"arcdata\s*=\s*\[([^\]]*)\]", text)
    if m:
        fields = tuple(("wire_feed_speed" if "wirefeed" in f else "current" if "current" in f else
                        "voltage" if "voltage" in f and "2" not in f else "job" if "job" in f else f.strip())
                       for f in m.group(1).split(","))
    welds: dict[str, _RapidWeld] = {}
    for name, speed, _org, main in _WELD.findall(text):
        numbers = [float(v) for v in re.findall(NUM, main)]
        welds[name.lower()] = _RapidWeld(float(speed), {f: v for f, v in zip(fields, numbers)
                                                        if f in WELD_COMMANDED and v != 0.0})
    b = _RunBuilder("rapid")
    for ln, raw in enumerate(text.splitlines(), start=1):
        code, _, comment = raw.partition("!")
        if comment.strip():
            b.comment(comment.strip())
        m = _RAPID_MOVE.match(code)
        if not m:
            continue
        instr = m.group(1).lower()
        args = [a.strip() for a in re.split(r",(?![^\[]*\])", m.group(2))]
        names = [a.split("\\")[0].lower() for a in args]
        circ = instr in ("movec", "arcc", "arccstart", "arccend")
        targets = names[:2] if circ else names[:1]
        if any(t not in pts for t in targets):
            b.out.notes.append(f"line {ln}: target {targets} not declared")
            continue
        seg = np.vstack([pts[t] for t in targets])
        sp = names[2 if circ else 1] if len(names) > (2 if circ else 1) else ""
        weld = next((welds[n] for n in names if n in welds), None)
        speed = speeds.get(sp, builtin.get(sp, math.nan))
        if weld is not None and weld.speed:
            speed = weld.speed                  # ArcWare: the weld speed of welddata governs the weld
        vals = dict(weld.values) if weld is not None else {}
        if instr in ("arclstart", "arccstart"):
            b.move(seg, math.nan, math.nan, False)   # moves to the start, the arc strikes there
            b.arc_on(ln)
            continue
        b.move(seg, speed, vals.get("wire_feed_speed", math.nan), bool(vals))
        if instr in ("arclend", "arccend"):
            b.close()
    b.close()
    return b.out


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


# ---- Yaskawa INFORM -------------------------------------------------------------------------------
_JOB_NAME = re.compile(r"^//NAME\s+(\S+)", re.MULTILINE)
_JOB_CALL = re.compile(r"^CALL\s+JOB:(\S+)", re.MULTILINE)
_CPOS = re.compile(r"^C(\d+)=(" + NUM + r"),(" + NUM + r"),(" + NUM + r")", re.MULTILINE)
_INF_MOVE = re.compile(r"^S?MOV[LJ]\s+C(\d+)\b.*?\bV=(" + NUM + r")")
_INF_VAL = re.compile(r"\b(AC|AV)=(" + NUM + r")")


def read_inform(files: dict[str, str]) -> ProgramRead:
    """INFORM jobs in the order the main job calls them (`CALL JOB:`); positions from each job's
    own //POS; the weld values are ARCON/ARCSET's AC= (current A) and AV= (voltage V)."""
    jobs = {m.group(1).upper(): t for t in files.values() if (m := _JOB_NAME.search(t))}
    main = next((t for t in files.values() if _JOB_CALL.search(t)), next(iter(files.values())))
    order = [jobs[c.upper()] for c in _JOB_CALL.findall(main) if c.upper() in jobs] or [main]
    b = _RunBuilder("inform")
    vals: dict[str, float] = {}
    line_no = 0
    for text in order:
        pos = {int(k): np.array([float(x), float(y), float(z)]) for k, x, y, z in _CPOS.findall(text)}
        inst = text.split("//INST", 1)[-1]
        for raw in inst.splitlines():
            line_no += 1
            ln = raw.strip()
            if ln.startswith("'"):
                b.comment(ln[1:])
                continue
            if ln.startswith(("ARCON", "ARCSET")):
                vals.update({k: float(v) for k, v in _INF_VAL.findall(ln)})
                if ln.startswith("ARCON"):
                    b.arc_on(line_no)
                continue
            if ln.startswith("ARCOF"):
                b.close()
                continue
            m = _INF_MOVE.match(ln)
            if m:
                k = int(m.group(1))
                if k not in pos:
                    b.out.notes.append(f"line {line_no}: C{k:05d} not in the job's //POS")
                    continue
                weld = bool(vals.get("AC") or vals.get("AV"))
                b.move(pos[k], float(m.group(2)), math.nan, weld)
    b.close()
    return b.out


# ---- Fanuc TP (.LS) -----------------------------------------------------------------------------
_TP_NAME = re.compile(r"^/PROG\s+(\S+)", re.MULTILINE)
_TP_LINE = re.compile(r"^\s*\d+:(.*?);\s*$")
_TP_CALL = re.compile(r"^CALL\s+(\w+)")
_TP_MOVE = re.compile(r"^[LJ]\s+P\[(\d+)\]\s+(" + NUM + r")(mm/sec|cm/min)\b")
_TP_ARC = re.compile(r"^Arc (Start|End)\[(\d+)\]")
_TP_POS = re.compile(r"P\[(\d+)\]\{.*?X =\s*(" + NUM + r")\s*mm,\s*Y =\s*(" + NUM + r")\s*mm,\s*Z =\s*("
                     + NUM + r")\s*mm", re.DOTALL)
_TP_SPEED = {"mm/sec": 1.0, "cm/min": 10.0 / 60.0}


def _tp_schedules(text: str) -> dict[int, dict[str, float]]:
    """schedule → {voltage, current, wire_feed_speed, job} (present, finite values) from the table
    `<NAME>_SCHED.CSV` (columns program.tp.SCHEDULE_COLUMNS, read by name)."""
    import csv
    import io

    cols = {"voltage_V": "voltage", "current_A": "current", "wire_feed_speed_m_min": "wire_feed_speed", "job": "job"}
    out: dict[int, dict[str, float]] = {}
    for row in csv.DictReader(io.StringIO(text)):
        try:
            k = int(row["schedule"])
        except (KeyError, TypeError, ValueError):
            continue
        out[k] = {name: float(row[c]) for c, name in cols.items() if (row.get(c) or "").strip()}
    return out


def read_tp(files: dict[str, str]) -> ProgramRead:
    """Fanuc TP programs in the order the main program calls them (`CALL`); positions from each
    program's own /POS; the weld values of a run are those of its `Arc Start[k]` schedule in the
    schedule table (a run is weld-commanded when schedule k is in the table with a non-zero
    current, voltage or wire feed; a schedule change while welding switches the values)."""
    progs = {m.group(1).upper(): t for t in files.values() if (m := _TP_NAME.search(t))}
    table = next((t for t in files.values() if t.lstrip().startswith("schedule,")), "")
    scheds = _tp_schedules(table)
    b = _RunBuilder("tp")
    if not table:
        b.out.notes.append("no weld schedule table (<NAME>_SCHED.CSV): the weld values cannot be read")

    def body(text: str) -> list[str]:
        mn = text.split("\n/MN\n", 1)[-1].split("\n/POS\n", 1)[0]
        return [m.group(1).strip() for ln in mn.splitlines() if (m := _TP_LINE.match(ln))]

    main = next((t for t in progs.values() if any(_TP_CALL.match(x) for x in body(t))), next(iter(progs.values()), ""))
    calls = [m.group(1).upper() for x in body(main) if (m := _TP_CALL.match(x))]
    order = [progs[c] for c in calls if c in progs] or [main]
    vals: dict[str, float] = {}
    line_no = 0
    for text in order:
        pos = {int(k): np.array([float(x), float(y), float(z)])
               for k, x, y, z in _TP_POS.findall(text.split("\n/POS\n", 1)[-1])}
        for ln in body(text):
            line_no += 1
            if ln.startswith("!"):
                b.comment(ln[1:].strip())
                continue
            m = _TP_ARC.match(ln)
            if m:
                k = int(m.group(2))
                if m.group(1) == "End":
                    b.close()
                    continue
                if k not in scheds and table:
                    b.out.notes.append(f"line {line_no}: Arc Start[{k}]: schedule {k} not in the table")
                vals = scheds.get(k, {})
                if b.pts is None:
                    b.arc_on(line_no)
                continue
            m = _TP_MOVE.match(ln)
            if m:
                k = int(m.group(1))
                if k not in pos:
                    b.out.notes.append(f"line {line_no}: P[{k}] not in the program's /POS")
                    continue
                weld = any(vals.get(n, 0.0) > 0 for n in ("current", "voltage", "wire_feed_speed"))
                b.move(pos[k], float(m.group(2)) * _TP_SPEED[m.group(3)], vals.get("wire_feed_speed", math.nan), weld)
    b.close()
    return b.out


# ---- cutter location CSV, print points, toolpath JSON ----------------------------------------------
def read_cl_csv(text: str) -> ProgramRead:
    lines = [ln for ln in text.splitlines() if ln and not ln.startswith("#")]
    head = lines[0].split(",")
    col = {h.strip(): i for i, h in enumerate(head)}
    b = _RunBuilder("csv")
    wfs_col = next((c for c in ("wire_feed_speed_m_min", "wire_feed_speed", "wfs_m_min") if c in col), None)
    weld_cols = [c for c in (wfs_col, "current_a", "voltage_v", "job") if c and c in col]
    if wfs_col is None:
        b.out.weld_commanded = False
        b.out.notes.append("the CL file has no wire feed column")
    arc_prev = False
    for ln, row in enumerate(lines[1:], start=2):
        f = row.split(",")
        p = np.array([float(f[col["x"]]), float(f[col["y"]]), float(f[col["z"]])])
        arc = f[col["arc"]].strip() in ("1", "true", "True")
        b.layer = int(f[col["layer"]]) if f[col["layer"]].strip() else b.layer
        b.section = f[col["section"]] or b.section
        if arc and not arc_prev:
            b.arc_on(ln)
        if not arc and arc_prev:
            b.close()
        sp = f[col["speed_mm_s"]].strip()
        w = f[col[wfs_col]].strip() if wfs_col else ""
        b.move(p[None], float(sp) if sp else math.nan, float(w) if w else math.nan,
               any(f[col[c]].strip() for c in weld_cols))
        arc_prev = arc
    b.close()
    return b.out


def read_printpoints(text: str) -> ProgramRead:
    data = json.loads(text)
    entries = data if isinstance(data, list) else [data[k] for k in sorted(data, key=lambda s: int(s))] \
        if all(str(k).isdigit() for k in data) else data.get("points", [])
    b = _RunBuilder("printpoints")
    b.out.weld_commanded = any("wire_feed_speed" in e for e in entries)
    on = False
    for i, e in enumerate(entries):
        p = np.asarray(e["point"], float)
        b.layer = e.get("layer", b.layer)
        b.section = e.get("section", b.section)
        toggle = bool(e.get("extruder_toggle"))      # the arc is on during the motion *to* this point
        if toggle and not on:
            b.arc_on(i)
            on = True
        elif not toggle and on:
            b.close()
            on = False
        w = e.get("wire_feed_speed")
        b.move(p[None], float(e.get("velocity") or math.nan), float(w) if w is not None else math.nan, w is not None)
    b.close()
    return b.out


def read_toolpath(doc: dict) -> ProgramRead:
    """A `<node>.toolpath.json` for recipes that write no program: the arc-ON runs and the zone
    parameters in force (weld data as the toolpath states it)."""
    b = _RunBuilder("toolpath")
    for layer in doc.get("layers", []):
        b.layer = layer.get("index")
        for sec in layer.get("sections", []):
            b.section = sec.get("key")
            pts = np.asarray(sec.get("points", []), float)
            arcs = sec.get("arc", [])
            speeds = sec.get("speed", [])
            zones = sec.get("zone", [])
            zp = sec.get("zone_params", {})
            if len(pts) == 0:
                continue
            b.close()
            b.pos = pts[0].copy()
            for i in range(len(pts) - 1):
                if arcs[i] and b.pts is None:
                    b.arc_on(0)
                elif not arcs[i] and b.pts is not None:
                    b.close()
                params = zp.get(zones[i], {}) if i < len(zones) else {}
                w = params.get("wire_feed_speed")
                b.move(pts[i + 1][None], float(speeds[i]) if i < len(speeds) else math.nan,
                       float(w) if w is not None else math.nan, bool(params))
            b.close()
    b.out.weld_commanded = False
    return b.out


def read_program(fmt: str, files: dict[str, str]) -> ProgramRead:
    """fmt: the post-process format; files: artifact name → text."""
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
