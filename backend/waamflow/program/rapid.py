"""ABB RAPID writer: one module (.mod) with ArcWare welding instructions, or, above
`max_module_bytes`, a main module and part modules (see "Controller-sized programs" below).

Module shape::

    MODULE name
      CONST speeddata vw1 := [v_tcp, 500, 5000, 1000];   ! one per distinct speed (mm/s)
      CONST zonedata zw := [FALSE, d, 1.5d, 1.5d, 0.15d, 1.5d, 0.15d];  ! blend distance d (mm)
      PERS seamdata sm1 := [...];  ! one per distinct ignition dwell (ign_move_delay)
      PERS welddata wd1 := [...];  ! one per distinct zone parameters + weld speed
      CONST robtarget p1 := [[x,y,z],[q1,q2,q3,q4],[0,0,0,0],[eax...]];
      PROC main()
        ConfL\\Off;
        MoveL p1, vw1, zw, tool\\WObj:=wobj;            ! arc-off travel (fine before a stop)
        ArcLStart p9, vw1, sm1, wd1, fine, tool\\WObj:=wobj;   ! move to the run start, ignite
        ArcL p10, vw2, sm1, wd2, zw, tool\\WObj:=wobj;  ! welding (ArcC for fitted arcs)
        ArcLEnd p20, vw2, sm1, wd3, fine, tool\\WObj:=wobj;    ! last welding motion, arc off
        WaitTime\\InPos, 20;                              ! interlayer / zone dwell
      ENDPROC
    ENDMODULE

Rules: ArcLStart is the motion into a run's first point (the arc ignites there; the ignition dwell
is the seamdata's `ign_move_delay`). When an interlayer dwell falls on that point, the robot goes
there with MoveL … fine, waits, and ArcLStart then targets the same point (one extra, zero-length
motion). The last welding motion of a run is ArcLEnd … fine (ArcCEnd for an arc). Weld speed:
welddata `weld_speed` = the segment's programmed speed (mm/s), and the speeddata says the same.

Data layouts (IRC5 ArcWare; the component list of seamdata/welddata depends on the ArcWare
system parameters — check against the controller's configuration before running):
welddata = [weld_speed, org_weld_speed, main_arc, org_arc];
arcdata = [sched, mode, voltage, wirefeed, control, current, voltage2, wirefeed2, control2]
with sched = the zone's `job`, voltage V, wirefeed m/min, current A;
seamdata = [purge_time, preflow_time, ign_arc, ign_move_delay, scrape_start, heat_speed,
heat_time, heat_distance, heat_arc, cool_time, fill_time, fill_arc, bback_time, rback_time,
bback_arc, postflow_time] with ign_arc = the first zone's arcdata, ign_move_delay = dwell (s).
robtarget orientation: quaternion from the tool axis (orientation.py, tool z along the axis).

Controller-sized programs (`write_rapid_modules`): an IRC5 loads a whole program into its
program memory, and a large module takes long to load, so a program above `max_module_bytes`
(the abb_irc5 profile: 512 kB) is written as a main module `<name>.mod` and part modules
`<name>_M001.mod`, ... (module name = file stem), each a layer range (cut at layer starts with
the arc off) with its data declared LOCAL and one routine `<name>_M001`. `main()` loads them one
after the other as ABB documents for programs larger than memory (RAPID Instructions, StartLoad /
WaitLoad / UnLoad; Technical reference manual - RAPID overview, late binding)::

    StartLoad \\Dynamic, post_dir \\File:="post_M001.mod", post_load;   WaitLoad post_load;
    StartLoad \\Dynamic, post_dir \\File:="post_M002.mod", post_load;   ! loads while M001 runs
    %"post_M001"%;   UnLoad post_dir \\File:="post_M001.mod";   WaitLoad post_load;   ...

with `post_dir` = `module_dir` (default "HOME:", as in ABB's StartLoad example): copy every .mod file into that folder and load
only `<name>.mod` into the task; at most two part modules are in program memory at a time.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from .common import check_identifier, num, process_summary, short, weld_tag
from .common import TOOL_COMMANDS, check_tool_template, tool_lines, tool_summary
from .orientation import quaternions, tool_frames
from .plan import ArcOff, ArcOn, Dwell, LayerStart, Motion, Plan, ProcessChange, SectionStart, Step, ToolOff, ToolOn


MIN_MODULE_BYTES = 16_384


@dataclass(frozen=True, eq=False)
class RapidSettings:
    """program_name: MODULE name (≤ 32 characters). tool / wobj: names of the tooldata and
    wobjdata declared on the controller. blend_distance: mm, zonedata radius (0 = fine
    everywhere). travel_speed: mm/s for arc-off travel. reorientation_speed: deg/s (speeddata
    v_ori). tool_direction: "z" (ABB) or "x". external_axes: (n, k ≤ 6) per point, or None.
    positioner_unit: mechanical unit of the positioner (e.g. "STN1"); with external axes the
    module declares a coordinated work object (see `coordinated_wobj`) on it and brackets the
    motion with ActUnit/DeactUnit. work_frame: the part origin in the positioner flange frame
    (x, y, z mm, q1..q4), the oframe of that work object. max_module_bytes: most bytes per
    module file (0 = no limit; name then ≤ 27 characters for the `_M001` parts); module_dir:
    the controller folder main() loads the part modules from."""

    program_name: str = "waamflow"
    tool: str = "tWeldGun"
    wobj: str = "wobj0"
    blend_distance: float = 1.0
    travel_speed: float = 100.0
    reorientation_speed: float = 500.0
    tool_direction: str = "z"
    external_axes: np.ndarray | None = None
    positioner_unit: str = "STN1"
    work_frame: tuple[float, ...] = (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
    decimals: int = 3
    max_module_bytes: int = 0  # 0 = one module whatever its size; else split (write_rapid_modules)
    module_dir: str = "HOME:"  # where main() loads the part modules from (the controller's file system)
    tool_on: str = TOOL_COMMANDS["rapid"][0]  # post-deposition tool (rolling, peening): common.py
    tool_off: str = TOOL_COMMANDS["rapid"][1]

    def __post_init__(self) -> None:
        check_tool_template(self.tool_on, "tool_on")
        check_tool_template(self.tool_off, "tool_off")
        check_identifier(self.program_name, 27 if self.max_module_bytes else 32)
        if self.max_module_bytes and self.max_module_bytes < MIN_MODULE_BYTES:
            raise ValueError(f"max_module_bytes must be 0 (no limit) or at least {MIN_MODULE_BYTES}")
        if not self.module_dir or any(c in self.module_dir for c in '"\\\n'):
            raise ValueError(f"module_dir {self.module_dir!r}: a controller path without quotes or backslashes")
        check_identifier(self.tool, 32, "tool name")
        check_identifier(self.wobj, 32, "work object name")
        if self.positioner_unit:
            check_identifier(self.positioner_unit, 32, "positioner mechanical unit")
        if len(self.work_frame) != 7:
            raise ValueError("work_frame must be (x, y, z, q1, q2, q3, q4)")

    @property
    def coordinated(self) -> bool:
        """Motion coordinated with the positioner: external axes and a mechanical unit given."""
        return self.external_axes is not None and bool(self.positioner_unit)

    @property
    def wobj_name(self) -> str:
        """The work object the motions use: `wobj`, or for coordinated motion (where the fixed
        wobj0 cannot serve) `wobj_<unit>` unless another name was given."""
        if self.coordinated and self.wobj == "wobj0":
            return f"wobj_{self.positioner_unit}"[:32]
        return self.wobj


def coordinated_wobj(s: RapidSettings) -> str:
    """wobjdata of a work object moved by the positioner: robhold FALSE (the robot does not hold
    it), ufprog FALSE (movable user frame, its uframe set by the system from the positioner's
    axes), ufmec = the positioner's mechanical unit, oframe = the part origin on the flange."""
    x, y, z, *q = s.work_frame
    qs = ",".join(num(v, 6) for v in q)
    return (
        f'PERS wobjdata {s.wobj_name} := [FALSE,FALSE,"{s.positioner_unit}",[[0,0,0],[1,0,0,0]],'
        f"[[{num(x, 3)},{num(y, 3)},{num(z, 3)}],[{qs}]]];"
    )


