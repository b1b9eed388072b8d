"""KUKA KRL writer: `name.src` (motion program) + `name.dat` (its data list), optionally split.

Program shape (expert KRL, no inline-form folds, so any KRC2/KRC4 editor reads it)::

    DEF name( )
      BAS(#INITMOV,0)  BAS(#TOOL,t)  BAS(#BASE,b)  $APO.CDIS=d  PTP $AXIS_ACT
      $VEL.CP=<m/s>                       ; restated wherever the speed changes (zone speeds)
      LIN P12 C_DIS / LIN P13             ; C_DIS blends; exact stop at arc switches and dwells
      CIRC P14,P15 C_DIS                  ; fitted arcs (aux point, end point) when arc fitting is on
      WAIT SEC t                          ; ignition, zone and interlayer dwell
    END

Arc control (`arc_control`):

* ``"output"``: the arc is a digital output. ON: ``$OUT[n]=TRUE`` at the (exactly reached) start
  point, then the ignition dwell. OFF: ``TRIGGER WHEN DISTANCE=1 DELAY=0 DO $OUT[n]=FALSE``
  armed on the last welding motion, so the output drops exactly at its end point without
  stopping the advance run. The zone's weld values are commands from `process_codes` templates
  (KRL statements), default `KRL_WELD_CODES`: analog outputs, $ANOUT[n] = value / full scale
  (±1.0 = ±10 V): $ANOUT[1] wire feed /20 (10 V = 20 m/min), $ANOUT[2] current /500 (10 V =
  500 A), $ANOUT[3] voltage /50 (10 V = 50 V); before an ignition as plain statements (the
  advance-run stop they cause falls on the exact stop there), inside a run (a zone change, a
  compensation step) only the changed values, each as `TRIGGER WHEN DISTANCE=0 DELAY=0 DO …` on
  the next motion (path-synchronised, no stop). A job number has no default command (map it to a
  template, e.g. a SIGNAL group output, or use ArcTech); a zone value without a command is a
  weld issue.
* ``"arctech"``: KUKA.ArcTech (Basic 3.x, KSS 8.x) in the expert form its inline forms ARC ON /
  ARC SWI / ARC OFF expand to: every welding motion is wrapped in calls of the ArcTech main routine
  (`arctech_routine`, default ``ArcMainNG``) with ArcTech path TRIGGERs, e.g. ::

      TRIGGER WHEN DISTANCE=1 DELAY=0 DO ArcMainNG(#ArcSwiMoveStd,WDAT3,WP1) PRIO=-1
      ArcMainNG(#ArcSwiBeforeMoveStd,WDAT3,WP1)
      LIN P14 C_DIS
      ArcMainNG(#ArcSwiAfterMoveStd,WDAT3,WP1)

  ARC ON wraps the motion into the run's first point (the torch stops there and ignites; when no
  such motion precedes, e.g. after an interlayer dwell, a zero-length LIN to that point), ARC OFF
  the run's last welding motion, ARC SWI every welding motion between. The weld data sets
  ``DECL stArcDat_T WDAT<k>`` in the .dat are filled from the zone parameters: Weld.Velocity =
  the segment's programmed speed (`arctech_velocity_unit`), Channel<n> = the zone parameter that
  `arctech_channels` maps to channel n (power-source dependent; default 1 job, 2 wire feed m/min,
  3 voltage V, 4 current A), Strike.StartTime = the ignition dwell, Strike/Crater channels as Weld. One set per
  distinct (channels, speed, ignition dwell). The seam data ``WP1`` names the program.

Points: every motion target (and CIRC auxiliary point) is ``P<i+1>`` for toolpath point i,
declared ``DECL E6POS P<i+1>={X,Y,Z,A,B,C,E1..E6}`` in the .dat of the program that uses it.
A, B, C come from the tool axis (orientation.py, KUKA tool direction X by default); E1..E6 from
the optional external-axis values (positioner), else 0.

Splitting (controllers limit file size): the main program (`src`/`dat`) then only initialises
and calls subprograms. `split_per_layer`: one per layer, ``name_L003`` (files ``L003.src`` /
``L003.dat``). `max_points_per_file` = N: no file holds more than N motions; a file ends after
an arc OFF when that leaves it at least half full, else between two motions (the arc output then
stays on across the call). Names ``name_P001``, … or, with both, ``name_L003_1``, ``name_L003_2``.
The files are named after their DEF (KRL requires module name = DEF name; `Program.file_names`):
``<program_name>.src``, ``<program_name>_L003.src``, …

Why ON is a plain output and OFF a TRIGGER: the ignition dwell must follow the switch-on with
the robot standing, so the output is set at the exact stop; switching off needs no stop, so a
path-related TRIGGER drops it exactly at the run's end point.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..core.process import PARAMETERS_BY_NAME
from .common import WELD_TAG, check_identifier, check_templates, num, process_lines, process_summary, short, weld_tag
from .common import TOOL_COMMANDS, check_tool_template, tool_lines, tool_summary
from .orientation import kuka_abc, tool_frames
from .plan import (
    ArcOff,
    ArcOn,
    Dwell,
    LayerStart,
    Motion,
    Plan,
    ProcessChange,
    SectionStart,
    Step,
    ToolOff,
    ToolOn,
    chunk_steps,
)


@dataclass(frozen=True, eq=False)
class KrlSettings:
    """program_name: DEF name (≤ 24 characters, ≤ 16 when split). tool / base: TOOL_DATA and
    BASE_DATA numbers. blend_distance: mm, $APO.CDIS (0 = exact stop everywhere). travel_speed:
    mm/s for arc-off travel. arc_control: "output" | "arctech". arc_output: $OUT number.
    tool_direction: "x" (KUKA default) or "z". max_points_per_file: 0 = no limit.
    split_per_layer: one subprogram per layer. process_codes: parameter name → KRL statement
    template with {value}. external_axes: (n, k ≤ 6) values of E1..Ek per toolpath point
    (positioner, mm or degrees), or None. arctech_routine: ArcTech main routine name.
    arctech_channels: zone parameter → ArcTech channel number 1..8. arctech_velocity_unit:
    unit of Weld.Velocity in the data sets ("m/min" or "m/s")."""

    program_name: str = "waamflow"
    tool: int = 1
    base: int = 1
    blend_distance: float = 1.0
    travel_speed: float = 100.0
    arc_control: str = "output"
    arc_output: int = 1
    tool_direction: str = "x"
    max_points_per_file: int = 0
    split_per_layer: bool = False
    process_codes: dict[str, str] = field(default_factory=lambda: dict(KRL_WELD_CODES))
    external_axes: np.ndarray | None = None
    arctech_routine: str = "ArcMainNG"
    arctech_channels: dict[str, int] = field(default_factory=lambda: dict(ARCTECH_CHANNELS))
    arctech_velocity_unit: str = "m/min"
    decimals: int = 3
    tool_on: str = TOOL_COMMANDS["krl"][0]  # post-deposition tool (rolling, peening): common.py
    tool_off: str = TOOL_COMMANDS["krl"][1]

    @property
    def split(self) -> bool:
        return self.split_per_layer or self.max_points_per_file > 0

    def __post_init__(self) -> None:
        check_identifier(self.program_name, 16 if self.split else 24)
        if self.arc_control not in ("output", "arctech"):
            raise ValueError(f"arc_control must be 'output' or 'arctech', not {self.arc_control!r}")
        if not 1 <= self.arc_output <= 4096:
            raise ValueError("arc_output must be an output number 1..4096")
        if self.max_points_per_file < 0 or 0 < self.max_points_per_file < 2:
            raise ValueError("max_points_per_file must be 0 (no limit) or at least 2")
        check_templates(self.process_codes)
        check_tool_template(self.tool_on, "tool_on")
        check_tool_template(self.tool_off, "tool_off")
        check_identifier(self.arctech_routine, 24, "ArcTech routine name")
        check_channels(self.arctech_channels)
        if self.arctech_velocity_unit not in VELOCITY_UNITS:
            raise ValueError(f"arctech_velocity_unit must be one of {', '.join(VELOCITY_UNITS)}")


ARCTECH_CHANNELS: dict[str, int] = {"job": 1, "wire_feed_speed": 2, "voltage": 3, "current": 4}
# Output mode: analog outputs, value / full scale (KRL $ANOUT is -1.0..1.0 = -10..10 V).
KRL_WELD_CODES: dict[str, str] = {
    "wire_feed_speed": "$ANOUT[1]={value:.3f}/20",
    "current": "$ANOUT[2]={value:.1f}/500",
    "voltage": "$ANOUT[3]={value:.2f}/50",
}
VELOCITY_UNITS: dict[str, float] = {"m/min": 0.06, "m/s": 0.001}  # factor from mm/s


def check_channels(channels: dict[str, int]) -> dict[str, int]:
    """ArcTech channel map: known zone parameter names → distinct channel numbers 1..8."""
    for name, ch in channels.items():
        if name not in PARAMETERS_BY_NAME:
            raise ValueError(
                f"ArcTech channel for unknown zone parameter {name!r} (known: {', '.join(PARAMETERS_BY_NAME)})"
            )
        if not isinstance(ch, int) or not 1 <= ch <= 8:
            raise ValueError(f"ArcTech channel of {name!r} must be 1..8, not {ch!r}")
    if len(set(channels.values())) != len(channels):
        raise ValueError("ArcTech channels must be distinct")
    return dict(channels)


@dataclass(frozen=True)
class _Chunk:
    name: str  # DEF name
    suffix: str  # "" for an unsplit program, else "L003", "P001", ...
    steps: tuple[int, ...]  # indices into plan.steps


def _chunks(plan: Plan, s: KrlSettings) -> list[_Chunk]:
    """Split the plan's steps into programs (`plan.chunk_steps`): at layer starts (per-layer) and
    so that no program holds more than `max_points_per_file` motions, cut back at the latest arc
    OFF that leaves it at least half full."""
    steps = plan.steps
    if not s.split:
        return [_Chunk(s.program_name, "", tuple(range(len(steps))))]
    groups = chunk_steps(steps, per_layer=s.split_per_layer, max_points=s.max_points_per_file, cut_back=True)
    per_layer: dict[int | None, int] = {}
    for g in groups:
        per_layer[g.layer] = per_layer.get(g.layer, 0) + 1
    seen: dict[int | None, int] = {}
    out: list[_Chunk] = []
    for i, g in enumerate(groups):
        if s.split_per_layer and g.layer is not None:
            seen[g.layer] = seen.get(g.layer, 0) + 1
            suffix = f"L{g.layer:03d}" + (f"_{seen[g.layer]}" if per_layer[g.layer] > 1 else "")
        else:
            suffix = f"P{i + 1:03d}"
        out.append(_Chunk(f"{s.program_name}_{suffix}", suffix, g.steps))
    return out


class _ArcTech:
    """ArcTech weld data sets (numbered in order of first use) and the calls around motions."""

    def __init__(self, plan: Plan, s: KrlSettings):
        self.plan, self.s = plan, s
        self.sets: dict[tuple, tuple[str, str]] = {}  # key → (name, description)
        self.seam = "WP1"
        self.used: set[str] = set()  # names used by the program being written

    def data_set(self, section: int, zone: int, speed: float, strike_s: float) -> str:
        params = self.plan.moves.zone_params.get((section, zone), {})
        chans = tuple(
            sorted((ch, round(float(params.get(name, 0.0)), 4)) for name, ch in self.s.arctech_channels.items())
        )
        key = (chans, round(float(speed), 3), round(float(strike_s), 3))
        if key not in self.sets:
            zid = self.plan.moves.zone_ids[zone] if 0 <= zone < len(self.plan.moves.zone_ids) else "-"
            desc = (
                f"{self.plan.moves.section_keys[section]} zone {zid}: {process_summary(params) or 'no parameters'}, "
                f"{short(round(float(speed), 3))} mm/s"
            )
            self.sets[key] = (f"WDAT{len(self.sets) + 1}", desc)
        self.used.add(self.sets[key][0])
        return self.sets[key][0]

    def call(self, action: str, wdat: str) -> str:
        return f"{self.s.arctech_routine}(#{action},{wdat},{self.seam})"

    def trigger(self, when: str, delay: str, action: str, wdat: str) -> str:
        return f"TRIGGER WHEN {when} DELAY={delay} DO {self.call(action, wdat)} PRIO=-1"

    def arc_on(self, wdat: str, motion: list[str]) -> list[str]:
        return [
            ";- ARC ON " + wdat,
            self.trigger("DISTANCE=1", f"ArcGetDelay(#PreDefinition,{wdat})", "PreDefinition", wdat),
            self.trigger(
                f"PATH=ArcGetPath(#OnTheFlyArcOn,{wdat})", f"ArcGetDelay(#GasPreflow,{wdat})", "GasPreflow", wdat
            ),
            self.trigger(f"PATH=ArcGetPath(#OnTheFlyArcOn,{wdat})", "0", "ArcOnMoveStd", wdat),
            self.call("ArcOnBeforeMoveStd", wdat),
            *motion,
            self.call("ArcOnAfterMoveStd", wdat),
        ]

    def arc_swi(self, wdat: str, motion: list[str]) -> list[str]:
        return [
            self.trigger("DISTANCE=1", "0", "ArcSwiMoveStd", wdat),
            self.call("ArcSwiBeforeMoveStd", wdat),
            *motion,
            self.call("ArcSwiAfterMoveStd", wdat),
        ]

    def arc_off(self, wdat: str, motion: list[str]) -> list[str]:
        return [
            ";- ARC OFF " + wdat,
            self.trigger(f"PATH=ArcGetPath(#ArcOffBefore,{wdat})", "0", "ArcOffBeforeOffStd", wdat),
            self.trigger(f"PATH=ArcGetPath(#OnTheFlyArcOff,{wdat})", "0", "ArcOffMoveStd", wdat),
            self.call("ArcOffBeforeMoveStd", wdat),
            *motion,
            self.call("ArcOffAfterMoveStd", wdat),
        ]

    def decls(self) -> list[str]:
        """The .dat declarations of the program just written: seam data WP1 and its weld data
        sets WDAT<k> (a .dat's declarations are local to its program)."""
        s = self.s
        if not self.used:
            return []
        factor = VELOCITY_UNITS[s.arctech_velocity_unit]
        out = [
            f'DECL stArcDat_T {self.seam}={{WdatId[] "{self.seam}",Strike {{SeamName[] "{s.program_name}",'
            f'PartName[] "waamflow",SeamNumber 0,PartNumber 0,DesiredLength 0.0,LengthTolNeg 0.0,'
            f"LengthTolPos 0.0,LengthCtrlActive FALSE}}}}"
        ]
        for (chans, speed, strike), (name, desc) in self.sets.items():
            if name not in self.used:
                continue
            values = dict(chans)
            ch = ",".join(f"Channel{k} {num(values.get(k, 0.0), 4)}" for k in range(1, 9))
            out.append(f";- {name}: {desc}" + (f", ignition dwell {short(strike)} s" if strike else ""))
            out.append(
                f'DECL stArcDat_T {name}={{WdatId[] "{name}",'
                f'Strike {{JobModeId[] "Job mode",StartTime {num(strike, 3)},PreFlowTime 0.0,{ch},PurgeTime 0.0}},'
                f'Weld {{JobModeId[] "Job mode",ParamSetId[] "Set1",Velocity {num(speed * factor, 5)},{ch}}},'
                f"Weave {{Pattern #None,Length 4.0,Amplitude 2.0,Angle 0.0,LeftSideDelay 0.0,RightSideDelay 0.0}},"
                f'Crater {{JobModeId[] "Job mode",ParamSetId[] "Set2",CraterTime 0.0,PostflowTime 0.0,{ch},'
                f"BurnBackTime 0.0}}}}"
            )
        return out


def _next_significant(steps, k: int):
    """The step after k that is not a marker or process comment (layer, section, zone change)."""
    for j in range(k + 1, len(steps)):
        if not isinstance(steps[j], (LayerStart, SectionStart, ProcessChange)):
            return steps[j]
    return None


def _first_weld(steps, k: int) -> Motion | None:
    for j in range(k + 1, len(steps)):
        if isinstance(steps[j], Motion):
            return steps[j] if steps[j].mode == "weld" else None
    return None


def _e6pos(i: int, pts: np.ndarray, abc: np.ndarray, ext: np.ndarray | None, d: int) -> str:
    p, o = pts[i], abc[i]
    e = [0.0] * 6
    if ext is not None:
        e[: ext.shape[1]] = ext[i].tolist()
    es = ",".join(f"E{k + 1} {num(v, d)}" for k, v in enumerate(e))
    return (
        f"DECL E6POS P{i + 1}={{X {num(p[0], d)},Y {num(p[1], d)},Z {num(p[2], d)},"
        f"A {num(o[0], 4)},B {num(o[1], 4)},C {num(o[2], 4)},{es}}}"
    )


def _arc_on_before(steps, first: int) -> bool:
    """Whether the arc is on where step `first` starts a program (output mode: on across a call)."""
    return any(isinstance(steps[j], ArcOn) for j in range(first)) and not isinstance(
        next((steps[j] for j in range(first - 1, -1, -1) if isinstance(steps[j], (ArcOn, ArcOff))), None), ArcOff
    )


class _KrlBody:
    """The body lines of one program, step by step: the $VEL.CP in force, the points used, the arc
    state and the weld values commanded (output mode), the arc-off motion just written (ArcTech
    ignites on it) and the weld-value path triggers waiting for the next motion."""

    def __init__(self, plan: Plan, s: KrlSettings, chunk: _Chunk, arctech: _ArcTech | None) -> None:
        self.s, self.arctech = s, arctech
        self.steps = plan.steps
        self.keys = plan.moves.section_keys
        self.lines: list[str] = []
        self.used: list[int] = []
        self.vel: float | None = None
        self.approach: tuple[int, int] | None = None  # lines[a:b] of the arc-off motion just written (ArcTech)
        self.arc = _arc_on_before(self.steps, chunk.steps[0] if chunk.steps else 0)
        self.commanded: dict[str, float] = {}
        self.pending: list[str] = []  # path triggers of weld values, right before the next motion

    def speed_lines(self, v: float) -> list[str]:
        v_ms = round(float(v) / 1000.0, 6)
        if v_ms == self.vel:
            return []
        self.vel = v_ms
        return [f"$VEL.CP={v_ms:.6f} ; {short(round(float(v), 3))} mm/s"]

    def motion_lines(self, st: Motion, blend: str) -> list[str]:
        if st.circular:
            self.used.extend([st.via, st.end])
            return [f"CIRC P{st.via + 1},P{st.end + 1}{blend}"]
        self.used.append(st.end)
        return [f"LIN P{st.end + 1}{blend}"]

    def step(self, k: int, st: Step) -> None:
        """The lines of plan step k."""
        s, lines = self.s, self.lines
        if isinstance(st, LayerStart):
            lines.append(f";- layer {st.layer} z={num(st.z, s.decimals)}")
        elif isinstance(st, SectionStart):
            lines.append(f";- section {self.keys[st.section]}")
        elif isinstance(st, ProcessChange):
            self.process_change(st)
        elif isinstance(st, ArcOn):
            self.arc_on(k, st)
        elif isinstance(st, ArcOff):
            self.arc = False
            if self.arctech is None:
                lines.append(f";- arc off at P{st.point + 1} (trigger)")
        elif isinstance(st, Dwell):
            self.approach = None
            if self.arctech is not None and st.reason == "ignition":
                lines.append(f";- ignition dwell {short(round(st.seconds, 3))} s (Strike.StartTime)")
                return
            lines.append(
                f"WAIT SEC {short(round(st.seconds, 3))} ; {st.reason} dwell" + (f" ({st.note})" if st.note else "")
            )
        elif isinstance(st, (ToolOn, ToolOff)):  # a routine call does not stop the advance run: WAIT SEC 0 does
            self.approach = None
            on = isinstance(st, ToolOn)
            tparams = st.params if isinstance(st, ToolOn) else {}
            tl = tool_lines(s.tool_on if on else s.tool_off, st.tool, tparams)
            self.lines += (
                ["WAIT SEC 0 ; advance-run stop: switch at the point"]
                + tl[:-1]
                + [f"{tl[-1]} ; {tool_summary(st.tool, tparams) if on else st.tool + ' off'}"]
            )
        elif isinstance(st, Motion):
            self.motion(k, st)

    def process_change(self, st: ProcessChange) -> None:
        desc = process_summary(st.params)
        self.lines.append(f";- zone {st.zone_id or '-'}" + (f": {desc}" if desc else ""))
        if self.arctech is None:
            if self.arc:  # inside a run: the changes, at the next motion's start
                changed = {n for n, v in st.params.items() if self.commanded.get(n) != float(v)}
                self.pending = [
                    f"TRIGGER WHEN DISTANCE=0 DELAY=0 DO {ln}"
                    for ln in process_lines(st.params, self.s.process_codes, names=changed)
                ]
            else:
                self.lines.extend(process_lines(st.params, self.s.process_codes))
            self.commanded.update({n: float(v) for n, v in st.params.items()})

    def arc_on(self, k: int, st: ArcOn) -> None:
        """Output mode: the arc output on. ArcTech: the arc-on call on the arc-off motion just
        written, else a LIN to the point to ignite in place."""
        steps, arctech = self.steps, self.arctech
        if arctech is None:
            self.lines.append(f"$OUT[{self.s.arc_output}]=TRUE ; arc on")
            self.arc = True
            return
        nxt = steps[k + 1] if k + 1 < len(steps) else None
        strike = nxt.seconds if isinstance(nxt, Dwell) and nxt.reason == "ignition" else 0.0
        first = _first_weld(steps, k)
        wdat = arctech.data_set(st.section, st.zone, first.speed if first else self.s.travel_speed, strike)
        if self.approach is not None:
            a, b = self.approach
            self.lines[a:b] = arctech.arc_on(wdat, self.lines[a:b])
        else:  # ignite where the torch stands
            self.used.append(st.point)
            self.lines.extend(arctech.arc_on(wdat, [f"LIN P{st.point + 1} ; ignite in place"]))

    def motion(self, k: int, st: Motion) -> None:
        s, steps, arctech, lines = self.s, self.steps, self.arctech, self.lines
        v = s.travel_speed if st.mode == "travel" else st.speed
        start = len(lines)
        lines.extend(self.speed_lines(v))
        lines.extend(self.pending)
        self.pending = []
        nxt = steps[k + 1] if k + 1 < len(steps) else None
        blend = " C_DIS" if (s.blend_distance > 0 and not st.stop) else ""
        if arctech is not None and st.mode == "weld":
            wdat = arctech.data_set(st.section, st.zone, st.speed, 0.0)
            wrap = arctech.arc_off if isinstance(_next_significant(steps, k), ArcOff) else arctech.arc_swi
            lines.extend(wrap(wdat, self.motion_lines(st, blend)))
            self.approach = None
            return
        if arctech is None and isinstance(nxt, ArcOff):
            lines.append(f"TRIGGER WHEN DISTANCE=1 DELAY=0 DO $OUT[{s.arc_output}]=FALSE")
        lines.extend(self.motion_lines(st, blend))
        self.approach = (start, len(lines))


def _render_chunk(plan: Plan, s: KrlSettings, chunk: _Chunk, arctech: _ArcTech | None) -> tuple[list[str], list[int]]:
    """Body lines of one program and the point indices it references."""
    body = _KrlBody(plan, s, chunk, arctech)
    for k in chunk.steps:
        body.step(k, plan.steps[k])
    return body.lines, body.used


def _header(plan: Plan, s: KrlSettings) -> list[str]:
    st = plan.stats
    arc = (
        f"digital output $OUT[{s.arc_output}]"
        if s.arc_control == "output"
        else f"KUKA.ArcTech {s.arctech_routine}, weld data sets WDAT<k> in the .dat (Weld.Velocity in "
        f"{s.arctech_velocity_unit}; channels "
        + ", ".join(f"{ch} {name}" for name, ch in sorted(s.arctech_channels.items(), key=lambda kv: kv[1]))
        + ")"
    )
    return [
        f";- waamflow KUKA KRL program {s.program_name}",
        f";- layers {st['layers']}, sections {st['sections']}, points {st['points']}, motions {st['motions']}",
        f";- deposition {st['deposition_length_mm']:.3f} mm, travel {st['travel_length_mm']:.3f} mm, "
        f"arc-on count {st['arc_on_count']}, dwell {st['dwell_total_s']:.3f} s",
        f";- units: mm, degrees, $VEL.CP in m/s; tool {s.tool}, base {s.base}, "
        f"tool direction {s.tool_direction.upper()}, blend $APO.CDIS {short(s.blend_distance)} mm",
        f";- arc control: {arc}",
        *(
            ";- " + t
            for t in (
                weld_tag(s.process_codes)
                if s.arc_control == "output"
                else weld_tag({n: f"stArcDat_T.Weld.Channel{ch}" for n, ch in s.arctech_channels.items()})
            )
        ),
    ]


def _init(s: KrlSettings, n_ext: int) -> list[str]:
    out = [
        "BAS(#INITMOV,0)",
        f"BAS(#TOOL,{s.tool})",
        f"BAS(#BASE,{s.base})",
        f"$APO.CDIS={short(s.blend_distance)}",
    ]
    if n_ext:
        axes = "E1" if n_ext == 1 else f"E1..E{n_ext}"
        out += [
            f";- external axes {axes} (positioner) in every E6POS; BASE_DATA[{s.base}] must be the "
            "base coupled to the positioner (external kinematics)",
            f"IF $EX_AX_NUM<{n_ext} THEN",
            f"  HALT ; this program moves {axes}: the controller has fewer external axes",
            "ENDIF",
        ]
    out.append("PTP $AXIS_ACT ; BCO run to the current position")
    return out


def _src(name: str, header: list[str], body: list[str]) -> str:
    lines = ["&ACCESS RVP", "&REL 1", f"DEF {name}( )", *header, *body, "END"]
    return "\n".join(lines) + "\n"


def _dat(name: str, points: list[int], pts, abc, ext, d, extra: Sequence[str] = ()) -> str:
    lines = [f"DEFDAT {name}", *extra]
    lines += [_e6pos(i, pts, abc, ext, d) for i in sorted(set(points))]
    lines.append("ENDDAT")
    return "\n".join(lines) + "\n"


def write_krl(plan: Plan, settings: KrlSettings = KrlSettings()) -> dict[str, str]:
    """Render a `Plan` as KRL files: suffix → text ("src", "dat", and "L003.src", ... when split)."""
    s = settings
    pts = plan.moves.points
    ext = None if s.external_axes is None else np.asarray(s.external_axes, dtype=float).reshape(len(pts), -1)
    if ext is not None and ext.shape[1] > 6:
        raise ValueError("at most 6 external axes (E1..E6)")
    n_ext = 0 if ext is None else ext.shape[1]
    abc = kuka_abc(tool_frames(plan.moves.tool_axis, s.tool_direction)) if len(pts) else np.zeros((0, 3))
    arctech = _ArcTech(plan, s) if s.arc_control == "arctech" else None
    header = _header(plan, s)
    chunks = _chunks(plan, s)
    files: dict[str, str] = {}

    def render(ch: _Chunk) -> tuple[list[str], list[int], list[str]]:
        if arctech is not None:
            arctech.used = set()
        body, used = _render_chunk(plan, s, ch, arctech)
        return body, used, arctech.decls() if arctech is not None else []

    if not s.split:
        body, used, decls = render(chunks[0])
        files["src"] = _src(s.program_name, header, _init(s, n_ext) + body)
        files["dat"] = _dat(s.program_name, used, pts, abc, ext, s.decimals, decls)
        return files
    calls = []
    for ch in chunks:
        body, used, decls = render(ch)
        files[f"{ch.suffix}.src"] = _src(
            ch.name,
            [f";- part of {s.program_name}, called from {s.program_name}.src", *(h for h in header if WELD_TAG in h)],
            body,
        )
        files[f"{ch.suffix}.dat"] = _dat(ch.name, used, pts, abc, ext, s.decimals, decls)
        calls.append(f"{ch.name}( )")
    off = [f"$OUT[{s.arc_output}]=FALSE ; arc off (safety)"] if s.arc_control == "output" else []
    files["src"] = _src(
        s.program_name,
        header + [f";- subprograms: {len(chunks)} (files {s.program_name}_<suffix>.src/.dat)"],
        _init(s, n_ext) + calls + off,
    )
    files["dat"] = _dat(s.program_name, [], pts, abc, ext, s.decimals)
    return dict(sorted(files.items(), key=lambda kv: (kv[0] not in ("src", "dat"), kv[0])))
