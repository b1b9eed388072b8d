"""G-code read back: motions, the arc codes the `waamflow-post:` header names and the weld
commands its `waamflow-weld:` lines declare."""

from __future__ import annotations

import math
import re
from typing import Callable, Iterator

import numpy as np

from ...program.common import parse_weld_tag, template_regex
from .core import NUM, ProgramRead, RunBuilder

_GWORD = re.compile(r"([A-Z])\s*(" + NUM + ")")
# the straight motions that make most of a program, as waamflow writes them: read without the
# general path's comment, word and weld-command passes (same numbers, same builder calls)
_PLAIN_G1 = re.compile(r"G1 X(" + NUM + ") Y(" + NUM + ") Z(" + NUM + r")(?: F(" + NUM + "))?")
# The same lines, each line of a joined text whole, numbers as runs of their characters: cheaper to
# match than NUM; a number float() then reads is one NUM matches (sign, digits with at most one
# point, exponent), and a run with any other is read line by line (`_plain_runs`).
_PLAIN_LINES = re.compile(r"(?m)^G1 X([-+\d.eE]+) Y([-+\d.eE]+) Z([-+\d.eE]+)(?: F([-+\d.eE]+))?\r?$")
_G1_RUNS = re.compile(r"(?m)^(?:G1 X[^\r\n]*\r?\n)+")  # lines in a row that start "G1 X" (and end in a line break)
_PLAIN_CHARS = frozenset("G1 XYZF0123456789.+-eE")
FAST_PATH = True  # False: every line by the general path (tests compare the two)
_POST_TAG = re.compile(
    r"waamflow-post:\s*arc_on=(\S+)\s+arc_off=(\S+)\s+dwell_units=(ms|s)\b"
    r"(?:\s+feed_units=(mm/min|mm/s))?"
)


def _weld_templates(text: str) -> dict[str, list[tuple[re.Pattern, float, str]]]:
    """parameter → (pattern of a command that sets it, scale the command carries the value at, the
    literal text before its first field: a line without it cannot match), from the program's
    `waamflow-weld:` header lines (the format `program.common` documents: a reader of the declared
    syntax, scales `name[unit]*k=` included)."""
    return {
        name: [(template_regex(t), e["scale"], t.split("{", 1)[0]) for t in e["commands"] if "{" in t]
        for name, e in parse_weld_tag(text).items()
    }


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


# Words that change how later coordinates are read: inches, incremental distance, a G92 offset (`_Modes`),
# a work offset, G10, G53 (`_frames`). A program holding any (a machine profile's start or layer code
# may) is read line by line; the plain-line fast path assumes mm, absolute, no offset, one frame (what
# waamflow's posts write).
_MODAL_WORDS = re.compile(r"G\s*0*(?:20|91|92|10|53|5[4-9])(?![0-9])", re.IGNORECASE)
_ENDS = (2.0, 30.0)  # M2, M30: the program ends, nothing after it runs (RS274/NGC)
_PLAIN_G = frozenset((0.0, 1.0, 2.0, 3.0, 4.0))  # motions and dwells: no mode of `_Modes` to take