# Where each zone weld value goes: the welddata's main_arc (and the seamdata's ign_arc) arcdata.
RAPID_WELD_FIELDS = {
    "current": "welddata.main_arc.current",
    "voltage": "welddata.main_arc.voltage",
    "wire_feed_speed": "welddata.main_arc.wirefeed",
    "job": "welddata.main_arc.sched",
}


def _arcdata(params: dict) -> str:
    job = int(round(params.get("job", 0)))
    v = params.get("voltage", 0.0)
    wfs = params.get("wire_feed_speed", 0.0)
    cur = params.get("current", 0.0)
    return f"[{job},0,{short(v)},{short(wfs)},0,{short(cur)},0,0,0]"


def _robtarget(i: int, pts, quat, ext, d: int) -> str:
    p, q = pts[i], quat[i]
    e = ["9E9"] * 6
    if ext is not None:
        e[: ext.shape[1]] = [num(v, d) for v in ext[i]]
    return (
        f"CONST robtarget p{i + 1} := [[{num(p[0], d)},{num(p[1], d)},{num(p[2], d)}],"
        f"[{num(q[0], 6)},{num(q[1], 6)},{num(q[2], 6)},{num(q[3], 6)}],[0,0,0,0],[{','.join(e)}]];"
    )


class _Names:
    """Distinct data declarations, numbered in order of first use."""

    def __init__(self, prefix: str):
        self.prefix = prefix
        self.items: dict[tuple, tuple[str, str]] = {}

    def get(self, key: tuple, decl) -> str:
        if key not in self.items:
            name = f"{self.prefix}{len(self.items) + 1}"
            self.items[key] = (name, decl(name))
        return self.items[key][0]

    def decls(self) -> list[str]:
        return [d for _, d in self.items.values()]


