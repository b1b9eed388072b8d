"""G-code writer for gantry/CNC WAAM machines.

There is no G-code standard for WAAM; defaults follow the open ORNL Slicer 2 wire-arc convention
(`M3` welder on, `M5` welder off, `G4 P…` dwell, `G1 … F…`, `M30` end) and every machine-specific
code is a setting. Output: absolute millimetres (G21, G90), G0 travel (or G1 at the travel speed),
G1 deposition with F in mm/min (= segment speed mm/s × 60, converted only here), G2/G3 in the XY
plane (G17, I/J relative to the arc start) when arc fitting is on, `arc_on` + `G4` dwell after
each ignition, per-zone process commands from templates, `G4` for interlayer dwell, comments
naming layer/section/zone, `M30`. Post-deposition tool sections (rolling, peening) are engaged
and lifted by the `tool_on` / `tool_off` templates (default LinuxCNC user M-codes
`M110 P<force N> Q<width mm>` / `M111`), with a comment stating force, width and speed.

Dialect (the machine profile's table): `comment_style` (`;` or `( )`), `feed_units` (F in mm/min,
G94 — or mm/s for controllers that read it so), `dwell_units` (G4 P in s or ms), `start_code`
lines after the header, `layer_code` templates at every layer change ({layer}, {z}), `end_code`
lines after the last motion, `final_lift` (mm: a G0 up by that much after the arc is off, before
the end code) and `program_end` (M30, M2, or e.g. M84 on Marlin where M30 deletes a file);
`preamble`/`postamble` lines go before the header and after the end (Fanuc-style `%` tape
delimiters and `O` program number).

The header carries a machine-readable line `; waamflow-post: arc_on=… arc_off=… dwell_units=…
feed_units=… end=…` that `gcode_parse.parse_gcode` uses to read the program back.

The weld as commands (`process_codes`, default `GCODE_WELD_CODES`: LinuxCNC analog outputs). At
every zone change the zone's weld values (wire feed m/min, current A, voltage V, job) are written
as commands, not only as the comment: before an ignition (arc off) in the `process_codes_start`
form — default `M68 E<n> Q<value>`, immediate, so the output is set before the arc-on code — and
while welding (a zone or a compensation step inside a run) in the `process_codes` form, only the
values that changed — default `M67 E<n> Q<value>`, synchronised with the start of the next
motion, no stop. Channels: E0 wire feed (m/min), E1 current (A), E2 voltage (V), values in the
parameter's unit (scale to the power source's 0-10 V in HAL); job by the user M-code `M120 P<job>`
(a script `M120` in the config's USER_M_PATH). `process_scale` multiplies a value before it is
written (e.g. Marlin PWM 0-255). A header line `; waamflow-weld: name[unit]="template" …` lists
every command (common.weld_tag); a zone value without one is a weld issue (post_process).

Travel: G0 at the controller's rapid rate (`rapid_travel`; the time estimate assumes
`travel_speed`), or — `travel_feed`, for controllers whose G0 moves at the modal feed (Marlin:
G0 = G1) — G0 with F = `travel_speed` on every travel line, or G1 at `travel_speed`.

Positioner cells: with `external_axes` (the positioner angles in degrees at every toolpath point,
columns E1 tilt, E2 turn, from `trajectory.cell.positioner_angles`) each motion carries them as
rotary-axis words, letters from `rotary_axes` (the machine profile's, e.g. A/C for a table that
tilts about X and turns about Z, B/C when the tilt axis is the machine's Y) in `rotary_units`
(deg or rad). X/Y/Z stay in the part frame on the positioner table: the controller's tool centre
point control (LinuxCNC `xyzac-trt-kins`, Sinumerik TRAORI, Fanuc G43.4) turns them into machine
motion. A rotary word is written when its value changes (and on the first motion).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .common import (
    TOOL_COMMANDS,
    check_templates,
    check_tool_template,
    num,
    process_lines,
    process_summary,
    short,
    tool_lines,
    tool_summary,
    weld_tag,
)
from .gcode_parse import _words
from .plan import ArcOff, ArcOn, Dwell, LayerStart, Motion, Plan, ProcessChange, SectionStart, Step, ToolOff, ToolOn

# LinuxCNC analog outputs (motion.analog-out-NN): E0 wire feed m/min, E1 current A, E2 voltage V;
# M67 = synchronised with the next motion (inside a run), M68 = immediate (before an ignition).
# Job: LinuxCNC user M-code M120 P<job> (M100-M199 take P and Q).
GCODE_WELD_CODES = {
    "wire_feed_speed": "M67 E0 Q{value:.2f}",
    "current": "M67 E1 Q{value:.1f}",
    "voltage": "M67 E2 Q{value:.2f}",
    "job": "M120 P{value:.0f}",
}
GCODE_WELD_CODES_START = {
    "wire_feed_speed": "M68 E0 Q{value:.2f}",
    "current": "M68 E1 Q{value:.1f}",
    "voltage": "M68 E2 Q{value:.2f}",
    "job": "M120 P{value:.0f}",
}


@dataclass(frozen=True, eq=False)
class GcodeSettings:
    """program_name: written in the header. arc_on / arc_off: the machine's codes (a whole line,
    may hold several words). dwell_units: "s" or "ms" — unit of the G4 P word on this controller.
    rapid_travel: G0 for arc-off travel; False → G1 at `travel_speed` mm/s. travel_feed: write
    F = travel_speed on every G0 (controllers whose G0 uses the modal feed: Marlin). process_codes:
    parameter name (core/process.py) → template using {value}, e.g. {"wire_feed_speed":
    "M100 S{value:.1f}"}, written where the zone changes while welding ("" = not commanded);
    process_codes_start: the form before an ignition (None: GCODE_WELD_CODES_START when
    process_codes is the default, else process_codes); process_scale: name → factor applied to
    the value. decimals: digits after the point for coordinates (mm)."""

    program_name: str = "waamflow"
    arc_on: str = "M3"
    arc_off: str = "M5"
    dwell_units: str = "s"
    rapid_travel: bool = True
    travel_speed: float = 100.0
    process_codes: dict[str, str] = field(default_factory=lambda: dict(GCODE_WELD_CODES))
    process_codes_start: dict[str, str] | None = None
    process_scale: dict[str, float] = field(default_factory=dict)
    travel_feed: bool = False
    decimals: int = 3
    rotary_axes: tuple[str, ...] = ("A", "C")
    rotary_units: str = "deg"
    tcp_control: bool = True  # the controller turns part-frame X Y Z + rotary words into machine motion
    external_axes: np.ndarray | None = None
    comment_style: str = "semicolon"
    feed_units: str = "mm/min"
    start_code: tuple[str, ...] = ()
    layer_code: tuple[str, ...] = ()
    end_code: tuple[str, ...] = ()
    final_lift: float = 0.0
    program_end: str = "M30"
    preamble: tuple[str, ...] = ()
    postamble: tuple[str, ...] = ()

    tool_on: str = TOOL_COMMANDS["gcode"][0]
    tool_off: str = TOOL_COMMANDS["gcode"][1]

    def __post_init__(self) -> None:
        check_tool_template(self.tool_on, "tool_on")
        check_tool_template(self.tool_off, "tool_off")
        if self.comment_style not in ("semicolon", "parentheses"):
            raise ValueError(f"comment_style must be 'semicolon' or 'parentheses', not {self.comment_style!r}")
        if self.feed_units not in ("mm/min", "mm/s"):
            raise ValueError(f"feed_units must be 'mm/min' or 'mm/s', not {self.feed_units!r}")
        if not (self.final_lift >= 0.0 and np.isfinite(self.final_lift)):
            raise ValueError(f"final_lift must be ≥ 0 mm, not {self.final_lift}")
        for name in ("start_code", "layer_code", "end_code", "preamble", "postamble"):
            for line in getattr(self, name):
                if "\n" in line:
                    raise ValueError(f"{name}: one line per entry, no newlines ({line!r})")
        for tpl in self.layer_code:
            check_line_template(tpl)
        if not self.program_end.strip() or any(c in self.program_end for c in ";()\n"):
            raise ValueError("program_end must be a non-empty code without comments or newlines")
        if self.rotary_units not in ("deg", "rad"):
            raise ValueError(f"rotary_units must be 'deg' or 'rad', not {self.rotary_units!r}")
        letters = tuple(self.rotary_axes)
        if len(set(letters)) != len(letters) or any(a not in ("A", "B", "C", "U", "V", "W") for a in letters):
            raise ValueError(f"rotary_axes {list(letters)!r}: distinct letters among A, B, C, U, V, W")
        if self.dwell_units not in ("s", "ms"):
            raise ValueError(f"dwell_units must be 's' or 'ms', not {self.dwell_units!r}")
        for name in ("arc_on", "arc_off"):
            check_arc_code(name, getattr(self, name))
        if self.arc_on.strip().upper() == self.arc_off.strip().upper():
            raise ValueError("arc_on and arc_off must differ")
        check_templates(self.process_codes)
        check_templates(self.process_codes_start or {})
        for name, k in self.process_scale.items():
            check_templates({name: ""})
            if not (np.isfinite(k) and k > 0):
                raise ValueError(f"process_scale of {name!r} must be > 0, not {k}")
        for tpl in [*self.process_codes.values(), *(self.process_codes_start or {}).values()]:
            if any(c in tpl for c in ";()"):
                raise ValueError(f"process template {tpl!r}: no comments (; or parentheses) in a G-code command")
            if any(a in _AXIS_LETTERS or (a == "G" and v in (0, 1, 2, 3)) for a, v in _words(tpl.format(value=1.0))):
                raise ValueError(
                    f"process template {tpl!r}: a weld command with a motion (G0..G3) or an axis or arc-centre "
                    "word would move the torch on the controller (the preflight reads it as the weld value only)"
                )

    @property
    def start_codes(self) -> dict[str, str]:
        """The commands written before an ignition: process_codes_start over process_codes."""
        if self.process_codes_start is None:
            return dict(GCODE_WELD_CODES_START) if self.process_codes == GCODE_WELD_CODES else dict(self.process_codes)
        return {**self.process_codes, **self.process_codes_start}


def check_line_template(tpl: str) -> str:
    """A layer-change template may use only the fields {layer} and {z}."""
    import string

    try:
        fields = [f for _, f, _, _ in string.Formatter().parse(tpl) if f is not None]
        bad = [f for f in fields if f not in ("layer", "z")]
        if bad:
            raise ValueError(f"layer_code template {tpl!r} uses {bad}: only {{layer}} and {{z}}")
        tpl.format(layer=1, z=1.0)
    except (ValueError, IndexError, KeyError) as err:
        raise ValueError(f"layer_code template {tpl!r}: {err}") from None
    return tpl


def header_tag(settings: GcodeSettings) -> str:
    return (
        f"waamflow-post: arc_on={settings.arc_on.strip().replace(' ', '_')} "
        f"arc_off={settings.arc_off.strip().replace(' ', '_')} dwell_units={settings.dwell_units} "
        f"feed_units={settings.feed_units} end={settings.program_end.strip().replace(' ', '_')}"
    )


def _travel_note(settings: GcodeSettings) -> str:
    """What the controller does on travel, as the header states it (no false time claim)."""
    v = short(settings.travel_speed)
    if not settings.rapid_travel:
        return f"travel: G1 at travel_speed {v} mm/s (F on the first travel line after a feed change)"
    if settings.travel_feed:
        return f"travel: G0 with F at travel_speed {v} mm/s on every travel line (G0 moves at the modal feed)"
    return (
        f"travel: G0 at the controller's rapid rate; the estimated time assumes {v} mm/s "
        "(set travel_speed to the machine's rapid rate)"
    )


def _commenter(settings: GcodeSettings) -> Callable[[str], str]:
    """text → a whole-line comment; (code, text) → code with a trailing comment."""
    if settings.comment_style == "parentheses":

        def c(text: str) -> str:
            return "(" + text.replace("(", "[").replace(")", "]").replace(";", ",") + ")"
    else:

        def c(text: str) -> str:
            return "; " + text

    return c


def _dwell(seconds: float, settings: GcodeSettings) -> str:
    if settings.dwell_units == "ms":
        return f"G4 P{int(round(seconds * 1000.0))}"
    return f"G4 P{short(round(seconds, 3))}"


_NEG_ZERO = re.compile(r"(?<=[XYZ])-(?=0\.?0*(?: |$))")
_AXIS_LETTERS = frozenset("XYZABCUVWIJK")  # words no weld command may carry, nor G0..G3
_MOTION_LETTERS = _AXIS_LETTERS | {"G", "F"}  # words no arc code may carry (check_arc_code)
_CODE_WORD = re.compile(r"[A-Za-z][-+]?(?:\d+\.?\d*|\.\d+)")  # one word of an arc code (the preflight reads it back so)


def check_arc_code(name: str, code: str) -> str:
    """`arc_on` / `arc_off` as the program writes and the preflight reads them: an M code and its
    parameters (M3, M101 P1, M42 P4 S255), written first, words of a letter and a number separated
    by spaces; no comment, and no G, axis, arc-centre or feed word (it would move the torch or change
    a mode on the controller while the preflight reads the line as the arc switch only)."""
    if not code.strip() or any(c in code for c in ";()\n"):
        raise ValueError(f"{name} must be a non-empty code without comments or newlines")
    words = [w for w in code.split(" ") if w]
    if not all(_CODE_WORD.fullmatch(w) for w in words):
        raise ValueError(
            f"{name} {code!r}: G-code words separated by spaces, each a letter and a number (e.g. M3, or M101 P1)"
        )
    if words[0][0].upper() != "M" or any(w[0].upper() in _MOTION_LETTERS for w in words):
        raise ValueError(
            f"{name} {code!r}: the arc is switched by an M code and its parameters (M3, M101 P1, "
            "M42 P4 S255), written first; no G, axis (X Y Z A B C U V W), arc-centre (I J K) or feed "
            "(F) word, which would move the torch or change a mode on the controller"
        )
    return code


def _xyz_words(pts: np.ndarray, decimals: int) -> list[str]:
    """ "X… Y… Z…" of every point, as `num` writes them (fixed point, no negative zero), in one pass."""
    if len(pts) == 0:
        return []
    fmt = f"X%.{decimals}f Y%.{decimals}f Z%.{decimals}f\n"
    flat = np.asarray(pts, float)[:, :3].ravel().tolist()  # row by row (ravel copies a column slice)
    out = ((fmt * len(pts)) % tuple(flat)).split("\n")[:-1]  # one % over all points: the same words
    return [_NEG_ZERO.sub("", w) if "-0" in w else w for w in out]


def _positioner_words(plan: Plan, settings: GcodeSettings) -> np.ndarray | None:
    """The positioner angles per point in the rotary words' unit, or None without a positioner."""
    pts = plan.moves.points
    if settings.external_axes is None or not len(pts):
        return None
    ext = np.asarray(settings.external_axes, dtype=float).reshape(len(pts), -1)
    if ext.shape[1] > len(settings.rotary_axes):
        raise ValueError(
            f"{ext.shape[1]} positioner axes but rotary_axes names only "
            f"{len(settings.rotary_axes)} ({', '.join(settings.rotary_axes)})"
        )
    if settings.rotary_units == "rad":
        ext = np.radians(ext)
    return ext


