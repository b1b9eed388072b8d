"""From the flat move list to a neutral program plan: motions, arc switches, dwells, process changes.

Every writer (G-code, KRL, RAPID, INFORM, TP) renders the same `Plan`, so they agree on where the
arc ignites, where it dwells and which speed each motion has; `chunk_steps` is the one splitter of
a plan into controller programs (per layer, at most N positions, never while welding) for the KRL,
INFORM and TP writers.

Rules (the plan is a faithful rendering of `waamflow.core.moves.Moves`):

* One motion per toolpath point (the first is the move to the start point), or fewer when arc
  fitting merges vertices into circular motions.
* A motion's mode: ``weld`` (segment with the arc on, programmed speed), ``move`` (arc off at a
  programmed speed — e.g. a strategy's link outside the section), ``travel`` (arc off between
  sections/layers, no programmed speed: the machine's travel speed or rapid).
* Arc ON before the first segment of each maximal arc-on run, arc OFF after its last one.
* Dwell after each ignition: the zone's ``dwell`` parameter (s) when the zone has one, otherwise
  the `ignition_dwell` setting — always emitted, so every ignition is followed by a dwell.
* A zone that starts inside a run (arc already on) and has a ``dwell`` > 0 dwells there, arc on.
* `Moves.dwell_before[i]` (interlayer dwell) dwells at point i before anything else happens there
  (after an arc OFF, before an arc ON); its `Moves.dwell_notes[i]` (e.g. the interpass rule that
  set it) goes with it.
* Post-deposition tool sections (`Moves.section_tools`: rolling, peening): the tool is engaged
  (`ToolOn`, with the tool's parameters) before each maximal run of the section's arc-OFF
  segments with a programmed speed (its contact strokes) and lifted (`ToolOff`) after it; the
  approach and retract around it are ordinary travel.
* Process parameters (current, voltage, wire feed speed, job) are restated wherever the
  (section, zone) of arc-on segments changes.
* A motion ends in an exact stop (`stop=True`) when an arc switch or dwell follows it, and at the
  end of the program; all other motions may be blended.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Union

import numpy as np

from ..core.errors import PlanningError
from ..core.moves import TRAVEL, Moves
from .arcfit import fit_arcs


@dataclass(frozen=True)
class PlanSettings:
    """ignition_dwell: s, default dwell after arc ON when the zone has no `dwell` parameter.
    arc_tolerance: mm, > 0 enables arc fitting (circular motions within this tolerance).
    arc_plane_normal: restrict fitted arcs to planes normal to this axis at constant height
    (G-code G17 arcs: (0, 0, 1)); None allows any plane (robot CIRC).
    travel_speed: mm/s, used for arc-off travel on robots and for the time estimate.
    """

    ignition_dwell: float = 0.5
    arc_tolerance: float = 0.0
    arc_plane_normal: tuple[float, float, float] | None = None
    travel_speed: float = 100.0


@dataclass(frozen=True)
class Motion:
    """A motion to point `end` (index into Moves.points) from point `start` (-1: from wherever
    the machine is). mode: "travel" | "move" | "weld". speed: mm/s (NaN for travel).
    via ≥ 0: circular motion through points[via] (center (3,), normal (3,) unit: the arc runs
    counter-clockwise about it). stop: exact stop at the end."""

    mode: str
    start: int
    end: int
    speed: float
    layer: int
    section: int
    zone: int
    via: int = -1
    center: tuple[float, float, float] | None = None
    normal: tuple[float, float, float] | None = None
    stop: bool = False

    @property
    def circular(self) -> bool:
        return self.via >= 0

    def arc_geometry(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """(center, normal) of a circular motion; ValueError naming the motion when it has none."""
        if self.center is None or self.normal is None:
            raise ValueError(
                f"motion to point {self.end} (layer {self.layer}) is not a circular motion with a centre and a normal"
            )
        return self.center, self.normal


@dataclass(frozen=True)
class LayerStart:
    layer: int
    z: float


@dataclass(frozen=True)
class SectionStart:
    section: int
    key: str


@dataclass(frozen=True)
class ProcessChange:
    """Process parameters for the arc-on segments that follow (names from core/process.py)."""

    section: int
    zone: int
    zone_id: str
    params: dict = field(default_factory=dict)


@dataclass(frozen=True)
class ArcOn:
    point: int
    section: int
    zone: int


@dataclass(frozen=True)
class ArcOff:
    point: int


@dataclass(frozen=True)
class Dwell:
    """Wait at `point` for `seconds`. reason: "ignition" | "zone" | "interlayer". note: why
    (interlayer dwells set by a rule, e.g. interpass control), "" when nothing more to say."""

    point: int
    seconds: float
    reason: str
    note: str = ""


@dataclass(frozen=True)
class ToolOn:
    """Engage a post-deposition tool (rolling, peening) at `point` for the contact motions that
    follow. params: the section's `tool_params` (force_n, tool_width_mm, speed_mm_s, ...)."""

    point: int
    section: int
    tool: str
    params: dict = field(default_factory=dict)