def _next_significant(steps, k: int):
    """The next step after k that is not a marker/process comment (for look-ahead)."""
    for j in range(k + 1, len(steps)):
        if not isinstance(steps[j], (LayerStart, SectionStart, ProcessChange)):
            return steps[j]
    return None


def _next_motion(steps, k: int) -> Motion | None:
    for j in range(k + 1, len(steps)):
        if isinstance(steps[j], Motion):
            return steps[j]
    return None


class _Body:
    """The motion routine's lines of a plan, step by step (see module doc): speed, seam and weld
    data numbered in order of first use, the points the lines use, and an arc-off motion held
    back until it is known whether it starts a run (then it is the ArcLStart)."""

    def __init__(self, plan: Plan, s: RapidSettings) -> None:
        self.s = s
        self.d = s.decimals
        self.steps = plan.steps
        self.keys = plan.moves.section_keys
        self.speeds, self.seams, self.welds = _Names("vw"), _Names("sm"), _Names("wd")
        self.zone = "fine" if s.blend_distance <= 0 else "zw"
        self.tool = f"{s.tool}\\WObj:={s.wobj_name}"
        self.lines: list[str] = []
        self.used: list[int] = []
        self.params: dict = {}
        self.seam = ""
        self.held: Motion | None = None  # arc-off motion waiting to know whether it starts a run
        self.ignite_at: int | None = None  # point reached with MoveL fine + dwell, to ignite in place

    def speed(self, v: float) -> str:
        v = round(float(v), 3)
        return self.speeds.get(
            (v,),
            lambda n: (
                f"CONST speeddata {n} := [{short(v)},{short(self.s.reorientation_speed)},5000,1000]; ! {short(v)} mm/s"
            ),
        )

    def weld(self, params: dict, v: float) -> str:
        arc = _arcdata(params)
        v = round(float(v), 3)
        return self.welds.get(
            (arc, v),
            lambda n: f"PERS welddata {n} := [{short(v)},0,{arc},[0,0,0,0,0,0,0,0,0]]; ! {process_summary(params)}",
        )

    def seamdata(self, params: dict, dwell: float) -> str:
        arc = _arcdata(params)
        dwell = round(float(dwell), 3)
        zero = "[0,0,0,0,0,0,0,0,0]"
        return self.seams.get(
            (arc, dwell),
            lambda n: (
                f"PERS seamdata {n} := [0,0,{arc},{short(dwell)},0,0,0,0,{zero},0,0,{zero},0,0,{zero},0]; ! ignition dwell {short(dwell)} s"
            ),
        )

    def motion_line(self, m: Motion, z: str) -> str:
        self.used.append(m.end)
        v = self.speed(self.s.travel_speed if m.mode == "travel" else m.speed)
        if m.circular:
            self.used.append(m.via)
            return f"MoveC p{m.via + 1}, p{m.end + 1}, {v}, {z}, {self.tool};"
        return f"MoveL p{m.end + 1}, {v}, {z}, {self.tool};"

    def flush(self) -> None:
        if self.held is not None:
            self.lines.append(self.motion_line(self.held, "fine" if self.held.stop else self.zone))
            self.held = None

    def step(self, k: int, st: Step) -> None:
        """The lines of plan step k."""
        if isinstance(st, LayerStart):
            self.lines.append(f"! layer {st.layer} z={num(st.z, self.d)}")
        elif isinstance(st, SectionStart):
            self.lines.append(f"! section {self.keys[st.section]}")
        elif isinstance(st, ProcessChange):
            self.params = st.params
            desc = process_summary(self.params)
            self.lines.append(f"! zone {st.zone_id or '-'}" + (f": {desc}" if desc else ""))
        elif isinstance(st, ArcOn):
            self.arc_on(k, st)
        elif isinstance(st, Dwell):
            self.dwell(st)
        elif isinstance(st, (ToolOn, ToolOff)):  # after the (fine) motion to the point
            self.flush()
            on = isinstance(st, ToolOn)
            tparams = st.params if isinstance(st, ToolOn) else {}
            tl = tool_lines(self.s.tool_on if on else self.s.tool_off, st.tool, tparams)
            self.lines += tl[:-1] + [f"{tl[-1]} ! {tool_summary(st.tool, tparams) if on else st.tool + ' off'}"]
        elif isinstance(st, ArcOff):
            self.lines.append("! arc off")
        elif isinstance(st, Motion):
            self.motion(k, st)

    def arc_on(self, k: int, st: ArcOn) -> None:
        """ArcLStart: the held arc-off motion becomes the start, else the arc ignites in place."""
        steps, s = self.steps, self.s
        nxt = steps[k + 1] if k + 1 < len(steps) else None
        ign = nxt.seconds if isinstance(nxt, Dwell) else 0.0
        first = _next_motion(steps, k)
        self.seam = self.seamdata(self.params, ign)
        wd = self.weld(self.params, first.speed if first is not None else s.travel_speed)
        if self.held is not None:
            m, self.held = self.held, None
            self.used.append(m.end)
            v = self.speed(s.travel_speed if m.mode == "travel" else m.speed)
            self.lines.append(f"ArcLStart p{m.end + 1}, {v}, {self.seam}, {wd}, fine, {self.tool};")
        else:
            target = self.ignite_at if self.ignite_at is not None else st.point
            self.used.append(target)
            self.lines.append(
                f"ArcLStart p{target + 1}, {self.speed(s.travel_speed)}, {self.seam}, {wd}, fine, "
                f"{self.tool}; ! ignite in place"
            )
        self.ignite_at = None

    def dwell(self, st: Dwell) -> None:
        if st.reason == "ignition":
            self.lines.append(f"! ignition dwell {short(round(st.seconds, 3))} s (seamdata ign_move_delay)")
            return
        if self.held is not None:
            self.ignite_at = self.held.end
            self.flush()
        self.lines.append(
            f"WaitTime\\InPos, {short(round(st.seconds, 3))}; ! {st.reason} dwell"
            + (f" ({st.note})" if st.note else "")
        )

    def motion(self, k: int, st: Motion) -> None:
        """A weld motion (ArcL/ArcC, ...End before the arc goes off); an arc-off one is held."""
        self.flush()
        self.ignite_at = None
        if st.mode != "weld":
            self.held = st
            return
        self.used.append(st.end)
        v = self.speed(st.speed)
        wd = self.weld(self.params, st.speed)
        end = isinstance(_next_significant(self.steps, k), ArcOff)
        z = "fine" if (end or st.stop) else self.zone
        tool, seam = self.tool, self.seam
        if st.circular:
            self.used.append(st.via)
            self.lines.append(
                f"{'ArcCEnd' if end else 'ArcC'} p{st.via + 1}, p{st.end + 1}, {v}, {seam}, {wd}, {z}, {tool};"
            )
        else:
            self.lines.append(f"{'ArcLEnd' if end else 'ArcL'} p{st.end + 1}, {v}, {seam}, {wd}, {z}, {tool};")


