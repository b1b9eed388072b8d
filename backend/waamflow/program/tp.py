"""Fanuc TP writer (ASCII `.LS` programs for an R-30iB ArcTool controller).

Program shape (one program per layer, called by the main program, so no program outgrows the
controller's memory; `max_points_per_program` cuts a layer further)::

    /PROG  WAAMFLOW_L003
    /ATTR
    OWNER       = MNEDITOR;
    COMMENT     = "waamflow L3";
    ...                                   ; fixed CREATE/MODIFIED date: the same plan, the same bytes
    LINE_COUNT  = 57;                     ; = the numbered /MN lines
    DEFAULT_GROUP   = 1,*,*,*,*;
    CONTROL_CODE    = 00000000 00000000;
    /APPL
      ARC Welding Equipment : 1,*,*,*,*;
    /MN
       1:  UFRAME_NUM=1 ;
       2:  UTOOL_NUM=1 ;
       3:  ! layer 3 z=4.500 ;
       4:L P[1] 100mm/sec FINE    ;        ; arc-off travel (FINE: exact stop before an ignition)
       5:  Arc Start[2] ;                  ; ignite with weld schedule 2
       6:  WAIT   0.50(sec) ;              ; the ignition dwell
       7:L P[2] 8mm/sec CNT100    ;        ; welding (CNT = `cnt`, 0..100)
       8:  Arc Start[3] ;                  ; a zone change while welding: the next schedule
       9:L P[3] 49cm/min CNT100    ;
      10:  Arc End[3] ;
    /POS
    P[1]{
       GP1:
        UF : 1, UT : 1,     CONFIG : 'N U T, 0, 0, 0',
        X = 12.000 mm, Y = 3.000 mm, Z = 4.500 mm,
        W = 180.000 deg, P = 0.000 deg, R = 0.000 deg
    };
    /END

The weld: TP carries no voltage, current or wire feed inline — ArcTool keeps them in the
controller's weld schedules. The distinct weld-value sets of the zones (voltage, current, wire feed,
job, travel speed) are numbered 1..n as schedules; `Arc Start[k]` ignites with schedule k and, while
welding, switches to it at a zone change; `Arc End[k]` ends the bead. The table is the program's
second file `<NAME>_SCHED.CSV` (SCHEDULE_COLUMNS, plus the zones that use each schedule) and is
repeated as comments in the main program; the schedules must be entered on the controller (the post
says so per schedule). Speeds: `mm/sec` when the speed is a whole number, else `cm/min` (the
controller takes whole numbers; 1 cm/min = 1/6 mm/s). Orientation W, P, R: fixed XYZ angles,
R = Rz(R)·Ry(P)·Rx(W) (KUKA's A, B, C reversed). Comments (`!`) hold at most 32 characters.
Circular motions are not written (the planner gives lines).

A positioner (`external_axes`, E1 tilt / E2 turn in degrees per toolpath point): motion group 2,
`DEFAULT_GROUP = 1,1,*,*,*`, every P[i] with a `GP2: J1 = .. deg, J2 = .. deg` block, and every
motion coordinated (`COORD`, the Coordinated Motion option: the positions are in user frame UF,
the part frame carried by the positioner, as the KRL/RAPID posts write them).
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass

import numpy as np

from ..core.process import PARAMETERS_BY_NAME
from .common import TOOL_COMMANDS, check_identifier, check_tool_template, num, short
from .orientation import fixed_xyz_angles
from .plan import LayerStart, Motion, Plan, ProcessChange, chunk_steps
from .walk import walk_programs

# a schedule's values, in the order of the schedule file's columns (zone parameter names)
SCHEDULE_VALUES = ("voltage", "current", "wire_feed_speed", "job", "travel_speed")
SCHEDULE_COLUMNS = ("schedule", "voltage_V", "current_A", "wire_feed_speed_m_min", "job", "travel_speed_mm_s", "zones")
SCHEDULE_FILE = "SCHED.CSV"
COMMENT_MAX = 32  # a TP comment (!) holds at most 32 characters
ATTR_COMMENT_MAX = 16  # /ATTR COMMENT holds at most 16
SCHEDULES_NAMED = 5  # weld issues name this many schedules one by one, then one for the rest
SCHEDULES_USUAL = 32  # more weld schedules than this: the post says to check the controller's count


@dataclass(frozen=True, eq=False)
class TpSettings:
    """program_name: main program name (≤ 24 characters so `<NAME>_L0003_12` fits the
    controller's 36; written upper case). tool / user_frame: UT and UF numbers. travel_speed: mm/s.
    cnt: CNT of blended motions (0..100; exact stops are FINE). max_points_per_program: positions
    per program (0 = only the per-layer split). external_axes: (n, 1..3) positioner angles in
    degrees per toolpath point (group 2, see module doc), or None."""

    program_name: str = "WAAMFLOW"
    tool: int = 1
    user_frame: int = 1
    travel_speed: float = 100.0
    cnt: int = 100
    max_points_per_program: int = 1000
    external_axes: np.ndarray | None = None
    decimals: int = 3
    tool_on: str = TOOL_COMMANDS["tp"][0]  # post-deposition tool (rolling, peening): common.py
    tool_off: str = TOOL_COMMANDS["tp"][1]

    def __post_init__(self) -> None:
        check_identifier(self.program_name, 24, "TP program name")
        check_tool_template(self.tool_on, "tool_on")
        check_tool_template(self.tool_off, "tool_off")
        if not 0 <= self.cnt <= 100:
            raise ValueError("cnt must be 0..100 (TP CNT)")
        if self.max_points_per_program < 0 or 0 < self.max_points_per_program < 10:
            raise ValueError("max_points_per_program must be 0 (per layer only) or at least 10")
        if not 1 <= self.tool <= 10 or not 0 <= self.user_frame <= 9:
            raise ValueError("tool must be 1..10 (UT) and user_frame 0..9 (UF)")
        if (
            self.external_axes is not None
            and not 1 <= np.asarray(self.external_axes).reshape(len(self.external_axes), -1).shape[1] <= 3
        ):
            raise ValueError("TP group 2: 1 to 3 positioner axes")


def schedule_key(params: dict) -> tuple:
    """The weld-value set of a zone's parameters (None where the zone does not give a value)."""
    return tuple(float(params[n]) if n in params else None for n in SCHEDULE_VALUES)


def _comment(text: str) -> str:
    return "! " + text[: COMMENT_MAX - 2]


def speed_text(v: float) -> str:
    """A TP linear speed: whole mm/sec, else whole cm/min (see module doc)."""
    if abs(v - round(v)) < 1e-6 and round(v) >= 1:
        return f"{round(v)}mm/sec"
    return f"{max(1, round(v * 6.0))}cm/min"


def _pos(k: int, p: np.ndarray, r: np.ndarray, s: TpSettings, ext: np.ndarray | None = None) -> list[str]:
    d = s.decimals
    out = [
        f"P[{k}]{{",
        "   GP1:",
        f"\tUF : {s.user_frame}, UT : {s.tool},\t\tCONFIG : 'N U T, 0, 0, 0',",
        f"\tX = {num(p[0], d):>10} mm,\tY = {num(p[1], d):>10} mm,\tZ = {num(p[2], d):>10} mm,",
        f"\tW = {num(r[0], d):>10} deg,\tP = {num(r[1], d):>10} deg,\tR = {num(r[2], d):>10} deg",
    ]
    if ext is not None:  # group 2: the positioner's joints, degrees
        out += [
            "   GP2:",
            f"\tUF : {s.user_frame}, UT : {s.tool},",
            "\t" + ",\t".join(f"J{j} = {num(v, d):>10} deg" for j, v in enumerate(ext, 1)),
        ]
    return out + ["};"]


def _mn_line(k: int, body: str) -> str:
    """A numbered /MN line: motions right after the colon, other instructions after two spaces."""
    return f"{k:4d}:{body}" if body.startswith(("L ", "J ")) else f"{k:4d}:  {body}"


def render(name: str, comment: str, body: list[str], positions: list[str], groups: str = "1,*,*,*,*") -> str:
    """A whole .LS file from its /MN instructions (without numbers or the trailing `;`) and the
    /POS lines. Creation date fixed (the trace comment says when it was made)."""
    mn = [_mn_line(k, ln + ("    ;" if ln.startswith(("L ", "J ")) else " ;")) for k, ln in enumerate(body, 1)]
    size = sum(len(x) + 1 for x in mn + positions)
    head = [
        "/PROG  " + name,
        "/ATTR",
        "OWNER\t\t= MNEDITOR;",
        f'COMMENT\t\t= "{comment[:ATTR_COMMENT_MAX]}";',
        f"PROG_SIZE\t= {size};",
        "CREATE\t\t= DATE 00-01-01  TIME 00:00:00;",
        "MODIFIED\t= DATE 00-01-01  TIME 00:00:00;",
        "FILE_NAME\t= ;",
        "VERSION\t\t= 0;",
        f"LINE_COUNT\t= {len(mn)};",
        f"MEMORY_SIZE\t= {size + 512};",
        "PROTECT\t\t= READ_WRITE;",
        "TCD:  STACK_SIZE\t= 0,",
        "      TASK_PRIORITY\t= 50,",
        "      TIME_SLICE\t= 0,",
        "      BUSY_LAMP_OFF\t= 0,",
        "      ABORT_REQUEST\t= 0,",
        "      PAUSE_REQUEST\t= 0;",
        f"DEFAULT_GROUP\t= {groups};",
        "CONTROL_CODE\t= 00000000 00000000;",
        "/APPL",
        "  ARC Welding Equipment : 1,*,*,*,*;",
        "/MN",
    ]
    return "\n".join(head + mn + ["/POS"] + positions + ["/END"]) + "\n"


_NUMBERED = re.compile(r"^\s*\d+:(.*?)\s*;\s*$")


def mn_body(text: str) -> list[str]:
    """The /MN instructions of an .LS file without their numbers and `;` (inverse of `render`)."""
    mn = text.split("\n/MN\n", 1)[1].split("\n/POS\n", 1)[0]
    return [m.group(1).strip() for ln in mn.splitlines() if (m := _NUMBERED.match(ln))]


def _attr(text: str, pattern: str, name: str, what: str) -> str:
    """Group 1 of the /ATTR line `pattern` of program `name`; ValueError naming the line when absent."""
    m = re.search(pattern, text, re.M)
    if m is None:
        raise ValueError(f"TP program {name}: no {what} line in its /ATTR section")
    return m.group(1)


def with_comments(text: str, comments: list[str]) -> str:
    """The .LS file with `comments` as the first /MN lines (renumbered, LINE_COUNT updated)."""
    name = text.split("\n", 1)[0].split()[1]
    comment = _attr(text, r'^COMMENT\t\t= "([^"]*)";', name, "COMMENT")
    groups = _attr(text, r"^DEFAULT_GROUP\t= (\S+);", name, "DEFAULT_GROUP")
    positions = text.split("\n/POS\n", 1)[1].rsplit("/END", 1)[0].splitlines()
    return render(name, comment, [_comment(c) for c in comments] + mn_body(text), positions, groups)


def schedule_csv(numbers: dict[tuple, int], zones: dict[int, list[str]]) -> str:
    """The schedule table (SCHEDULE_COLUMNS): one row per schedule, empty where a zone gives no value."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(SCHEDULE_COLUMNS)
    for key, n in sorted(numbers.items(), key=lambda kv: kv[1]):
        w.writerow([n, *("" if v is None else f"{v:.6g}" for v in key), " ".join(zones.get(n, []))])
    return buf.getvalue()


def schedule_comment(n: int, key: tuple) -> list[str]:
    """The schedule as ≤ 32-character comment lines (what to enter on the controller)."""
    units = {name: PARAMETERS_BY_NAME[name].unit for name in SCHEDULE_VALUES}
    vals = dict(zip(SCHEDULE_VALUES, key))
    first = " ".join(f"{short(vals[n])}{units[n]}" for n in ("voltage", "current") if vals[n] is not None)
    second = " ".join(
        f"{short(vals[n])}{units[n]}" if n != "job" else f"job {short(vals[n])}"
        for n in ("wire_feed_speed", "job", "travel_speed")
        if vals[n] is not None
    )
    return [f"sched {n}: {first or 'no values'}"[: COMMENT_MAX - 2]] + (
        [f" {second}"[: COMMENT_MAX - 2]] if second else []
    )


def tp_schedule_issues(plan: Plan, base: str) -> tuple:
    """`WeldDataIssue`s saying the weld schedules must be entered on the controller (TP has no
    inline weld values; numbered as `write_tp` does): one per schedule, at the first zone that
    welds with it, for the first SCHEDULES_NAMED; the rest in one issue at the next one's zone (a
    per-layer compensation gives a schedule per layer). More than SCHEDULES_USUAL schedules is said
    too: check the controller holds that many."""
    from .common import WeldDataIssue

    numbers: dict[tuple, int] = {}
    first: list[tuple] = []  # (schedule, key, section key, layer, zone id)
    layer = None
    for st in plan.steps:
        if isinstance(st, LayerStart):
            layer = st.layer
        elif isinstance(st, ProcessChange):
            key = schedule_key(st.params)
            if key not in numbers:
                numbers[key] = len(numbers) + 1
                first.append((numbers[key], key, plan.moves.section_keys[st.section], layer, st.zone_id or "-"))
    where = f"table in {base}_{SCHEDULE_FILE}"
    out = []
    for n, key, sec, lay, zid in first[:SCHEDULES_NAMED]:
        vals = " ".join(v.strip() for v in schedule_comment(n, key)).split(": ", 1)[1]
        out.append(
            WeldDataIssue(
                sec,
                lay,
                zid,
                f"weld schedule {n} ({vals}) must be entered on the controller: "
                f"TP has no inline weld values (Arc Start[{n}]; {where})",
            )
        )
    if len(first) > SCHEDULES_NAMED:
        _n, _key, sec, lay, zid = first[SCHEDULES_NAMED]
        many = f"; {len(first)} schedules: check the controller holds that many" if len(first) > SCHEDULES_USUAL else ""
        rest = (
            f"schedule {len(first)}"
            if len(first) == SCHEDULES_NAMED + 1
            else f"schedules {SCHEDULES_NAMED + 1}..{len(first)}"
        )
        out.append(
            WeldDataIssue(sec, lay, zid, f"weld {rest} must be entered on the controller as well ({where}){many}")
        )
    return tuple(out)


class _Tp:
    """TP's lines for the shared statement walk (`walk.walk_programs`): every motion a new P[i] of
    its program; the weld by schedule numbers (1.. in order of first use, and the zones that use
    each), `Arc Start[k]` igniting with schedule k or switching to it while welding."""

    name = "TP"

    def __init__(self, s: TpSettings, coordinated: bool) -> None:
        self.travel_speed, self.tool_on, self.tool_off = s.travel_speed, s.tool_on, s.tool_off
        self.cnt = s.cnt
        self.coord = " COORD" if coordinated else ""
        self.numbers: dict[tuple, int] = {}  # weld-value set → schedule number, 1.. in order of first use
        self.zones: dict[int, list[str]] = {}  # schedule → the zones that use it
        self.sched = 0
        self.pts: list[int] = []

    def comment(self, text: str) -> str:
        return _comment(text)

    def process_change(self, st: ProcessChange, arc: bool) -> list[str]:
        new = self.numbers.setdefault(schedule_key(st.params), len(self.numbers) + 1)
        zid = st.zone_id or "-"
        if zid not in self.zones.setdefault(new, []):
            self.zones[new].append(zid)
        out = [_comment(f"zone {st.zone_id or '-'} sched {new}")]
        if arc and new != self.sched:
            out.append(f"Arc Start[{new}]")  # ArcTool: Arc Start while welding = schedule change
        self.sched = new
        return out

    def arc_on(self, ignition_s: float) -> list[str]:
        if not self.sched:  # no weld values given: an empty schedule
            self.sched = self.numbers.setdefault(schedule_key({}), len(self.numbers) + 1)
        return [f"Arc Start[{self.sched}]"] + ([f"WAIT {ignition_s:6.2f}(sec)"] if ignition_s > 0 else [])

    def arc_off(self) -> list[str]:
        return [f"Arc End[{self.sched}]"]

    def wait(self, seconds: float) -> str:
        return f"WAIT {seconds:6.2f}(sec)"

    def start_program(self) -> None:
        self.pts = []

    def motion(self, st: Motion, speed: float) -> str:
        self.pts.append(st.end)
        term = "FINE" if st.stop else f"CNT{self.cnt}"
        return f"L P[{len(self.pts)}] {speed_text(speed)} {term}{self.coord}"

    def positions(self) -> list[int]:
        return list(self.pts)


def write_tp(plan: Plan, settings: TpSettings = TpSettings()) -> dict[str, str]:
    """The main program {"LS": ...}, one program per layer {"L003.LS": ...} and the schedule table
    {"SCHED.CSV": ...} (see module doc)."""
    s = settings
    base = s.program_name.upper()
    P = plan.moves.points
    R = fixed_xyz_angles(plan.moves.tool_axis)
    ext = None if s.external_axes is None else np.asarray(s.external_axes, dtype=float).reshape(len(P), -1)
    groups = "1,*,*,*,*" if ext is None else "1,1,*,*,*"
    progs: list[tuple[str, str, list[str], list[int]]] = []  # (name, comment, body, point indices)
    frames = [f"UFRAME_NUM={s.user_frame}", f"UTOOL_NUM={s.tool}"]
    tp = _Tp(s, ext is not None)
    chunks = chunk_steps(plan.steps, max_points=s.max_points_per_program)
    for chunk, cur, cur_pts in walk_programs(plan, chunks, tp):
        k = chunk.layer if chunk.layer is not None else 0
        part = chunk.part
        progs.append(
            (
                f"{base}_L{k:03d}" + (f"_{part}" if part else ""),
                f"waamflow L{k}" + (f".{part}" if part else ""),
                frames + cur,
                cur_pts,
            )
        )
    numbers, zones = tp.numbers, tp.zones
    st_ = plan.stats
    main = [
        _comment(f"waamflow: {len(progs)} programs"),
        _comment(f"layers {st_['layers']}"),
        _comment(f"deposit {st_['deposition_length_mm']:.1f} mm"),
        _comment(f"travel {st_['travel_length_mm']:.1f} mm"),
        _comment(f"weld schedules: {base}_SCHED"),
        _comment("enter them on the controller"),
    ]
    for key, n in sorted(numbers.items(), key=lambda kv: kv[1]):
        main += [_comment(c) for c in schedule_comment(n, key)]
    main += [f"CALL {name}" for name, _, _, _ in progs]
    files = {"LS": render(base, "waamflow main", main, [])}
    for name, comment, body, pts in progs:
        pos = [ln for j, i in enumerate(pts, 1) for ln in _pos(j, P[i], R[i], s, None if ext is None else ext[i])]
        files[name[len(base) + 1 :] + ".LS"] = render(name, comment, body, pos, groups)
    files[SCHEDULE_FILE] = schedule_csv(numbers, zones)
    return files