class _Modes:
    """The modal state a controller keeps for coordinates (RS274/NGC, as LinuxCNC's interpreter):
    length units (G20 inches, G21 mm), distance mode (G90 absolute, G91 incremental), arc centre mode
    (G91.1 incremental, the default; G90.1 absolute) and the G92 offset (G92 sets it so the point in
    hand reads the given coordinates; G92.1/G92.2 clear it). Points are kept in mm, in the frame the
    program starts in (the part's)."""

    def __init__(self) -> None:
        self.scale = 1.0
        self.incremental = False
        self.arc_absolute = False
        self.offset = np.zeros(3)
        self.plain = True  # mm, absolute, no offset: a motion's words are its point

    def apply(self, gs: list[float], vals: dict[str, float], here: np.ndarray) -> bool:
        """Take a line's G words; True when the line is consumed (a G92 offset, no motion)."""
        for g in gs:
            if g in (20.0, 21.0):
                self.scale = 25.4 if g == 20.0 else 1.0
            elif g in (90.0, 91.0):
                self.incremental = g == 91.0
            elif g in (90.1, 91.1):
                self.arc_absolute = g == 90.1
            elif g in (92.1, 92.2):
                self.offset = np.zeros(3)
        if 92.0 in gs:
            for k, a in enumerate("XYZ"):
                if a in vals:
                    self.offset[k] = here[k] - vals[a] * self.scale
        self.plain = self.scale == 1.0 and not self.incremental and not self.offset.any()
        return 92.0 in gs

    def target(self, vals: dict[str, float], here: np.ndarray) -> np.ndarray:
        """Where a motion's X Y Z words send the torch (axes not given stay)."""
        out = here.astype(float)
        for k, a in enumerate("XYZ"):
            if a in vals:
                v = vals[a] * self.scale
                out[k] = here[k] + v if self.incremental else v + self.offset[k]
        return out

    def centre_ij(self, vals: dict[str, float], here: np.ndarray) -> tuple[float, float]:
        """An arc's I J as offsets from its start, mm."""
        i, j = vals.get("I", 0.0) * self.scale, vals.get("J", 0.0) * self.scale
        if self.arc_absolute:
            return i + self.offset[0] - here[0], j + self.offset[1] - here[1]
        return i, j


def _frames(b: RunBuilder, gs: list[float], vals: dict[str, float], ln: int, raw: str) -> bool:
    """Work offsets (G54-G59.3) as the builder's frame; a G10 offset setting once the program has
    moved (the frame it changes is the controller's), and a G53 move in machine coordinates (with
    the arc on: a deposit the preflight cannot place; off: a travel it does not follow): unplaced.
    True when the line is consumed."""
    for g in gs:
        if 54.0 <= g <= 59.3:
            b.frame("work offset", f"G{g:g}", f"line {ln}")
    if 10.0 in gs:
        if b.moved:
            b.out.unplaced.append(
                f"line {ln}: {raw.strip()}: G10 sets a work offset to values the program does not state"
            )
        return True
    if 53.0 in gs:
        if any(k in vals for k in "XYZ"):
            b.unplaced(f"line {ln}: {raw.strip()}: G53 moves in machine coordinates")
        return True
    return False


def _plain_g1(weld_rx: dict, arc_letters: set) -> Callable[[str], re.Match | None] | None:
    """The matcher of plain `G1 X Y Z [F]` lines, or None when such a line could be something else
    in this program: a weld command whose literal text could occur in it, or an arc code made of
    those letters (the general path decides those)."""
    if not FAST_PATH or {("G", "X", "Y", "Z"), ("G", "X", "Y", "Z", "F")} & arc_letters:
        return None
    for pats in weld_rx.values():
        for _rx, _scale, literal in pats:
            if set(literal) <= _PLAIN_CHARS:  # "" too: its pattern is tried on every line
                return None
    return _PLAIN_G1.fullmatch


def _dwell_s(vals: dict[str, float], tag: re.Match | None) -> float:
    """A G4's seconds: P in the header's `dwell_units` (s, as RS274/NGC, when there is none) or ms; S
    in seconds (Marlin)."""
    if "P" in vals:
        return vals["P"] * (0.001 if tag is not None and tag.group(3) == "ms" else 1.0)
    return vals.get("S", 0.0)


_ROTARY = re.compile(r"rotary axes: (.*?) in (degrees|radians)")
_ROTARY_AXIS = re.compile(r"\b([A-CU-W]) = positioner E(\d)")


class _Rotary:
    """The positioner's rotary words as the header maps them (`rotary axes: A = positioner E1
    (tilt), C = positioner E2 (turn) in degrees|radians`): modal, they hold until changed."""

    def __init__(self, text: str) -> None:
        m = _ROTARY.search(text, 0, 20_000)
        self.words = {a: int(k) - 1 for a, k in _ROTARY_AXIS.findall(m.group(1))} if m else {}
        self.scale = 1.0 if m is None or m.group(2) == "degrees" else 180.0 / math.pi
        self.angles = np.full(max(self.words.values(), default=-1) + 1, np.nan)  # degrees

    def take(self, vals: dict[str, float], b: RunBuilder) -> None:
        """A line's words: its rotary ones become the angles of the motions from here on."""
        if self.words and any(a in vals for a in self.words):
            for a, k in self.words.items():
                if a in vals:
                    self.angles[k] = vals[a] * self.scale
            b.positioner(tuple(self.angles.tolist()))


