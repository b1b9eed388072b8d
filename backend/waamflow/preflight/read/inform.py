"""Yaskawa INFORM read back: the jobs in the order the main job calls them, C positions from each
job's //POS (with the user frame, tool and position type each is declared under), current and
voltage from ARCON/ARCSET. A motion the reader cannot place — an incremental `IMOV`, a move to a
position variable (P, BP, EX, LP: the controller's values), a move while a parallel shift
(`SFTON`) is on, a C position in joint pulses, a circular or spline MOVC/MOVS — and a change of
user frame or tool after the program has moved are `unplaced` (RunBuilder)."""

from __future__ import annotations

import math
import re

import numpy as np

from .core import NUM, ProgramRead, RunBuilder
from .orient import axes_euler

_JOB_NAME = re.compile(r"^//NAME\s+(\S+)", re.MULTILINE)
_JOB_CALL = re.compile(r"^CALL\s+JOB:(\S+)", re.MULTILINE)
_CPOS = re.compile(
    r"^C(\d+)=(" + NUM + r"),(" + NUM + r"),(" + NUM + r")(?:,(" + NUM + r"),(" + NUM + r"),(" + NUM + r"))?"
)
_POS_TAG = re.compile(r"^///(USER|TOOL|POSTYPE)\s+(\w+)")
_INF_MOVE = re.compile(r"^(S?MOV[LJCS]|IMOV)\s+(\S+)(.*)$")
_INF_SPEED = re.compile(r"\bV=(" + NUM + r")")
_INF_TOOL = re.compile(r"\bTOOL#\((\d+)\)")
_INF_MFRAME = re.compile(r"^MFRAME\s+UF#\((\d+)\)")
_INF_VAL = re.compile(r"\b(AC|AV)=(" + NUM + r")")
_INF_T = re.compile(r"\bT=(" + NUM + ")")  # ARCON's ignition time, s
_INF_TIMER = re.compile(r"TIMER\s+T=(" + NUM + ")")
_INF_C = re.compile(r"C(\d+)")
_INF_EC = re.compile(r"^EC(\d+)=(.*)$", re.MULTILINE)  # a station position, pulses
_INF_STATION = re.compile(r"\+MOVJ\s+EC(\d+)")  # the station's coordinated target of a motion
_INF_PPD = re.compile(r"^'pulse/deg\s+(.*)$", re.MULTILINE)  # the post's note of the station's pulses per degree


class _CPoint:
    """A C position of a job's //POS and the frame it is declared in."""

    __slots__ = ("xyz", "postype", "user", "tool", "axis")

    def __init__(self, xyz: np.ndarray, postype: str, user: str, tool: str) -> None:
        self.xyz, self.postype, self.user, self.tool = xyz, postype, user, tool
        self.axis: np.ndarray | None = None  # the tool z (along the torch) from Rx, Ry, Rz


def _job_positions(text: str) -> dict[int, _CPoint]:
    """C number → position and frame, from the //POS section: `///POSTYPE` USER (the user frame
    `///USER n`), ROBOT (the robot's base), PULSE (joint pulses: not a place); `///TOOL n`."""
    out: dict[int, _CPoint] = {}
    angles: list[tuple[int, tuple[str, str, str]]] = []
    postype, user, tool = "USER", "0", "0"
    for ln in text.split("//INST", 1)[0].splitlines():
        m = _POS_TAG.match(ln)
        if m:
            tag, v = m.group(1), m.group(2).upper()
            postype, user, tool = (
                (v, user, tool) if tag == "POSTYPE" else (postype, v, tool) if tag == "USER" else (postype, user, v)
            )
            continue
        m = _CPOS.match(ln)
        if m:
            xyz = np.array([float(m.group(2)), float(m.group(3)), float(m.group(4))])
            out[int(m.group(1))] = _CPoint(xyz, postype, user, tool)
            if m.group(5) is not None and postype in ("USER", "ROBOT"):
                angles.append((int(m.group(1)), (m.group(5), m.group(6), m.group(7))))
    # Yaskawa Rx, Ry, Rz: fixed axes, R = Rz·Ry·Rx, tool z along the torch
    for (k, _), axis in zip(angles, axes_euler(np.array([a for _, a in angles], float), "xyz", 2)):
        out[k].axis = axis
    return out


