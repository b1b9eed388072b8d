"""G-code read back: motions, the arc codes the `waamflow-post:` header names and the weld
commands its `waamflow-weld:` lines declare."""

from __future__ import annotations

import math
import re
from typing import Callable

import numpy as np

from ...program.common import parse_weld_tag, template_regex
from .core import NUM, ProgramRead, RunBuilder

_GWORD = re.compile(r"([A-Z])\s*(" + NUM + ")")
# the straight motions that make most of a program, as waamflow writes them: read without the
# general path's comment, word and weld-command passes (same numbers, same builder calls)
_PLAIN_G1 = re.compile(r"G1 X(" + NUM + ") Y(" + NUM + ") Z(" + NUM + r")(?: F(" + NUM + "))?")
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
    plain = _plain_g1(weld_rx, arc_letters)
    block: list[tuple[str, ...]] = []  # plain lines in a row, not yet handed to the builder
    for ln, raw in enumerate(text.splitlines(), start=1):
        if plain is not None and raw.startswith("G1 X"):
            m = plain(raw)
            if m is not None:
                motion = 1
                block.append(m.groups())
                continue
        if block:  # what the next line means may depend on them (the feed, the position)
            feed = _plain_block(b, block, feed, per_s, values)
            block.clear()
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
        x = vals["X"] if "X" in vals else float(here[0])
        y = vals["Y"] if "Y" in vals else float(here[1])
        z = vals["Z"] if "Z" in vals else float(here[2])
        speed = math.nan if motion == 0 else feed
        if motion in (2, 3):
            seg = _gcode_arc(here, np.array((x, y, z)), vals.get("I", 0.0), vals.get("J", 0.0), motion == 2)
            b.move(seg, speed, values.get("wire_feed_speed", math.nan), bool(values))
        else:
            b.move_to(x, y, z, speed, values.get("wire_feed_speed", math.nan), bool(values))
    if block:
        _plain_block(b, block, feed, per_s, values)
    b.close()
    return b.out


def _plain_block(b: RunBuilder, block: list[tuple[str, ...]], feed: float, per_s: bool, values: dict) -> float:
    """Plain `G1 X Y Z [F]` lines in a row (their regex groups) to the builder at once, as
    `move_to` of each would: the numbers converted in one pass, the points of a run under way added
    in one call (`RunBuilder.moves_to`; 0.2-0.3 s of the bench vase's 68,000 lines was one call
    per line). No weld command lies among them: the weld values hold for all. Returns the feed the
    block leaves (mm/s)."""
    scale = 1.0 if per_s else 1.0 / 60.0
    speeds = []
    for g in block:
        if g[3] is not None:
            feed = float(g[3]) * scale
        speeds.append(feed)
    xyz = np.array([(float(g[0]), float(g[1]), float(g[2])) for g in block])
    b.moves_to(xyz, speeds, values.get("wire_feed_speed", math.nan), bool(values))
    return feed