def _render(plan: Plan, settings: RapidSettings) -> "_Rendered":
    """Render a `Plan` as RAPID lines (see module doc), not yet put into modules."""
    s = settings
    pts = plan.moves.points
    ext = None if s.external_axes is None else np.asarray(s.external_axes, dtype=float).reshape(len(pts), -1)
    if ext is not None and ext.shape[1] > 6:
        raise ValueError("at most 6 external axes")
    quat = quaternions(tool_frames(plan.moves.tool_axis, s.tool_direction)) if len(pts) else np.zeros((0, 4))
    b = _Body(plan, s)
    for k, st in enumerate(plan.steps):
        b.step(k, st)
    b.flush()
    bd = float(s.blend_distance)
    data: dict[str, str] = {}
    if bd > 0:
        data["zw"] = (
            f"CONST zonedata zw := [FALSE,{short(bd)},{short(1.5 * bd)},{short(1.5 * bd)},"
            f"{short(0.15 * bd)},{short(1.5 * bd)},{short(0.15 * bd)}];"
        )
    for names in (b.speeds, b.seams, b.welds):
        data.update({n: decl for n, decl in names.items.values()})
    data.update({f"p{i + 1}": _robtarget(i, pts, quat, ext, s.decimals) for i in sorted(set(b.used))})
    shared = [coordinated_wobj(s)] if s.coordinated else []
    start = ["ConfL\\Off;"] + ([f"ActUnit {s.positioner_unit};"] if s.coordinated else [])
    finish = [f"DeactUnit {s.positioner_unit};"] if s.coordinated else []
    return _Rendered(_head(plan, s, ext), shared, data, b.lines, start, finish)


