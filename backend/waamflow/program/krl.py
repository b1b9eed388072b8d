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
  stopping the advance run. Process values go through `process_codes` templates (KRL statements,
  e.g. {"current": "$ANOUT[1]={value:.0f}/500"}) plus a comment.
* ``"arctech"``: ArcTech-style calls ``ARC_ON(k)``, ``ARC_SWI(k)`` (zone change inside a run),
  ``ARC_OFF(k)`` where k is the zone's power-source ``job`` number (or, without one, the index of
  the zone's distinct parameter set, listed in the header). The cell maps these onto its ArcTech
  inline forms / wrapper routines (ArcTech's own folds carry option-specific data we cannot emit).

Points: every motion target (and CIRC auxiliary point) is ``P<i+1>`` for toolpath point i,
declared ``DECL E6POS P<i+1>={X,Y,Z,A,B,C,E1..E6}`` in the .dat of the program that uses it.
A, B, C come from the tool axis (orientation.py, KUKA tool direction X by default); E1..E6 from
the optional external-axis values (positioner), else 0.

Splitting (controllers limit file size): the main program (`src`/`dat`) then only initialises
and calls subprograms. `split_per_layer`: one per layer, ``name_L003`` (files ``L003.src`` /
``L003.dat``). `max_points_per_file` = N: no file holds more than N motions; a file ends after
an arc OFF when that leaves it at least half full, else between two motions (the arc output then
stays on across the call). Names ``name_P001``, … or, with both, ``name_L003_1``, ``name_L003_2``.
On the controller, name the files after their DEF (KRL requires module name = DEF name):
``<program_name>.src``, ``<program_name>_L003.src``, …

Why ON is a plain output and OFF a TRIGGER: the ignition dwell must follow the switch-on with
the robot standing, so the output is set at the exact stop; switching off needs no stop, so a
path-related TRIGGER drops it exactly at the run's end point.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .common import check_identifier, check_templates, num, process_lines, process_summary, short
from .common import TOOL_COMMANDS, check_tool_template, tool_lines, tool_summary
from .orientation import kuka_abc, tool_frames
from .plan import ArcOff, ArcOn, Dwell, LayerStart, Motion, Plan, ProcessChange, SectionStart, Step, ToolOff, ToolOn


@dataclass(frozen=True, eq=False)
class KrlSettings:
    """program_name: DEF name (≤ 24 characters, ≤ 16 when split). tool / base: TOOL_DATA and
    BASE_DATA numbers. blend_distance: mm, $APO.CDIS (0 = exact stop everywhere). travel_speed:
    mm/s for arc-off travel. arc_control: "output" | "arctech". arc_output: $OUT number.
    tool_direction: "x" (KUKA default) or "z". max_points_per_file: 0 = no limit.
    split_per_layer: one subprogram per layer. process_codes: parameter name → KRL statement
    template with {value}. external_axes: (n, k ≤ 6) values of E1..Ek per toolpath point
    (positioner, mm or degrees), or None."""

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
    process_codes: dict[str, str] = field(default_factory=dict)
    external_axes: np.ndarray | None = None
    decimals: int = 3
    tool_on: str = TOOL_COMMANDS["krl"][0]     # post-deposition tool (rolling, peening): common.py
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


@dataclass(frozen=True)
class _Chunk:
    name: str      # DEF name
    suffix: str    # "" for an unsplit program, else "L003", "P001", ...
    steps: tuple[int, ...]  # indices into plan.steps


def _chunks(plan: Plan, s: KrlSettings) -> list[_Chunk]:
    """Split the plan's steps into programs: at layer starts (per-layer) and so that no program
    holds more than `max_points_per_file` motions (see `_cut`)."""
    steps = plan.steps
    if not s.split:
        return [_Chunk(s.program_name, "", tuple(range(len(steps))))]
    groups: list[tuple[int | None, list[int]]] = []
    layer: int | None = None
    count = 0
    for k, st in enumerate(steps):
        if isinstance(st, LayerStart):
            layer = st.layer
            if s.split_per_layer and groups and any(isinstance(steps[j], Motion) for j in groups[-1][1]):
                groups.append((layer, []))
                count = 0
        if not groups:
            groups.append((layer, []))
        if isinstance(st, Motion) and s.max_points_per_file and count >= s.max_points_per_file:
            cur = groups[-1][1]
            j = _cut(steps, cur, s.max_points_per_file)
            tail = cur[j:]
            del cur[j:]
            groups.append((groups[-1][0], tail))
            count = sum(isinstance(steps[i], Motion) for i in tail)
        groups[-1][1].append(k)
        if isinstance(st, Motion):
            count += 1
    per_layer: dict[int | None, int] = {}
    for lay, _ in groups:
        per_layer[lay] = per_layer.get(lay, 0) + 1
    seen: dict[int | None, int] = {}
    out: list[_Chunk] = []
    for i, (lay, g) in enumerate(groups):
        if s.split_per_layer and lay is not None:
            seen[lay] = seen.get(lay, 0) + 1
            suffix = f"L{lay:03d}" + (f"_{seen[lay]}" if per_layer[lay] > 1 else "")
        else:
            suffix = f"P{i + 1:03d}"
        out.append(_Chunk(f"{s.program_name}_{suffix}", suffix, tuple(g)))
    return out


def _cut(steps, cur: list[int], limit: int) -> int:
    """Where to end a full program (index into `cur`): right after the latest arc OFF that leaves
    it at least half full (no subprogram switch while welding), else right after its last motion
    (keeping an arc OFF that closes it)."""
    motions = 0
    best = None
    for j, i in enumerate(cur):
        if isinstance(steps[i], Motion):
            motions += 1
        elif isinstance(steps[i], ArcOff) and motions >= max(1, limit // 2):
            best = j + 1
    if best is not None:
        return best
    j = len(cur)
    while j > 0 and not isinstance(steps[cur[j - 1]], Motion):
        j -= 1
    if j < len(cur) and isinstance(steps[cur[j]], ArcOff):
        j += 1
    return j


def _weld_sets(plan: Plan) -> dict[tuple[int, int], int]:
    """(section, zone) → ArcTech data-set number: the zone's `job` when it has one; zones without
    a job are numbered by distinct parameter set, after the highest job number."""
    sets: dict[tuple[int, int], int] = {}
    changes = [st for st in plan.steps if isinstance(st, ProcessChange)]
    top = max((int(round(st.params["job"])) for st in changes if "job" in st.params), default=0)
    distinct: list[tuple] = []
    for st in changes:
        if (st.section, st.zone) in sets:
            continue
        if "job" in st.params:
            sets[(st.section, st.zone)] = int(round(st.params["job"]))
            continue
        key = tuple(sorted(st.params.items()))
        if key not in distinct:
            distinct.append(key)
        sets[(st.section, st.zone)] = top + distinct.index(key) + 1
    return sets


def _e6pos(i: int, pts: np.ndarray, abc: np.ndarray, ext: np.ndarray | None, d: int) -> str:
    p, o = pts[i], abc[i]
    e = [0.0] * 6
    if ext is not None:
        e[: ext.shape[1]] = ext[i].tolist()
    es = ",".join(f"E{k + 1} {num(v, d)}" for k, v in enumerate(e))
    return (f"DECL E6POS P{i + 1}={{X {num(p[0], d)},Y {num(p[1], d)},Z {num(p[2], d)},"
            f"A {num(o[0], 4)},B {num(o[1], 4)},C {num(o[2], 4)},{es}}}")


def _render_chunk(plan: Plan, s: KrlSettings, chunk: _Chunk, weld_sets) -> tuple[list[str], list[int]]:
    """Body lines of one program and the point indices it references."""
    steps = plan.steps
    keys = plan.moves.section_keys
    d = s.decimals
    lines: list[str] = []
    used: list[int] = []
    vel: float | None = None
    active_set: int | None = None
    out_no = s.arc_output
    for k in chunk.steps:
        st: Step = steps[k]
        if isinstance(st, LayerStart):
            lines.append(f";- layer {st.layer} z={num(st.z, d)}")
        elif isinstance(st, SectionStart):
            lines.append(f";- section {keys[st.section]}")
        elif isinstance(st, ProcessChange):
            desc = process_summary(st.params)
            lines.append(f";- zone {st.zone_id or '-'}" + (f": {desc}" if desc else ""))
            if s.arc_control == "output":
                lines.extend(process_lines(st.params, s.process_codes))
            else:
                new_set = weld_sets[(st.section, st.zone)]
                nxt = steps[k + 1] if k + 1 < len(steps) else None
                if not isinstance(nxt, ArcOn) and active_set is not None and new_set != active_set:
                    lines.append(f"ARC_SWI({new_set})")
                active_set = new_set
        elif isinstance(st, ArcOn):
            if s.arc_control == "output":
                lines.append(f"$OUT[{out_no}]=TRUE ; arc on")
            else:
                active_set = weld_sets.get((st.section, st.zone), 1)
                lines.append(f"ARC_ON({active_set})")
        elif isinstance(st, ArcOff):
            if s.arc_control == "output":
                lines.append(f";- arc off at P{st.point + 1} (trigger)")
            else:
                lines.append(f"ARC_OFF({active_set if active_set is not None else 1})")
        elif isinstance(st, Dwell):
            lines.append(f"WAIT SEC {short(round(st.seconds, 3))} ; {st.reason} dwell" + (f" ({st.note})" if st.note else ""))
        elif isinstance(st, (ToolOn, ToolOff)):   # a routine call does not stop the advance run: WAIT SEC 0 does
            on = isinstance(st, ToolOn)
            tl = tool_lines(s.tool_on if on else s.tool_off, st.tool, st.params if on else {})
            lines += ["WAIT SEC 0 ; advance-run stop: switch at the point"] + tl[:-1] + [
                f"{tl[-1]} ; {tool_summary(st.tool, st.params) if on else st.tool + ' off'}"]
        elif isinstance(st, Motion):
            v = s.travel_speed if st.mode == "travel" else st.speed
            v_ms = round(float(v) / 1000.0, 6)
            if v_ms != vel:
                lines.append(f"$VEL.CP={v_ms:.6f} ; {short(round(float(v), 3))} mm/s")
                vel = v_ms
            nxt = steps[k + 1] if k + 1 < len(steps) else None
            if s.arc_control == "output" and isinstance(nxt, ArcOff):
                lines.append(f"TRIGGER WHEN DISTANCE=1 DELAY=0 DO $OUT[{out_no}]=FALSE")
            blend = " C_DIS" if (s.blend_distance > 0 and not st.stop) else ""
            if st.circular:
                lines.append(f"CIRC P{st.via + 1},P{st.end + 1}{blend}")
                used += [st.via, st.end]
            else:
                lines.append(f"LIN P{st.end + 1}{blend}")
                used.append(st.end)
    return lines, used


def _header(plan: Plan, s: KrlSettings, weld_sets) -> list[str]:
    st = plan.stats
    out = [
        f";- waamflow KUKA KRL program {s.program_name}",
        f";- layers {st['layers']}, sections {st['sections']}, points {st['points']}, motions {st['motions']}",
        f";- deposition {st['deposition_length_mm']:.3f} mm, travel {st['travel_length_mm']:.3f} mm, "
        f"arc-on count {st['arc_on_count']}, dwell {st['dwell_total_s']:.3f} s",
        f";- units: mm, degrees, $VEL.CP in m/s; tool {s.tool}, base {s.base}, "
        f"tool direction {s.tool_direction.upper()}, blend $APO.CDIS {short(s.blend_distance)} mm",
        f";- arc control: " + (f"digital output $OUT[{s.arc_output}]" if s.arc_control == "output"
                                  else "ArcTech-style ARC_ON/ARC_SWI/ARC_OFF(data set)"),
    ]
    if s.arc_control == "arctech":
        listed: set[int] = set()
        for (sec, zone), n in sorted(weld_sets.items(), key=lambda kv: kv[1]):
            if n in listed:
                continue
            listed.add(n)
            params = plan.moves.zone_params.get((sec, zone), {})
            zid = plan.moves.zone_ids[zone] if 0 <= zone < len(plan.moves.zone_ids) else ""
            out.append(f";- data set {n} (first used by {plan.moves.section_keys[sec]} zone {zid}): "
                       f"{process_summary(params)}")
    return out


def _init(s: KrlSettings) -> list[str]:
    return [
        "BAS(#INITMOV,0)",
        f"BAS(#TOOL,{s.tool})",
        f"BAS(#BASE,{s.base})",
        f"$APO.CDIS={short(s.blend_distance)}",
        "PTP $AXIS_ACT ; BCO run to the current position",
    ]


def _src(name: str, header: list[str], body: list[str]) -> str:
    lines = ["&ACCESS RVP", "&REL 1", f"DEF {name}( )", *header, *body, "END"]
    return "\n".join(lines) + "\n"


def _dat(name: str, points: list[int], pts, abc, ext, d) -> str:
    lines = [f"DEFDAT {name}"]
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
    abc = kuka_abc(tool_frames(plan.moves.tool_axis, s.tool_direction)) if len(pts) else np.zeros((0, 3))
    weld_sets = _weld_sets(plan) if s.arc_control == "arctech" else {}
    header = _header(plan, s, weld_sets)
    chunks = _chunks(plan, s)
    files: dict[str, str] = {}
    if not s.split:
        body, used = _render_chunk(plan, s, chunks[0], weld_sets)
        files["src"] = _src(s.program_name, header, _init(s) + body)
        files["dat"] = _dat(s.program_name, used, pts, abc, ext, s.decimals)
        return files
    calls = []
    for ch in chunks:
        body, used = _render_chunk(plan, s, ch, weld_sets)
        files[f"{ch.suffix}.src"] = _src(ch.name, [f";- part of {s.program_name}, called from {s.program_name}.src"], body)
        files[f"{ch.suffix}.dat"] = _dat(ch.name, used, pts, abc, ext, s.decimals)
        calls.append(f"{ch.name}( )")
    off = [f"$OUT[{s.arc_output}]=FALSE ; arc off (safety)"] if s.arc_control == "output" else []
    files["src"] = _src(s.program_name, header + [f";- subprograms: {len(chunks)} (files {s.program_name}_<suffix>.src/.dat)"],
                        _init(s) + calls + off)
    files["dat"] = _dat(s.program_name, [], pts, abc, ext, s.decimals)
    return dict(sorted(files.items(), key=lambda kv: (kv[0] not in ("src", "dat"), kv[0])))