def _weld_values(code: str, weld_rx: dict, values: dict[str, float]) -> bool:
    """A weld command of the header's templates on the line: its value into `values` (True)."""
    matched = False
    for name, pats in weld_rx.items():
        for rx, scale, literal in pats:
            m = rx.search(code) if literal in code else None
            if m:
                values[name] = float(m.group(1)) / scale
                matched = True
    return matched


def read_gcode(text: str) -> ProgramRead:
    tag = _POST_TAG.search(text)
    arc_on = (tag.group(1) if tag else "M3").replace("_", " ").upper().split()
    arc_off = (tag.group(2) if tag else "M5").replace("_", " ").upper().split()
    per_s = tag is not None and tag.group(4) == "mm/s"
    weld_rx = _weld_templates(text)
    b = RunBuilder("gcode")
    if not weld_rx:
        b.out.notes.append("no `waamflow-weld:` header: the program commands no weld parameter the reader knows")
    feed = math.nan
    motion = 0
    values: dict[str, float] = {}
    on_words = [f"{w[0]}{float(w[1:]):g}" for w in arc_on]
    off_words = [f"{w[0]}{float(w[1:]):g}" for w in arc_off]
    # a line can be the arc code only if its letters are the code's: the words (a float format
    # each) are made for those lines alone, not for every motion
    arc_letters = {tuple(w[0] for w in on_words), tuple(w[0] for w in off_words)}
    arc_sizes = {len(on_words), len(off_words)}
    plain = None if _MODAL_WORDS.search(text) else _plain_g1(weld_rx, arc_letters)
    modes = _Modes()
    rotary = _Rotary(text)
    lines = text.splitlines()
    runs = _plain_runs(text, lines, plain) if plain is not None else {}
    ln = 0  # lines read (the 1-based number of the line in hand, once it is taken)
    while ln < len(lines):
        run = runs.get(ln)
        if run is not None:  # plain lines in a row: to the builder at once
            ln, xyz, fs = run
            feed = _plain_block(b, xyz, fs, feed, per_s, values)
            motion = 1
            continue
        raw = lines[ln]
        ln += 1
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
        if len(gwords) in arc_sizes and tuple(a for a, _v in gwords) in arc_letters:
            words = [f"{a}{float(v):g}" for a, v in gwords]
            if words == on_words:
                b.arc_on(ln)
                continue
            if words == off_words:
                b.close()
                continue
        if _weld_values(code, weld_rx, values):
            continue
        vals: dict[str, float] = {}
        gs: list[float] = []
        for a, v in gwords:
            if a == "G":
                gs.append(float(v))
            else:
                vals[a] = float(v)
        if vals.get("M") in _ENDS:
            break  # M2 / M30: the program ends here
        if gs and not _PLAIN_G.issuperset(gs):  # a mode, a frame or an offset: what later coordinates mean
            here = b.pos if b.pos is not None else np.zeros(3)
            if _frames(b, gs, vals, ln, raw) or modes.apply(gs, vals, here):
                continue
        for g in gs:
            if g in (0, 1, 2, 3):
                motion = int(g)
        if "F" in vals:
            feed = vals["F"] * modes.scale * (1.0 if per_s else 1.0 / 60.0)
        if 4 in gs:  # a dwell: the wire feeds in one spot when the arc is on
            b.dwell(_dwell_s(vals, tag), values.get("wire_feed_speed", math.nan))
            continue
        rotary.take(vals, b)
        if not any(k in vals for k in "XYZ"):
            continue
        here = b.pos if b.pos is not None else np.zeros(3)
        if modes.plain:
            x = vals["X"] if "X" in vals else float(here[0])
            y = vals["Y"] if "Y" in vals else float(here[1])
            z = vals["Z"] if "Z" in vals else float(here[2])
        else:
            x, y, z = modes.target(vals, here).tolist()
        speed = math.nan if motion == 0 else feed
        if motion in (2, 3):
            seg = _gcode_arc(here, np.array((x, y, z)), *modes.centre_ij(vals, here), motion == 2)
            b.move(seg, speed, values.get("wire_feed_speed", math.nan), bool(values))
        else:
            b.move_to(x, y, z, speed, values.get("wire_feed_speed", math.nan), bool(values))
    b.close()
    return b.out