def _header(plan: Plan, settings: GcodeSettings, c: Callable[[str], str], ext: np.ndarray | None) -> list[str]:
    """Preamble, header comments (summary, travel, `waamflow-post:` and weld tags), modes, start
    code, the rotary axes' meaning and G17 when there are arcs."""
    st = plan.stats
    out = [
        *settings.preamble,
        c(f"waamflow G-code -- program: {settings.program_name}"),
        c(
            f"units: mm (G21), absolute (G90), feed F in {settings.feed_units}, "
            f"dwell G4 P in {'milliseconds' if settings.dwell_units == 'ms' else 'seconds'}"
        ),
        c(
            f"summary: layers {st['layers']}, sections {st['sections']}, points {st['points']}, "
            f"deposition {st['deposition_length_mm']:.3f} mm, travel {st['travel_length_mm']:.3f} mm, "
            f"arc-on count {st['arc_on_count']}, dwell {st['dwell_total_s']:.3f} s, "
            f"estimated time {st['estimated_time_s']:.1f} s"
        ),
        c(_travel_note(settings)),
        c(header_tag(settings)),
        *(c(t) for t in weld_tag(settings.process_codes, settings.start_codes, settings.process_scale)),
        f"G21 {c('millimetres')}",
        f"G90 {c('absolute coordinates')}",
    ]
    if settings.feed_units == "mm/min":
        out.append(f"G94 {c('feed per minute')}")
    out.extend(settings.start_code)
    if ext is not None:
        names = ("E1 (tilt)", "E2 (turn)", "E3", "E4", "E5", "E6")
        out.append(
            c(
                "rotary axes: "
                + ", ".join(f"{a} = positioner {names[k]}" for k, a in enumerate(settings.rotary_axes[: ext.shape[1]]))
                + f" in {'degrees' if settings.rotary_units == 'deg' else 'radians'}; X Y Z in the part "
                + (
                    "frame on the positioner (needs the controller's tool centre point control)"
                    if settings.tcp_control
                    else "frame on the positioner; this controller has no tool centre point control: the part "
                    "frame must coincide with the table's axes"
                )
            )
        )
    if st.get("circular_motions"):
        out.append(f"G17 {c('arcs in the XY plane')}")
    return out