class _InformReader:
    """Walks the jobs' //INST lines into a RunBuilder."""

    def __init__(self, ppd: tuple[float, ...] | None = None) -> None:
        self.b = RunBuilder("inform")
        self.ppd = ppd  # the station axes' pulses per degree (the main job's note), None: not stated
        self.station: dict[int, str] = {}  # the job being walked: EC number → its pulses as written
        # a station position's text → its angles in degrees (None: no pulses per degree for them);
        # a layer's positions repeat the same text
        self.degrees: dict[str, tuple[float, ...] | None] = {}
        self.vals: dict[str, float] = {}
        self.shift: str | None = None  # where a parallel shift (SFTON) was turned on
        self.line_no = 0  # INST lines over all jobs (a run's line)

    def job(self, name: str, text: str) -> None:
        pos = _job_positions(text)
        head, _, inst = text.partition("//INST")
        self.station = {int(k): vals for k, vals in _INF_EC.findall(head)}
        first = head.count("\n") + 1  # the file line of //INST
        self.shift = None  # a shift ends with its job
        for k, raw in enumerate(inst.splitlines()):
            self.line_no += 1
            self.instruction(raw.strip(), pos, f"{name} line {first + k}")

    def instruction(self, ln: str, pos: dict[int, _CPoint], where: str) -> None:
        b = self.b
        if ln.startswith("'"):
            b.comment(ln[1:])
        elif ln.startswith(("ARCON", "ARCSET")):
            self.vals.update({k: float(v) for k, v in _INF_VAL.findall(ln)})
            if ln.startswith("ARCON"):
                b.arc_on(self.line_no)
                t = _INF_T.search(ln)
                b.dwell(float(t.group(1)) if t else 0.0, math.nan)  # INFORM commands no wire feed
        elif ln.startswith("ARCOF"):
            b.close()
        elif m := _INF_TIMER.match(ln):
            b.dwell(float(m.group(1)), math.nan)
        elif ln.startswith("SFTON"):
            self.shift = where
        elif ln.startswith("SFTOF"):
            self.shift = None
        elif m := _INF_MFRAME.match(ln):
            if b.moved and b.frames.get("user frame") == f"USER {m.group(1)}":
                b.out.unplaced.append(
                    f"{where}: {ln}: the user frame in use is redefined after the program has moved; where it "
                    "lies then is the controller's computation"
                )
        elif m := _INF_MOVE.match(ln):
            self.motion(m.group(1), m.group(2), m.group(3), pos, f"{where}: {ln}")

    def motion(self, kind: str, target: str, tail: str, pos: dict[int, _CPoint], where: str) -> None:
        b = self.b
        c = _INF_C.fullmatch(target)
        if kind == "IMOV":
            b.unplaced(f"{where}: an incremental motion the preflight cannot place")
            return
        if kind.endswith(("MOVC", "MOVS")):
            b.unplaced(f"{where}: a circular or spline motion the preflight does not follow (write MOVL)")
            return
        if c is None:
            b.unplaced(f"{where}: a move to the position variable {target}, the controller's value")
            return
        if self.shift is not None:
            b.unplaced(f"{where}: a move under the parallel shift (SFTON at {self.shift})")
            return
        p = pos.get(int(c.group(1)))
        if p is None:
            b.unplaced(f"{where}: C{int(c.group(1)):05d} not in the job's //POS")
            return
        if p.postype not in ("USER", "ROBOT"):
            b.unplaced(f"{where}: C{int(c.group(1)):05d} is in {p.postype.lower()} (joint) values")
            return
        tool = _INF_TOOL.search(tail)
        b.frame("user frame", f"USER {p.user}" if p.postype == "USER" else "the robot base", where)
        b.frame("tool", f"TOOL {tool.group(1) if tool else p.tool}", where)
        sp = _INF_SPEED.search(tail)
        # a joint move (MOVJ, VJ= % of the joints' speed) has no tool speed: nan (check weld_speed)
        speed = float(sp.group(1)) if sp and kind != "MOVJ" else math.nan
        weld = bool(self.vals.get("AC") or self.vals.get("AV"))
        b.axis = p.axis
        st = _INF_STATION.search(tail)
        if st is not None:
            self.station_angles(int(st.group(1)), where)
        b.move(p.xyz, speed, math.nan, weld)

    def station_angles(self, k: int, where: str) -> None:
        """The positioner's angles (degrees) of the coordinated target EC k, into the builder."""
        text = self.station.get(k)
        if text is None:
            self.b.out.notes.append(f"{where}: EC{k:05d} not in the job's //POS: the positioner's angles are unknown")
            return
        if text not in self.degrees:
            pulses, ppd, deg = tuple(map(float, re.findall(NUM, text))), self.ppd, None
            if ppd is not None and len(ppd) >= len(pulses) and all(d > 0 for d in ppd[: len(pulses)]):
                deg = tuple(p / d for p, d in zip(pulses, ppd))
            self.degrees[text] = deg
        deg = self.degrees[text]
        if deg is not None:
            self.b.positioner(deg)
        elif not any("pulses per degree" in n for n in self.b.out.notes):
            self.b.out.notes.append(
                "the station's pulses per degree are not stated ('pulse/deg in the main job): the "
                "positioner's angles are not known to the preflight"
            )


def read_inform(files: dict[str, str]) -> ProgramRead:
    """INFORM jobs in the order the main job calls them (`CALL JOB:`); positions from each job's
    own //POS; the weld values are ARCON/ARCSET's AC= (current A) and AV= (voltage V)."""
    jobs = {m.group(1).upper(): t for t in files.values() if (m := _JOB_NAME.search(t))}
    main = next((t for t in files.values() if _JOB_CALL.search(t)), next(iter(files.values())))
    calls = [c for c in _JOB_CALL.findall(main) if c.upper() in jobs]
    ppd = next((m.group(1) for t in files.values() if (m := _INF_PPD.search(t))), None)
    r = _InformReader(tuple(float(v) for v in re.findall(NUM, ppd)) if ppd else None)
    if calls:
        for c in calls:
            r.job(c.upper(), jobs[c.upper()])
    else:
        m = _JOB_NAME.search(main)
        r.job(m.group(1) if m else "job", main)
    r.b.close()
    return r.b.out