@dataclass(frozen=True)
class ToolOff:
    """Lift the tool at `point` (end of a contact run)."""

    point: int
    tool: str


Step = Union[Motion, LayerStart, SectionStart, ProcessChange, ArcOn, ArcOff, Dwell, ToolOn, ToolOff]


@dataclass(frozen=True, eq=False)
class Plan:
    moves: Moves
    steps: tuple[Step, ...]
    stats: dict

    @property
    def motions(self) -> list[Motion]:
        return [s for s in self.steps if isinstance(s, Motion)]


def ignition_dwell_after(steps, k: int) -> float:
    """Seconds of the ignition dwell that follows step k (an ArcOn), 0 when none follows."""
    nxt = steps[k + 1] if k + 1 < len(steps) else None
    return nxt.seconds if isinstance(nxt, Dwell) and nxt.reason == "ignition" else 0.0


@dataclass(frozen=True)
class StepChunk:
    """One controller program's share of a plan: `steps` (indices into `Plan.steps`, in order),
    the `layer` it belongs to (the latest LayerStart at its start; None before any) and `part`:
    0 for a layer's first program, 1, 2, .. for the next ones when the layer is cut."""

    layer: int | None
    part: int
    steps: tuple[int, ...]


def chunk_steps(
    steps, *, per_layer: bool = True, max_points: int = 0, distinct: bool = False, cut_back: bool = False
) -> list[StepChunk]:
    """Split a plan's steps into controller programs (the one chunker of the robot writers).

    per_layer: a new program at every LayerStart once the current one has a motion. max_points
    (0 = no limit): how many positions a program holds — motions, or with `distinct` the distinct
    points its motions go to (a job that declares each point once). Where a full program ends:
    by default right after the motion that fills it when the arc is off there, else at the first
    motion after the arc goes off (INFORM, TP: no program switch while welding); `cut_back`:
    before the motion that would overfill it, back at the latest arc OFF that leaves it at least
    half full, else right after its last motion (KRL, see `_cut_back`)."""
    groups: list[list] = []  # [layer, part, step indices]
    layer: int | None = None
    count = 0
    seen: set[int] = set()
    arc = False
    for k, st in enumerate(steps):
        if isinstance(st, LayerStart):
            layer = st.layer
            if groups and not groups[-1][2]:
                groups[-1][:2] = [layer, 0]
            elif per_layer and groups and any(isinstance(steps[j], Motion) for j in groups[-1][2]):
                groups.append([layer, 0, []])
                count, seen = 0, set()
        if not groups:
            groups.append([layer, 0, []])
        if cut_back and max_points and isinstance(st, Motion) and count >= max_points:
            cur = groups[-1][2]
            j = _cut_back(steps, cur, max_points)
            tail = cur[j:]
            del cur[j:]
            groups.append([groups[-1][0], groups[-1][1] + 1, tail])
            count = sum(isinstance(steps[i], Motion) for i in tail)
        groups[-1][2].append(k)
        if isinstance(st, ArcOn):
            arc = True
        elif isinstance(st, ArcOff):
            arc = False
        elif isinstance(st, Motion):
            if not distinct or st.end not in seen:
                seen.add(st.end)
                count += 1
            if max_points and not cut_back and count >= max_points and not arc:
                groups.append([layer, groups[-1][1] + 1, []])
                count, seen = 0, set()
    return [StepChunk(lay, part, tuple(g)) for lay, part, g in groups if g]


def _cut_back(steps, cur: list[int], limit: int) -> int:
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


def _mode(moves: Moves, i: int) -> str:
    if moves.arc[i]:
        return "weld"
    if moves.kind[i] == TRAVEL or not np.isfinite(moves.speed[i]) or moves.speed[i] <= 0:
        return "travel"
    return "move"


def _check_weld_speeds(moves: Moves) -> None:
    """Every arc-on segment needs a positive programmed speed (the feed of the program)."""
    bad = np.flatnonzero(moves.arc & ~(np.isfinite(moves.speed) & (moves.speed > 0)))
    if len(bad):
        i = int(bad[0])
        raise PlanningError(
            f"arc-on segment {i} has no positive travel speed ({moves.speed[i]}); "
            "set travel_speed in the zone parameters",
            layer=int(moves.layer[i]),
            section=moves.section_keys[int(moves.section[i])],
        )