def _head(plan: Plan, s: RapidSettings, ext: np.ndarray | None) -> list[str]:
    """The header comments: the program's figures, units, data layout and the weld tag."""
    st_ = plan.stats
    bd = float(s.blend_distance)
    head = [
        f"! waamflow ABB RAPID program {s.program_name} (ArcWare)",
        f"! layers {st_['layers']}, sections {st_['sections']}, points {st_['points']}, motions {st_['motions']}",
        f"! deposition {st_['deposition_length_mm']:.3f} mm, travel {st_['travel_length_mm']:.3f} mm, "
        f"arc-on count {st_['arc_on_count']}, dwell {st_['dwell_total_s']:.3f} s",
        f"! units: mm, mm/s, s; tool {s.tool}, tool direction {s.tool_direction.upper()}, work object {s.wobj_name}, "
        f"blend zone {short(bd)} mm",
        "! welddata = [weld_speed, org_weld_speed, main_arc, org_arc]; "
        "arcdata = [sched(job), mode, voltage V, wirefeed m/min, control, current A, voltage2, wirefeed2, control2]",
        *("! " + t for t in weld_tag(RAPID_WELD_FIELDS)),
    ]
    if ext is not None:
        head.append(
            f"! external axes eax_a..eax_{'abcdef'[ext.shape[1] - 1]} (deg / mm) in every robtarget"
            + (f", positioner {s.positioner_unit}, coordinated work object {s.wobj_name}" if s.coordinated else "")
        )
    return head


