"""ABB RAPID writer: one module (.mod) with ArcWare welding instructions.

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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .common import check_identifier, num, process_summary, short, weld_tag
from .common import TOOL_COMMANDS, check_tool_template, tool_lines, tool_summary
from .orientation import quaternions, tool_frames
from .plan import ArcOff, ArcOn, Dwell, LayerStart, Motion, Plan, ProcessChange, SectionStart, ToolOff, ToolOn


@dataclass(frozen=True, eq=False)
class RapidSettings:
    """program_name: MODULE name (≤ 32 characters). tool / wobj: names of the tooldata and
    wobjdata declared on the controller. blend_distance: mm, zonedata radius (0 = fine
    everywhere). travel_speed: mm/s for arc-off travel. reorientation_speed: deg/s (speeddata
    v_ori). tool_direction: "z" (ABB) or "x". external_axes: (n, k ≤ 6) per point, or None.
    positioner_unit: mechanical unit of the positioner (e.g. "STN1"); with external axes the
    module declares a coordinated work object (see `coordinated_wobj`) on it and brackets the
    motion with ActUnit/DeactUnit. work_frame: the part origin in the positioner flange frame
    (x, y, z mm, q1..q4), the oframe of that work object."""

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
    tool_on: str = TOOL_COMMANDS["rapid"][0]   # post-deposition tool (rolling, peening): common.py
    tool_off: str = TOOL_COMMANDS["rapid"][1]

    def __post_init__(self) -> None:
        check_tool_template(self.tool_on, "tool_on")
        check_tool_template(self.tool_off, "tool_off")
        check_identifier(self.program_name, 32)
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
    return (f"PERS wobjdata {s.wobj_name} := [FALSE,FALSE,\"{s.positioner_unit}\",[[0,0,0],[1,0,0,0]],"
            f"[[{num(x, 3)},{num(y, 3)},{num(z, 3)}],[{qs}]]];")


# Where each zone weld value goes: the welddata's main_arc (and the seamdata's ign_arc) arcdata.
RAPID_WELD_FIELDS = {"current": "welddata.main_arc.current", "voltage": "welddata.main_arc.voltage",
                     "wire_feed_speed": "welddata.main_arc.wirefeed", "job": "welddata.main_arc.sched"}


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
    return (f"CONST robtarget p{i + 1} := [[{num(p[0], d)},{num(p[1], d)},{num(p[2], d)}],"
            f"[{num(q[0], 6)},{num(q[1], 6)},{num(q[2], 6)},{num(q[3], 6)}],[0,0,0,0],[{','.join(e)}]];")


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


def write_rapid(plan: Plan, settings: RapidSettings = RapidSettings()) -> str:
    """Render a `Plan` as a RAPID module (see module doc)."""
    s = settings
    d = s.decimals
    pts = plan.moves.points
    steps = plan.steps
    keys = plan.moves.section_keys
    ext = None if s.external_axes is None else np.asarray(s.external_axes, dtype=float).reshape(len(pts), -1)
    if ext is not None and ext.shape[1] > 6:
        raise ValueError("at most 6 external axes")
    quat = quaternions(tool_frames(plan.moves.tool_axis, s.tool_direction)) if len(pts) else np.zeros((0, 4))
    speeds, seams, welds = _Names("vw"), _Names("sm"), _Names("wd")
    zone = "fine" if s.blend_distance <= 0 else "zw"
    tool = f"{s.tool}\\WObj:={s.wobj_name}"

    def speed(v: float) -> str:
        v = round(float(v), 3)
        return speeds.get((v,), lambda n: f"CONST speeddata {n} := [{short(v)},{short(s.reorientation_speed)},5000,1000]; ! {short(v)} mm/s")

    def weld(params: dict, v: float) -> str:
        arc = _arcdata(params)
        v = round(float(v), 3)
        return welds.get((arc, v), lambda n: f"PERS welddata {n} := [{short(v)},0,{arc},[0,0,0,0,0,0,0,0,0]]; ! {process_summary(params)}")

    def seamdata(params: dict, dwell: float) -> str:
        arc = _arcdata(params)
        dwell = round(float(dwell), 3)
        zero = "[0,0,0,0,0,0,0,0,0]"
        return seams.get((arc, dwell), lambda n: f"PERS seamdata {n} := [0,0,{arc},{short(dwell)},0,0,0,0,{zero},0,0,{zero},0,0,{zero},0]; ! ignition dwell {short(dwell)} s")

    body: list[str] = []
    used: list[int] = []
    params: dict = {}
    seam = ""
    held: Motion | None = None      # arc-off motion waiting to know whether it starts a run
    ignite_at: int | None = None    # point reached with MoveL fine + dwell, to ignite in place

    def motion_line(m: Motion, z: str) -> str:
        used.append(m.end)
        v = speed(s.travel_speed if m.mode == "travel" else m.speed)
        if m.circular:
            used.append(m.via)
            return f"MoveC p{m.via + 1}, p{m.end + 1}, {v}, {z}, {tool};"
        return f"MoveL p{m.end + 1}, {v}, {z}, {tool};"

    def flush() -> None:
        nonlocal held
        if held is not None:
            body.append(motion_line(held, "fine" if held.stop else zone))
            held = None

    for k, st in enumerate(steps):
        if isinstance(st, LayerStart):
            body.append(f"! layer {st.layer} z={num(st.z, d)}")
        elif isinstance(st, SectionStart):
            body.append(f"! section {keys[st.section]}")
        elif isinstance(st, ProcessChange):
            params = st.params
            desc = process_summary(params)
            body.append(f"! zone {st.zone_id or '-'}" + (f": {desc}" if desc else ""))
        elif isinstance(st, ArcOn):
            ign = steps[k + 1].seconds if k + 1 < len(steps) and isinstance(steps[k + 1], Dwell) else 0.0
            first = _next_motion(steps, k)
            seam = seamdata(params, ign)
            wd = weld(params, first.speed if first is not None else s.travel_speed)
            if held is not None:
                m, held = held, None
                used.append(m.end)
                v = speed(s.travel_speed if m.mode == "travel" else m.speed)
                body.append(f"ArcLStart p{m.end + 1}, {v}, {seam}, {wd}, fine, {tool};")
            else:
                target = ignite_at if ignite_at is not None else st.point
                used.append(target)
                body.append(f"ArcLStart p{target + 1}, {speed(s.travel_speed)}, {seam}, {wd}, fine, {tool}; ! ignite in place")
            ignite_at = None
        elif isinstance(st, Dwell):
            if st.reason == "ignition":
                body.append(f"! ignition dwell {short(round(st.seconds, 3))} s (seamdata ign_move_delay)")
                continue
            if held is not None:
                ignite_at = held.end
                flush()
            body.append(f"WaitTime\\InPos, {short(round(st.seconds, 3))}; ! {st.reason} dwell" + (f" ({st.note})" if st.note else ""))
        elif isinstance(st, (ToolOn, ToolOff)):   # after the (fine) motion to the point
            flush()
            on = isinstance(st, ToolOn)
            tl = tool_lines(s.tool_on if on else s.tool_off, st.tool, st.params if on else {})
            body += tl[:-1] + [f"{tl[-1]} ! {tool_summary(st.tool, st.params) if on else st.tool + ' off'}"]
        elif isinstance(st, ArcOff):
            body.append("! arc off")
        elif isinstance(st, Motion):
            flush()
            ignite_at = None
            if st.mode != "weld":
                held = st
                continue
            used.append(st.end)
            v = speed(st.speed)
            wd = weld(params, st.speed)
            end = isinstance(_next_significant(steps, k), ArcOff)
            z = "fine" if (end or st.stop) else zone
            if st.circular:
                used.append(st.via)
                body.append(f"{'ArcCEnd' if end else 'ArcC'} p{st.via + 1}, p{st.end + 1}, {v}, {seam}, {wd}, {z}, {tool};")
            else:
                body.append(f"{'ArcLEnd' if end else 'ArcL'} p{st.end + 1}, {v}, {seam}, {wd}, {z}, {tool};")
    flush()

    st_ = plan.stats
    bd = float(s.blend_distance)
    out = [
        f"MODULE {s.program_name}",
        f"  ! waamflow ABB RAPID program {s.program_name} (ArcWare)",
        f"  ! layers {st_['layers']}, sections {st_['sections']}, points {st_['points']}, motions {st_['motions']}",
        f"  ! deposition {st_['deposition_length_mm']:.3f} mm, travel {st_['travel_length_mm']:.3f} mm, "
        f"arc-on count {st_['arc_on_count']}, dwell {st_['dwell_total_s']:.3f} s",
        f"  ! units: mm, mm/s, s; tool {s.tool}, work object {s.wobj_name}, blend zone {short(bd)} mm",
        "  ! welddata = [weld_speed, org_weld_speed, main_arc, org_arc]; "
        "arcdata = [sched(job), mode, voltage V, wirefeed m/min, control, current A, voltage2, wirefeed2, control2]",
        "  ! " + weld_tag(RAPID_WELD_FIELDS),
    ]
    if ext is not None:
        out.append(f"  ! external axes eax_a..eax_{'abcdef'[ext.shape[1] - 1]} (deg / mm) in every robtarget"
                   + (f", positioner {s.positioner_unit}, coordinated work object {s.wobj_name}" if s.coordinated else ""))
    if s.coordinated:
        out.append("  " + coordinated_wobj(s))
    if bd > 0:
        out.append(f"  CONST zonedata zw := [FALSE,{short(bd)},{short(1.5 * bd)},{short(1.5 * bd)},"
                   f"{short(0.15 * bd)},{short(1.5 * bd)},{short(0.15 * bd)}];")
    out += ["  " + x for x in speeds.decls() + seams.decls() + welds.decls()]
    out += ["  " + _robtarget(i, pts, quat, ext, d) for i in sorted(set(used))]
    out += ["  PROC main()", "    ConfL\\Off;"]
    if s.coordinated:
        out.append(f"    ActUnit {s.positioner_unit};")
    out += ["    " + x for x in body]
    if s.coordinated:
        out.append(f"    DeactUnit {s.positioner_unit};")
    out += ["  ENDPROC", "ENDMODULE"]
    return "\n".join(out) + "\n"
