"""G-code writer for gantry/CNC WAAM machines.

There is no G-code standard for WAAM; defaults follow the open ORNL Slicer 2 wire-arc convention
(`M3` welder on, `M5` welder off, `G4 P…` dwell, `G1 … F…`, `M30` end) and every machine-specific
code is a setting. Output: absolute millimetres (G21, G90), G0 travel (or G1 at the travel speed),
G1 deposition with F in mm/min (= segment speed mm/s × 60, converted only here), G2/G3 in the XY
plane (G17, I/J relative to the arc start) when arc fitting is on, `arc_on` + `G4` dwell after
each ignition, per-zone process commands from templates, `G4` for interlayer dwell, comments
naming layer/section/zone, `M30`.

The header carries a machine-readable line `; waamflow-post: arc_on=… arc_off=… dwell_units=…`
that `gcode_parse.parse_gcode` uses to read the program back.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from .common import check_templates, num, process_lines, process_summary, short
from .plan import ArcOff, ArcOn, Dwell, LayerStart, Motion, Plan, ProcessChange, SectionStart


@dataclass(frozen=True, eq=False)
class GcodeSettings:
    """program_name: written in the header. arc_on / arc_off: the machine's codes (a whole line,
    may hold several words). dwell_units: "s" or "ms" — unit of the G4 P word on this controller.
    rapid_travel: G0 for arc-off travel; False → G1 at `travel_speed` mm/s. process_codes:
    parameter name (core/process.py) → template using {value}, e.g. {"wire_feed_speed":
    "M100 S{value:.1f}"}; one line per parameter the zone has, where the zone changes. decimals:
    digits after the point for coordinates (mm)."""

    program_name: str = "waamflow"
    arc_on: str = "M3"
    arc_off: str = "M5"
    dwell_units: str = "s"
    rapid_travel: bool = True
    travel_speed: float = 100.0
    process_codes: dict[str, str] = field(default_factory=dict)
    decimals: int = 3

    def __post_init__(self) -> None:
        if self.dwell_units not in ("s", "ms"):
            raise ValueError(f"dwell_units must be 's' or 'ms', not {self.dwell_units!r}")
        for name in ("arc_on", "arc_off"):
            code = getattr(self, name)
            if not code.strip() or any(c in code for c in ";()\n"):
                raise ValueError(f"{name} must be a non-empty code without comments or newlines")
        if self.arc_on.strip().upper() == self.arc_off.strip().upper():
            raise ValueError("arc_on and arc_off must differ")
        check_templates(self.process_codes)


def header_tag(settings: GcodeSettings) -> str:
    return (f"; waamflow-post: arc_on={settings.arc_on.strip().replace(' ', '_')} "
            f"arc_off={settings.arc_off.strip().replace(' ', '_')} dwell_units={settings.dwell_units}")


def _dwell(seconds: float, settings: GcodeSettings) -> str:
    if settings.dwell_units == "ms":
        return f"G4 P{int(round(seconds * 1000.0))}"
    return f"G4 P{short(round(seconds, 3))}"


_NEG_ZERO = re.compile(r"(?<=[XYZ])-(?=0\.?0*(?: |$))")


def _xyz_words(pts: np.ndarray, decimals: int) -> list[str]:
    """"X… Y… Z…" of every point, as `num` writes them (fixed point, no negative zero), in one pass."""
    fmt = f"X%.{decimals}f Y%.{decimals}f Z%.{decimals}f"
    out = [fmt % tuple(p) for p in np.asarray(pts, float)[:, :3].tolist()]
    return [_NEG_ZERO.sub("", w) if "-0" in w else w for w in out]


def write_gcode(plan: Plan, settings: GcodeSettings = GcodeSettings()) -> str:
    """Render a `Plan` as G-code text (see module doc)."""
    pts = plan.moves.points
    st = plan.stats
    d = settings.decimals
    out = [
        f"; waamflow G-code -- program: {settings.program_name}",
        "; units: mm (G21), absolute (G90), feed F in mm/min, "
        f"dwell G4 P in {'milliseconds' if settings.dwell_units == 'ms' else 'seconds'}",
        f"; summary: layers {st['layers']}, sections {st['sections']}, points {st['points']}, "
        f"deposition {st['deposition_length_mm']:.3f} mm, travel {st['travel_length_mm']:.3f} mm, "
        f"arc-on count {st['arc_on_count']}, dwell {st['dwell_total_s']:.3f} s, "
        f"estimated time {st['estimated_time_s']:.1f} s",
        header_tag(settings),
        "G21 ; millimetres",
        "G90 ; absolute coordinates",
    ]
    if st.get("circular_motions"):
        out.append("G17 ; arcs in the XY plane")
    feed: float | None = None
    keys = plan.moves.section_keys
    words = _xyz_words(pts, d)
    for s in plan.steps:
        if isinstance(s, LayerStart):
            out.append(f"; layer {s.layer} z={num(s.z, d)}")
        elif isinstance(s, SectionStart):
            out.append(f"; section {keys[s.section]}")
        elif isinstance(s, ProcessChange):
            desc = process_summary(s.params)
            out.append(f"; zone {s.zone_id or '-'}" + (f": {desc}" if desc else ""))
            out.extend(process_lines(s.params, settings.process_codes))
        elif isinstance(s, ArcOn):
            out.append(f"{settings.arc_on} ; arc on")
        elif isinstance(s, ArcOff):
            out.append(f"{settings.arc_off} ; arc off")
        elif isinstance(s, Dwell):
            out.append(f"{_dwell(s.seconds, settings)} ; {s.reason} dwell {short(round(s.seconds, 3))} s")
        elif isinstance(s, Motion):
            xyz = words[s.end]
            if s.mode == "travel" and settings.rapid_travel:
                out.append(f"G0 {xyz}")
                continue
            v = settings.travel_speed if s.mode == "travel" else s.speed
            f_word = ""
            f_val = round(float(v) * 60.0, 1)
            if f_val != feed:
                f_word = f" F{short(f_val)}"
                feed = f_val
            if s.circular:
                c = np.asarray(s.center) - pts[s.start]
                code = "G3" if s.normal[2] > 0 else "G2"
                out.append(f"{code} {xyz} I{num(c[0], d)} J{num(c[1], d)}{f_word}")
            else:
                out.append(f"G1 {xyz}{f_word}")
    out.append("M30 ; end of program")
    return "\n".join(out) + "\n"