def _segment_key(moves: Moves, i: int) -> tuple:
    sp = float(moves.speed[i])
    return (
        _mode(moves, i),
        sp if np.isfinite(sp) else None,
        int(moves.zone[i]),
        int(moves.section[i]),
        int(moves.layer[i]),
    )


def _groups(moves: Moves) -> list[tuple[int, int]]:
    """Maximal segment ranges [a, b) with equal attributes (`_segment_key`) and no dwell at
    interior points; all segments compared at once (a program has ~10⁵ of them)."""
    n_seg = len(moves.points) - 1
    if n_seg <= 0:
        return []
    speed = np.asarray(moves.speed[:n_seg], float)
    finite = np.isfinite(speed)
    arc = np.asarray(moves.arc[:n_seg], bool)
    travel = (np.asarray(moves.kind[:n_seg]) == TRAVEL) | ~finite | ~(speed > 0)
    mode = np.where(arc, 0, np.where(travel, 1, 2))  # weld, travel, move
    same_speed = np.where(finite[1:] & finite[:-1], speed[1:] == speed[:-1], ~finite[1:] & ~finite[:-1])
    cut = ~same_speed | (mode[1:] != mode[:-1])
    for attr in (moves.zone, moves.section, moves.layer):
        a = np.asarray(attr[:n_seg])
        cut |= a[1:] != a[:-1]
    cut |= np.asarray(moves.dwell_before[1:n_seg]) > 0
    bounds = [0, *(np.flatnonzero(cut) + 1).tolist(), n_seg]
    return list(zip(bounds[:-1], bounds[1:]))


def _group_motions(moves: Moves, a: int, b: int, settings: PlanSettings) -> list[Motion]:
    mode, _, zone, section, layer = _segment_key(moves, a)
    speed = float(moves.speed[a]) if mode != "travel" else float("nan")
    base = dict(mode=mode, speed=speed, layer=layer, section=section, zone=zone)
    arcs = []
    if mode != "travel" and settings.arc_tolerance > 0:
        arcs = fit_arcs(moves.points[a : b + 1], settings.arc_tolerance, plane_normal=settings.arc_plane_normal)
    out: list[Motion] = []
    i = a
    for arc in arcs:
        s, e = a + arc.start, a + arc.end
        out.extend(_straight_motions(base, i, s))
        out.append(Motion(start=s, end=e, via=a + arc.via, center=_vec3(arc.center), normal=_vec3(arc.normal), **base))
        i = e
    out.extend(_straight_motions(base, i, b))
    return out


def _straight_motions(base: dict, i: int, j: int) -> list[Motion]:
    """Motion(start=k, end=k + 1, **base) for k in range(i, j), filled in directly: a frozen
    dataclass's __init__ sets its 11 fields one `object.__setattr__` at a time (0.15-0.2 s of the
    bench vase's 68,000 motions); the same objects (fields in the same order, equality, hash,
    pickles)."""
    template = vars(Motion(start=i, end=i + 1, **base))  # every field, in order, defaults included
    out = []
    for k in range(i, j):
        m = object.__new__(Motion)
        d = m.__dict__
        d.update(template)
        d["start"], d["end"] = k, k + 1
        out.append(m)
    return out


def _vec3(v: np.ndarray) -> tuple[float, float, float]:
    """A (3,) array as a tuple of three floats."""
    x, y, z = (float(c) for c in v)
    return (x, y, z)


def _ignition_dwell(moves: Moves, section: int, zone: int, settings: PlanSettings) -> float:
    params = moves.zone_params.get((section, zone), {})
    return float(params.get("dwell", settings.ignition_dwell))