PlainRun = tuple[int, np.ndarray, list]  # (index after the run, x y z (k, 3), F per line or None)
#: A run is read in pieces of about this much text (~50,000 lines, whole lines each): the lines'
#: numbers as text (a tuple of 4 strings a line) are held a piece at a time, not a whole spiral's.
PIECE_CHARS = 2_000_000


def _pieces(text: str, s: int, e: int) -> Iterator[tuple[int, int]]:
    """[s, e) of a run cut after the line break at or after every PIECE_CHARS characters."""
    while e - s > PIECE_CHARS:
        cut = text.find("\n", s + PIECE_CHARS - 1, e) + 1
        if cut <= 0 or cut >= e:
            break
        yield s, cut
        s = cut
    yield s, e


def _plain_runs(text: str, lines: list[str], plain: Callable[[str], re.Match | None]) -> dict[int, PlainRun]:
    """Runs of plain `G1 X Y Z [F]` lines: index of a run's first line → (index after its last,
    their points, each line's F or None). The lines in a row that start "G1 X" are found in the
    text by one regex and matched by one `findall`, each line whole (`^…$`: as many matches as
    lines) and each number read by float(); a run where that fails is matched line by line
    (`plain`, NUM) and split where a line is not plain. Only where the text's line breaks are
    "\\n" or "\\r\\n", so that its lines are `lines` (else {}: every line by the general path).
    1.76 million lines (a 0.55 m ball's contour fill): 6.0 → 3.7 s of reading (min of 3)."""
    if len(lines) != text.count("\n") + (0 if text.endswith("\n") or not text else 1):
        return {}
    out: dict[int, PlainRun] = {}
    line, at = 0, 0  # the line index of text position `at`
    for s, e in (piece for m in _G1_RUNS.finditer(text) for piece in _pieces(text, *m.span())):
        line += text.count("\n", at, s)
        a, b = line, line + text.count("\n", s, e)
        line, at = b, e
        rows = _PLAIN_LINES.findall(text, s, e)
        if len(rows) == b - a:
            try:
                out[a] = (b, *_numbers(rows))
                continue
            except ValueError:  # "1.2.3", "1e": not a number NUM matches
                pass
        k = a
        while k < b:
            g = plain(lines[k])
            if g is None:
                k += 1
                continue
            first, got = k, []
            while g is not None:
                got.append(g.groups())
                k += 1
                g = plain(lines[k]) if k < b else None
            out[first] = (k, *_numbers(got))
    return out


def _numbers(rows: list[tuple[str, ...]]) -> tuple[np.ndarray, list]:
    """x y z (k, 3) and each line's F or None, from plain lines' numbers as text (F "" or None
    where absent); ValueError where a number is not one."""
    xyz = np.array(list(map(float, [v for r in rows for v in r[:3]]))).reshape(-1, 3)
    return xyz, [float(r[3]) if r[3] else None for r in rows]


def _plain_block(b: RunBuilder, xyz: np.ndarray, fs: list, feed: float, per_s: bool, values: dict) -> float:
    """Plain `G1 X Y Z [F]` lines in a row (their points, each line's F or None) to the builder
    at once, as `move_to` of each would: the points of a run under way added in one call
    (`RunBuilder.moves_to`). No weld command lies among them: the weld values hold for all.
    Returns the feed the block leaves (mm/s)."""
    scale = 1.0 if per_s else 1.0 / 60.0
    speeds = []
    for f in fs:
        if f is not None:
            feed = f * scale
        speeds.append(feed)
    b.moves_to(xyz, speeds, values.get("wire_feed_speed", math.nan), bool(values))
    return feed