@dataclass(frozen=True)
class _Rendered:
    """A rendered program before it is cut into modules: header comments, shared declarations
    (the coordinated work object), data name → declaration (in declaration order), the body of
    the motion routine and the lines before / after it."""

    head: list[str]
    shared: list[str]
    data: dict[str, str]
    body: list[str]
    start: list[str]
    end: list[str]


def write_rapid(plan: Plan, settings: RapidSettings = RapidSettings()) -> str:
    """Render a `Plan` as one RAPID module (see module doc), whatever its size."""
    r = _render(plan, settings)
    out = [
        f"MODULE {settings.program_name}",
        *("  " + x for x in r.head + r.shared),
        *("  " + x for x in r.data.values()),
        "  PROC main()",
        *("    " + x for x in r.start + r.body + r.end),
        "  ENDPROC",
        "ENDMODULE",
    ]
    return "\n".join(out) + "\n"


def write_rapid_modules(plan: Plan, settings: RapidSettings = RapidSettings()) -> dict[str, str]:
    """Render a `Plan` as RAPID files: {"mod": the module} when it fits `max_module_bytes` (or
    there is no limit), else {"mod": the main module, "M001.mod": part 1, ...}: the motion
    routine cut into part modules at layer starts where the arc is off (inside a layer too big
    for one module: after an arc end, else between two instructions), each part module at most
    `max_module_bytes - TRACE_RESERVE` bytes (room for the trace lines stamped in later)."""
    s = settings
    whole = write_rapid(plan, s)
    if not s.max_module_bytes or len(whole.encode()) <= s.max_module_bytes - TRACE_RESERVE:
        return {"mod": whole}
    r = _render(plan, s)
    budget = s.max_module_bytes - TRACE_RESERVE
    for _ in range(20):
        groups = _pack(r, budget - _PART_OVERHEAD - 4 * len(s.program_name))
        parts = [_part_module(r, s, k + 1, len(groups), g) for k, g in enumerate(groups)]
        if all(len(t.encode()) <= s.max_module_bytes - TRACE_RESERVE for t in parts):
            break
        budget = int(budget * 0.95)
    else:  # pragma: no cover - defensive
        raise ValueError(f"RAPID: cannot cut the program into modules of at most {s.max_module_bytes} bytes")
    files = {"mod": _main_module(r, s, len(parts))}
    files.update({f"M{k + 1:03d}.mod": t for k, t in enumerate(parts)})
    return files


TRACE_RESERVE = 4096  # bytes kept free in every module for the trace lines (common.stamp_trace)
_PART_OVERHEAD = 400  # MODULE/PROC/ENDPROC/ENDMODULE lines and the part's header comment
_USES = re.compile(r"\b(p\d+|vw\d+|sm\d+|wd\d+|zw)\b")
_LAYER = re.compile(r"^! layer (\d+) ")


def _uses(line: str) -> set[str]:
    return set(_USES.findall(line.split("!", 1)[0]))


def _pack(r: _Rendered, budget: int) -> list[tuple[int, int]]:
    """Body line ranges [a, b) of the part modules: whole layer ranges where they fit, cut at
    layer starts with the arc off; a piece larger than `budget` is cut after arc ends, then
    between instructions. Bytes counted as written (indent, newline, the data each range uses)."""
    body = r.body
    arc = False
    layer_cuts, end_cuts = [0], [0]
    for i, ln in enumerate(body):
        if i and _LAYER.match(ln) and not arc:
            layer_cuts.append(i)
        w = ln.split(" ", 1)[0]
        if w in ("ArcLStart", "ArcCStart"):
            arc = True
        elif w in ("ArcLEnd", "ArcCEnd"):
            arc = False
            end_cuts.append(i + 1)
    cost_line = [len(ln.encode()) + 5 for ln in body]
    uses = [_uses(ln) for ln in body]
    dcost = {n: len(v.encode()) + 9 for n, v in r.data.items()}

    def cost(a: int, b: int) -> int:
        names = set().union(*uses[a:b]) if b > a else set()
        return sum(cost_line[a:b]) + sum(dcost.get(n, 0) for n in names)

    def pieces(a: int, b: int, cuts: list[list[int]]) -> list[tuple[int, int]]:
        if cost(a, b) <= budget or not cuts:
            return [(a, b)]
        inner = sorted({c for c in cuts[0] if a < c < b} | {a, b})
        if len(inner) <= 2:
            return pieces(a, b, cuts[1:])
        out: list[tuple[int, int]] = []
        for x, y in zip(inner, inner[1:]):
            out += pieces(x, y, cuts[1:])
        return out

    every = list(range(len(body) + 1))
    segs = pieces(0, len(body), [layer_cuts, end_cuts, every])
    groups: list[tuple[int, int]] = []
    for a, b in segs:  # greedy: add whole pieces while the module fits
        if groups and cost(groups[-1][0], b) <= budget:
            groups[-1] = (groups[-1][0], b)
        else:
            groups.append((a, b))
    return groups


