"""Read a G-code program (ours, or any using the same conventions) back into deposition runs.

Used by the round-trip tests and for a "load program" preview. Understands G0/G1/G2/G3 (modal,
XY-plane arcs with I/J relative centres, Z interpolated linearly = helix), G4 P (in the program's
dwell units) and G4 S (seconds), G20/G21, G90/G91, F (mm/min, modal), `;` and `( )` comments,
the machine's arc ON/OFF lines (matched word for word) and M2/M30.

Arc codes and dwell units come from the arguments, else from the `; waamflow-post:` header line
our writer emits, else the defaults M3/M5/seconds; so do the feed unit (mm/min, or mm/s) and the
program end code (M2/M30, or the profile's, e.g. M84).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

_WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
_TAG = re.compile(
    r"waamflow-post:\s*arc_on=(\S+)\s+arc_off=(\S+)\s+dwell_units=(ms|s)\b"
    r"(?:\s+feed_units=(mm/min|mm/s))?(?:\s+end=([^\s)]+))?"
)
ARC_STEP_RAD = math.radians(2.0)  # arc discretisation: chord/arc length error < θ²/24 ≈ 5e-5


@dataclass(frozen=True, eq=False)
class DepositRun:
    """The motion between one arc ON and the next arc OFF.

    points: (k, 3) float mm (G2/G3 arcs discretised every 2°). feed_mm_min: (k - 1,) float, the
    F in force on each segment. ignition_line: 1-based line number of the arc ON.
    ignition_dwell_s: the first dwell after the arc ON before any motion (None: no dwell).
    """

    points: np.ndarray
    feed_mm_min: np.ndarray
    ignition_line: int
    ignition_dwell_s: float | None

    @property
    def length(self) -> float:
        if len(self.points) < 2:
            return 0.0
        return float(np.linalg.norm(np.diff(self.points, axis=0), axis=1).sum())


@dataclass(frozen=True, eq=False)
class ParsedProgram:
    """runs: deposition runs in program order. dwells: (line, seconds, arc on) for every G4.
    travel_length_mm: length moved with the arc off. ignitions / extinctions: counts of arc ON /
    OFF lines. ended: an M2/M30 was read. units_mm: G21 seen (or no G20)."""

    runs: tuple[DepositRun, ...]
    dwells: tuple[tuple[int, float, bool], ...]
    travel_length_mm: float
    ignitions: int
    extinctions: int
    ended: bool
    comments: tuple[str, ...] = field(default_factory=tuple)

    @property
    def deposition_length_mm(self) -> float:
        return float(sum(r.length for r in self.runs))

    def to_dict(self) -> dict:
        """JSON-ready form for a program preview: runs (points mm, feed mm/min, ignition dwell s),
        dwells, counts and lengths."""
        return {
            "units": "mm",
            "runs": [
                {
                    "points": np.round(r.points, 4).tolist(),
                    "feed_mm_min": np.round(r.feed_mm_min, 3).tolist(),
                    "ignition_line": r.ignition_line,
                    "ignition_dwell_s": r.ignition_dwell_s,
                    "length_mm": round(r.length, 4),
                }
                for r in self.runs
            ],
            "dwells": [{"line": ln, "seconds": s, "arc_on": on} for ln, s, on in self.dwells],
            "ignitions": self.ignitions,
            "extinctions": self.extinctions,
            "deposition_length_mm": round(self.deposition_length_mm, 4),
            "travel_length_mm": round(self.travel_length_mm, 4),
            "ended": self.ended,
        }


def _words(code: str) -> list[tuple[str, float]]:
    return [(m.group(1), float(m.group(2))) for m in _WORD.finditer(code.upper())]


def _split_comment(line: str) -> tuple[str, str]:
    comments = re.findall(r"\(([^)]*)\)", line)
    code = re.sub(r"\([^)]*\)", " ", line)
    if ";" in code:
        code, c = code.split(";", 1)
        comments.append(c)
    return code.strip(), " ".join(x.strip() for x in comments)


def _arc_points(p0: np.ndarray, p1: np.ndarray, ij: tuple[float, float], cw: bool) -> np.ndarray:
    """Discretised XY arc from p0 to p1 about p0 + (i, j), Z linear; excludes p0, ends at p1."""
    c = p0[:2] + np.asarray(ij)
    a0 = math.atan2(p0[1] - c[1], p0[0] - c[0])
    a1 = math.atan2(p1[1] - c[1], p1[0] - c[0])
    sweep = a1 - a0
    if cw:
        sweep = sweep - 2 * math.pi if sweep >= -1e-12 else sweep
        if abs(sweep + 2 * math.pi) < 1e-9 and np.linalg.norm(p1[:2] - p0[:2]) > 1e-6:
            sweep = 0.0
    else:
        sweep = sweep + 2 * math.pi if sweep <= 1e-12 else sweep
        if abs(sweep - 2 * math.pi) < 1e-9 and np.linalg.norm(p1[:2] - p0[:2]) > 1e-6:
            sweep = 0.0
    r = float(np.linalg.norm(p0[:2] - c))
    n = max(1, int(math.ceil(abs(sweep) / ARC_STEP_RAD)))
    t = np.arange(1, n + 1) / n
    ang = a0 + sweep * t
    out = np.column_stack([c[0] + r * np.cos(ang), c[1] + r * np.sin(ang), p0[2] + (p1[2] - p0[2]) * t])
    out[-1] = p1
    return out


def parse_gcode(
    text: str, *, arc_on: str | None = None, arc_off: str | None = None, dwell_units: str | None = None
) -> ParsedProgram:
    """Parse G-code text into a `ParsedProgram` (see module doc)."""
    tag = _TAG.search(text)
    if tag:
        arc_on = arc_on or tag.group(1).replace("_", " ")
        arc_off = arc_off or tag.group(2).replace("_", " ")
        dwell_units = dwell_units or tag.group(3)
    on_words = _words(arc_on or "M3")
    off_words = _words(arc_off or "M5")
    dwell_scale = 1e-3 if (dwell_units or "s") == "ms" else 1.0
    feed_to_mm_min = 60.0 if (tag and tag.group(4) == "mm/s") else 1.0
    end_words = _words(tag.group(5).replace("_", " ")) if (tag and tag.group(5)) else None

    pos = np.zeros(3)
    scale, absolute, motion, feed = 1.0, True, 0, float("nan")
    runs: list[DepositRun] = []
    dwells: list[tuple[int, float, bool]] = []
    comments: list[str] = []
    travel = 0.0
    ignitions = extinctions = 0
    ended = False
    run_pts: list[np.ndarray] | None = None
    run_feed: list[float] = []
    run_line, run_dwell, run_moved = 0, None, False

    def close_run() -> None:
        nonlocal run_pts
        if run_pts is not None:
            runs.append(DepositRun(np.vstack(run_pts), np.asarray(run_feed, float), run_line, run_dwell))
        run_pts = None

    for ln, raw in enumerate(text.splitlines(), start=1):
        code, comment = _split_comment(raw)
        if comment:
            comments.append(comment)
        if not code:
            continue
        words = _words(code)
        if words == on_words:
            ignitions += 1
            close_run()
            run_pts, run_feed, run_line, run_dwell, run_moved = [pos.copy()], [], ln, None, False
            continue
        if words == off_words:
            extinctions += 1
            close_run()
            continue
        vals = {}
        gcodes = []
        for letter, v in words:
            if letter == "G":
                gcodes.append(v)
            else:
                vals[letter] = v
        dwell_here = False
        for g in gcodes:
            if g in (0, 1, 2, 3):
                motion = int(g)
            elif g == 20:
                scale = 25.4
            elif g == 21:
                scale = 1.0
            elif g == 90:
                absolute = True
            elif g == 91:
                absolute = False
            elif g == 4:
                dwell_here = True
        if vals.get("M") in (2, 30) or (end_words and words == end_words):
            ended = True
        if "F" in vals:
            feed = vals["F"] * scale * feed_to_mm_min
        if dwell_here:
            sec = vals["S"] if "S" in vals else vals.get("P", 0.0) * dwell_scale
            dwells.append((ln, float(sec), run_pts is not None))
            if run_pts is not None and not run_moved and run_dwell is None:
                run_dwell = float(sec)
            continue
        if not any(k in vals for k in "XYZ"):
            continue
        target = pos.copy()
        for axis, k in enumerate("XYZ"):
            if k in vals:
                target[axis] = vals[k] * scale if absolute else pos[axis] + vals[k] * scale
        if motion in (2, 3):
            seg = _arc_points(pos, target, (vals.get("I", 0.0) * scale, vals.get("J", 0.0) * scale), motion == 2)
        else:
            seg = target[None, :]
        if run_pts is not None:
            run_pts.extend(seg)
            run_feed.extend([feed] * len(seg))
            run_moved = True
        else:
            travel += float(np.linalg.norm(np.diff(np.vstack([pos, seg]), axis=0), axis=1).sum())
        pos = target
    close_run()
    return ParsedProgram(tuple(runs), tuple(dwells), travel, ignitions, extinctions, ended, tuple(comments))