class _Body:
    """The program's lines after the header, step by step: the modal feed, the rotary words last
    written, the weld values in force and whether the arc is on."""

    def __init__(self, plan: Plan, settings: GcodeSettings, c: Callable[[str], str], ext: np.ndarray | None) -> None:
        self.s, self.c, self.ext = settings, c, ext
        self.pts = plan.moves.points
        self.d = settings.decimals
        self.keys = plan.moves.section_keys
        self.words = _xyz_words(self.pts, self.d)
        self.feed_scale = 60.0 if settings.feed_units == "mm/min" else 1.0
        self.travel_f = round(settings.travel_speed * self.feed_scale, 1 if self.feed_scale == 60.0 else 3)
        self.feed: float | None = None
        self.last_v: float | None = None  # the speed (mm/s) whose F value is last_f
        self.last_f = math.nan
        self.rot_last: list[str | None] = [None] * (0 if ext is None else ext.shape[1])
        self.last_end = -1  # the point of the last motion (-1: none yet)
        self.arc = False
        self.commanded: dict[str, float] = {}  # weld values in force (written while welding: changes only)
        self.out: list[str] = []

    def step(self, s: Step) -> None:
        if isinstance(s, Motion):  # most steps are motions: before the other kinds are tried one by one
            self.motion(s)
            return
        settings, c, out = self.s, self.c, self.out
        if isinstance(s, LayerStart):
            out.append(c(f"layer {s.layer} z={num(s.z, self.d)}"))
            out.extend(t.format(layer=s.layer, z=float(s.z)) for t in settings.layer_code)
        elif isinstance(s, SectionStart):
            out.append(c(f"section {self.keys[s.section]}"))
        elif isinstance(s, ProcessChange):
            self.process_change(s)
        elif isinstance(s, ArcOn):
            out.append(f"{settings.arc_on} {c('arc on')}")
            self.arc = True
        elif isinstance(s, ArcOff):
            out.append(f"{settings.arc_off} {c('arc off')}")
            self.arc = False
        elif isinstance(s, Dwell):
            note = f" ({s.note})" if s.note else ""
            out.append(f"{_dwell(s.seconds, settings)} {c(f'{s.reason} dwell {short(round(s.seconds, 3))} s{note}')}")
        elif isinstance(s, ToolOn):
            lines = tool_lines(settings.tool_on, s.tool, s.params)
            out.extend(lines[:-1] + [f"{lines[-1]} {c(tool_summary(s.tool, s.params))}"])
        elif isinstance(s, ToolOff):
            lines = tool_lines(settings.tool_off, s.tool, {})
            out.extend(lines[:-1] + [f"{lines[-1]} {c(f'{s.tool} off')}"])

    def process_change(self, s: ProcessChange) -> None:
        settings = self.s
        desc = process_summary(s.params)
        self.out.append(self.c(f"zone {s.zone_id or '-'}" + (f": {desc}" if desc else "")))
        if self.arc:  # inside a run: only what changed, synchronised with motion
            changed = {k for k, v in s.params.items() if self.commanded.get(k) != float(v)}
            self.out.extend(process_lines(s.params, settings.process_codes, settings.process_scale, changed))
        else:
            self.out.extend(process_lines(s.params, settings.start_codes, settings.process_scale))
        self.commanded.update({k: float(v) for k, v in s.params.items()})

    def motion(self, s: Motion) -> None:
        settings, out, d, ext = self.s, self.out, self.d, self.ext
        self.last_end = s.end
        xyz = self.words[s.end]
        if ext is not None:
            for k, letter in enumerate(settings.rotary_axes[: ext.shape[1]]):
                word = num(ext[s.end, k], d if settings.rotary_units == "deg" else 6)
                if word != self.rot_last[k]:
                    xyz += f" {letter}{word}"
                    self.rot_last[k] = word
        if s.mode == "travel" and settings.rapid_travel:
            if settings.travel_feed:  # G0 at the modal feed (Marlin): F on every travel line
                out.append(f"G0 {xyz} F{short(self.travel_f)}")
                self.feed = self.travel_f
            else:
                out.append(f"G0 {xyz}")
            return
        v = settings.travel_speed if s.mode == "travel" else s.speed
        f_word = ""
        if v != self.last_v:  # the feed word of a speed: computed when the speed changes (NaN: always)
            self.last_v, self.last_f = v, round(float(v) * self.feed_scale, 1 if self.feed_scale == 60.0 else 3)
        f_val = self.last_f
        if f_val != self.feed:
            f_word = f" F{short(f_val)}"
            self.feed = f_val
        if s.circular:
            center, normal = s.arc_geometry()
            cc = np.asarray(center) - self.pts[s.start]
            code = "G3" if normal[2] > 0 else "G2"
            out.append(f"{code} {xyz} I{num(cc[0], d)} J{num(cc[1], d)}{f_word}")
        else:
            out.append(f"G1 {xyz}{f_word}")


def write_gcode(plan: Plan, settings: GcodeSettings = GcodeSettings()) -> str:
    """Render a `Plan` as G-code text (see module doc)."""
    c = _commenter(settings)
    ext = _positioner_words(plan, settings)
    out = _header(plan, settings, c, ext)
    body = _Body(plan, settings, c, ext)
    for s in plan.steps:
        body.step(s)
    out += body.out
    d = settings.decimals
    if settings.final_lift > 0 and body.last_end >= 0:
        f_lift = f" F{short(body.travel_f)}" if settings.travel_feed else ""
        out.append(
            f"G0 Z{num(body.pts[body.last_end][2] + settings.final_lift, d)}{f_lift} "
            f"{c(f'final lift {short(settings.final_lift)} mm')}"
        )
    out.extend(settings.end_code)
    out.append(f"{settings.program_end} {c('end of program')}")
    out.extend(settings.postamble)
    return "\n".join(out) + "\n"