def _layers_of(lines: list[str]) -> str:
    layers = [int(m.group(1)) for ln in lines if (m := _LAYER.match(ln))]
    if not layers:
        return "no layer start"
    return f"layer {layers[0]}" if layers[0] == layers[-1] else f"layers {layers[0]}-{layers[-1]}"


def part_name(program_name: str, k: int) -> str:
    """Name of part module k (1-based), also its file stem: `<program>_M001`."""
    return f"{program_name}_M{k:03d}"


def _part_module(r: _Rendered, s: RapidSettings, k: int, n: int, rng: tuple[int, int]) -> str:
    name = part_name(s.program_name, k)
    lines = r.body[rng[0] : rng[1]]
    names = set().union(*(_uses(ln) for ln in lines)) if lines else set()
    out = [
        f"MODULE {name}",
        f"  ! part {k} of {n} of RAPID program {s.program_name} ({_layers_of(lines)}), loaded and called by "
        f"{s.program_name}.mod; data LOCAL (two parts are loaded at a time)",
        *(f"  LOCAL {decl}" for nm, decl in r.data.items() if nm in names),
        f"  PROC {name}()",
        *("    " + x for x in lines),
        "  ENDPROC",
        "ENDMODULE",
    ]
    return "\n".join(out) + "\n"


def _main_module(r: _Rendered, s: RapidSettings, n: int) -> str:
    """The main module: `main()` loads the part modules one after the other from `module_dir`
    (ABB: StartLoad\\Dynamic starts loading while the program runs on, WaitLoad links the
    module, a late-bound call %"name"% runs a routine of a module loaded at run time, UnLoad
    frees its memory), so at most two part modules are in program memory at a time."""
    name = s.program_name
    dvar, lvar = f"{name}_dir", f"{name}_load"
    first, last = part_name(name, 1), part_name(name, n)
    body = [f'StartLoad \\Dynamic, {dvar} \\File:="{first}.mod", {lvar};', f"WaitLoad {lvar};"]
    for k in range(1, n + 1):
        part = part_name(name, k)
        if k < n:
            body.append(
                f'StartLoad \\Dynamic, {dvar} \\File:="{part_name(name, k + 1)}.mod", {lvar}; '
                "! the next part loads while this one runs"
            )
        body += [f'%"{part}"%;', f'UnLoad {dvar} \\File:="{part}.mod";']
        if k < n:
            body.append(f"WaitLoad {lvar};")
    out = [
        f"MODULE {name}",
        *("  " + x for x in r.head),
        f"  ! main module: {n} part modules {first}..{last} (files {first}.mod ... {last}.mod, each at most "
        f"{s.max_module_bytes} bytes) in {s.module_dir}; keep them beside {name}.mod and load only this module",
        *("  " + x for x in r.shared),
        f'  CONST string {dvar} := "{s.module_dir}";',
        f"  VAR loadsession {lvar};",
        "  PROC main()",
        *("    " + x for x in r.start + body + r.end),
        "  ENDPROC",
        "ENDMODULE",
    ]
    return "\n".join(out) + "\n"