def plan_program(moves: Moves, settings: PlanSettings = PlanSettings()) -> Plan:
    """Build the `Plan` of a flat move list (see module doc for the rules)."""
    steps: list[Step] = []
    n = len(moves.points)
    if n == 0:
        return Plan(moves, (), _stats(moves, [], settings))
    _check_weld_speeds(moves)
    layer0 = int(moves.layer[0]) if n > 1 else 0
    sec0 = int(moves.section[0]) if n > 1 else 0
    steps.append(LayerStart(layer0, float(moves.layer_z.get(layer0, moves.points[0, 2]))))
    if moves.section_keys:
        steps.append(SectionStart(sec0, moves.section_keys[sec0]))
    steps.append(Motion("travel", -1, 0, float("nan"), layer0, sec0, -1))
    arc_on = False
    tool_on: str | None = None
    cur_layer, cur_section, cur_process = layer0, sec0, None
    for a, b in _groups(moves) if n > 1 else []:
        mode, _, zone, section, layer = _segment_key(moves, a)
        if arc_on and mode != "weld":
            steps.append(ArcOff(a))
            arc_on = False
        contact = mode == "move" and section in moves.section_tools
        if tool_on is not None and (not contact or section != cur_section):
            steps.append(ToolOff(a, tool_on))
            tool_on = None
        if layer != cur_layer:
            steps.append(LayerStart(layer, float(moves.layer_z.get(layer, moves.points[a, 2]))))
            cur_layer = layer
        if section != cur_section:
            steps.append(SectionStart(section, moves.section_keys[section]))
            cur_section = section
        if moves.dwell_before[a] > 0:
            steps.append(Dwell(a, float(moves.dwell_before[a]), "interlayer", moves.dwell_notes.get(a, "")))
        if contact and tool_on is None:
            tool, tparams = moves.section_tools[section]
            steps.append(ToolOn(a, section, tool, dict(tparams)))
            tool_on = tool
        if mode == "weld":
            new_zone = (section, zone) != cur_process
            if new_zone:
                zid = moves.zone_ids[zone] if 0 <= zone < len(moves.zone_ids) else ""
                steps.append(ProcessChange(section, zone, zid, dict(moves.zone_params.get((section, zone), {}))))
                cur_process = (section, zone)
            if not arc_on:
                steps.append(ArcOn(a, section, zone))
                steps.append(Dwell(a, _ignition_dwell(moves, section, zone, settings), "ignition"))
                arc_on = True
            elif new_zone:
                d = float(moves.zone_params.get((section, zone), {}).get("dwell", 0.0))
                if d > 0:
                    steps.append(Dwell(a, d, "zone"))
        steps.extend(_group_motions(moves, a, b, settings))
    if arc_on:
        steps.append(ArcOff(n - 1))
    if tool_on is not None:
        steps.append(ToolOff(n - 1, tool_on))
    steps = _mark_stops(steps)
    return Plan(moves, tuple(steps), _stats(moves, steps, settings))


def _mark_stops(steps: list[Step]) -> list[Step]:
    out = list(steps)
    pending_stop = True  # the last motion of the program stops
    for k in range(len(out) - 1, -1, -1):
        s = out[k]
        if isinstance(s, Motion):
            if pending_stop:
                out[k] = replace(s, stop=True)
            pending_stop = False
        elif isinstance(s, (ArcOn, ArcOff, Dwell, ToolOn, ToolOff)):
            pending_stop = True
    return out


def _stats(moves: Moves, steps: list[Step], settings: PlanSettings) -> dict:
    seg = moves.segment_lengths if len(moves.points) > 1 else np.zeros(0)
    arc = moves.arc.astype(bool) if len(seg) else np.zeros(0, bool)
    speed = (
        np.where(np.isfinite(moves.speed) & (moves.speed > 0), moves.speed, settings.travel_speed)
        if len(seg)
        else np.zeros(0)
    )
    dwell = sum(s.seconds for s in steps if isinstance(s, Dwell))
    return {
        "layers": len(set(moves.layer.tolist())) if len(seg) else 0,
        "sections": len(moves.section_keys),
        "points": int(len(moves.points)),
        "motions": sum(1 for s in steps if isinstance(s, Motion)),
        "circular_motions": sum(1 for s in steps if isinstance(s, Motion) and s.circular),
        "arc_on_count": sum(1 for s in steps if isinstance(s, ArcOn)),
        "tool_on_count": sum(1 for s in steps if isinstance(s, ToolOn)),
        "deposition_length_mm": round(float(seg[arc].sum()), 3),
        "travel_length_mm": round(float(seg[~arc].sum()), 3),
        "dwell_total_s": round(float(dwell), 3),
        "estimated_time_s": round(float((seg / speed).sum() + dwell), 3) if len(seg) else 0.0,
        "max_tool_tilt_deg": _max_tilt(moves),
    }


def _max_tilt(moves: Moves) -> float:
    """Largest angle (degrees) between a tool axis and the vertical (0, 0, -1): 3-axis G-code
    cannot tilt the torch, so the G-code post warns when this is not ~0."""
    if len(moves.tool_axis) == 0:
        return 0.0
    t = moves.tool_axis / np.linalg.norm(moves.tool_axis, axis=1, keepdims=True)
    return round(float(np.degrees(np.arccos(np.clip(-t[:, 2], -1.0, 1.0))).max()), 3)
