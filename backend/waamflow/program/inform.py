"""Yaskawa Motoman INFORM writer (YRC1000 / DX200 `.JBI` jobs, ArcWorld arc welding).

Job shape (one job per layer, called by the main job, so no job outgrows the controller's
position table; `max_points_per_job` cuts a layer further)::

    /JOB
    //NAME WAAMFLOW_L003
    //POS
    ///NPOS 412,0,0,0,0,0          ; C (robot) positions, BC, EC, P, BP, EP
    ///TOOL 1
    ///POSTYPE USER
    ///USER 1
    ///RECTAN
    ///RCONF 0,0,0,0,0,0,0,0
    C00000=x,y,z,rx,ry,rz          ; mm, deg: the user frame `user_frame` (the part frame)
    //INST
    ///DATE 2026/11/25 12:00
    ///COMM waamflow layer 3
    ///ATTR SC,RW
    ///GROUP1 RB1
    NOP
    'layer 3 z=4.500
    MOVL C00000 V=100.0 PL=0        ; arc-off travel (PL=0: exact stop before an ignition)
    ARCON AC=150 AV=20.0 T=0.50     ; ignite: current A, voltage V, T = the ignition dwell s
    MOVL C00001 V=8.0 PL=1          ; welding (PL = position level `position_level`)
    ARCSET AC=160 AV=21.0           ; a zone or compensation step changes the weld while welding
    ARCOF
    TIMER T=20.00                   ; interlayer / zone dwell
    END

Comments (') are cut to 32 characters, the controller's limit; the layer / section / zone of
each motion is in them. The weld: `ARCON`/`ARCSET` carry the zone's current (`AC=`, A) and voltage (`AV=`, V) — the
inline form of the arc start condition. Wire feed speed and a job number have no inline form in
INFORM (they live in the arc start condition file `ASF#()` and the power source's synergic line):
a zone that sets them is a weld issue, and the preflight refuses the program (so the values are
never silently dropped). `V=` is the TCP speed in mm/s (the controller's default unit, S2C
parameter; check it is not cm/min). Orientation Rx, Ry, Rz: fixed XYZ angles, R = Rz·Ry·Rx (as
KUKA's A, B, C reversed). Circular motions are not written (the planner gives lines).

A positioner (`external_axes`, E1 tilt / E2 turn in degrees per toolpath point) is station 1: each
layer job is a coordinated job (`///GROUP1 RB1`, `///GROUP2 ST1`), its //POS holds, after the C
positions, one station position per C position (`///NPOS n,0,n,0,0,0`; `EC00000=` in pulses
under `///POSTYPE PULSE`: degrees × `station_pulses_per_deg`, the controller's pulses per degree
of each station axis), and every motion is coordinated: the robot moves relative to the station
while the station moves to its angles (`SMOVL C00001 V=8.0 PL=1 +MOVJ EC00001`; the C positions
are in `user_frame`, the part frame on the positioner, as the KRL/RAPID/TP posts write them)::

    ///NPOS 412,0,412,0,0,0
    ...
    C00000=x,y,z,rx,ry,rz
    ///POSTYPE PULSE
    ///PULSE
    EC00000=1540,-90000           ; E1 1.54°, E2 -90° at 1000 pulses/°
    //INST
    ...
    ///GROUP1 RB1
    ///GROUP2 ST1
    NOP
    SMOVL C00000 V=100.0 PL=0 +MOVJ EC00000
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .common import TOOL_COMMANDS, check_identifier, check_tool_template, num, short
from .orientation import fixed_xyz_angles
from .plan import Motion, Plan, ProcessChange, chunk_steps
from .walk import walk_programs

# INFORM inline weld values: parameter → ARCON/ARCSET tag (what a power source takes inline)
INFORM_WELD_CODES = {"current": "AC={value:.0f}", "voltage": "AV={value:.1f}"}


@dataclass(frozen=True, eq=False)
class InformSettings:
    """program_name: main job name (≤ 24 characters so `<name>_L001` fits 32; stored uppercase).
    tool / user_frame: tool and user frame numbers. travel_speed: mm/s. position_level: PL of
    blended motions (0 = exact stop everywhere). max_points_per_job: positions per job (0 = only
    the per-layer split). external_axes: (n, 1..3) station axis angles in degrees per toolpath
    point, or None. station_pulses_per_deg: pulses per degree of each station axis (the
    controller's; needed with external_axes)."""

    program_name: str = "WAAMFLOW"
    tool: int = 1
    user_frame: int = 1
    travel_speed: float = 100.0
    position_level: int = 1
    max_points_per_job: int = 999
    external_axes: np.ndarray | None = None
    station_pulses_per_deg: tuple[float, ...] = ()
    decimals: int = 3
    tool_on: str = TOOL_COMMANDS["inform"][0]  # post-deposition tool (rolling, peening): common.py
    tool_off: str = TOOL_COMMANDS["inform"][1]

    def __post_init__(self) -> None:
        check_identifier(self.program_name, 24, "INFORM job name")
        check_tool_template(self.tool_on, "tool_on")
        check_tool_template(self.tool_off, "tool_off")
        if not 0 <= self.position_level <= 8:
            raise ValueError("position_level must be 0..8 (INFORM PL)")
        if self.max_points_per_job < 0 or 0 < self.max_points_per_job < 10:
            raise ValueError("max_points_per_job must be 0 (per layer only) or at least 10")
        if not 0 <= self.tool <= 63 or not 1 <= self.user_frame <= 63:
            raise ValueError("tool must be 0..63 and user_frame 1..63")
        if self.external_axes is not None:
            k = np.asarray(self.external_axes).reshape(len(self.external_axes), -1).shape[1]
            if not 1 <= k <= 3:
                raise ValueError("INFORM station: 1 to 3 positioner axes")
            ppd = self.station_pulses_per_deg
            if len(ppd) < k or not all(np.isfinite(v) and v > 0 for v in ppd[:k]):
                raise ValueError(
                    f"INFORM station axes: station_pulses_per_deg needs {k} positive values (the "
                    f"controller's pulses per degree of each positioner axis), got {list(ppd)}"
                )


COMMENT_MAX = 32  # INFORM comment lines (') hold at most 32 characters


def _comment(text: str) -> str:
    return "'" + text[:COMMENT_MAX]


def _name(base: str, k: int | None) -> str:
    return base.upper() if k is None else f"{base.upper()}_L{k:03d}"


def _weld_fields(params: dict, names=None) -> str:
    out = [
        INFORM_WELD_CODES[n].format(value=float(params[n]))
        for n in ("current", "voltage")
        if n in params and (names is None or n in names)
    ]
    return " ".join(out)


def station_pulses(angles_deg: np.ndarray, pulses_per_deg) -> np.ndarray:
    """Station axis angles (deg, (n, k)) as whole encoder pulses."""
    a = np.asarray(angles_deg, float)
    return np.rint(a * np.asarray(pulses_per_deg, float)[: a.shape[1]]).astype(np.int64)


def _job(
    name: str,
    comment: str,
    lines: list[str],
    pts: list[int],
    P: np.ndarray,
    R: np.ndarray,
    s: InformSettings,
    ec: np.ndarray | None = None,
) -> str:
    """A job: its C positions (points `pts`) and, for a coordinated job, `ec` (station pulses per
    point of the whole program) as EC positions."""
    d = s.decimals
    n_ec = len(pts) if ec is not None else 0
    head = [
        "/JOB",
        f"//NAME {name}",
        "//POS",
        f"///NPOS {len(pts)},0,{n_ec},0,0,0",
        f"///TOOL {s.tool}",
        "///POSTYPE USER",
        f"///USER {s.user_frame}",
        "///RECTAN",
        "///RCONF 0,0,0,0,0,0,0,0",
    ]
    head += [
        f"C{k:05d}={num(P[i, 0], d)},{num(P[i, 1], d)},{num(P[i, 2], d)},"
        f"{num(R[i, 0], 4)},{num(R[i, 1], 4)},{num(R[i, 2], 4)}"
        for k, i in enumerate(pts)
    ]
    if ec is not None and n_ec:
        head += ["///POSTYPE PULSE", "///PULSE"]
        head += [f"EC{k:05d}=" + ",".join(str(int(v)) for v in ec[i]) for k, i in enumerate(pts)]
    # a fixed date: the same plan gives the same bytes (the run's trace says when it was made)
    head += [
        "//INST",
        "///DATE 2000/01/01 00:00",
        f"///COMM {comment[:COMMENT_MAX]}",
        "///ATTR SC,RW",
        "///GROUP1 RB1",
        *(["///GROUP2 ST1"] if n_ec else []),
        "NOP",
    ]
    return "\n".join(head + lines + ["END"]) + "\n"


class _Inform:
    """INFORM's lines for the shared statement walk (`walk.walk_programs`): a job declares each
    position once (C00000.. in order of first use); ARCON/ARCSET carry current and voltage inline."""

    name = "INFORM"

    def __init__(self, s: InformSettings, coordinated: bool) -> None:
        self.travel_speed, self.tool_on, self.tool_off = s.travel_speed, s.tool_on, s.tool_off
        self.position_level = s.position_level
        self.coordinated = coordinated
        self.params: dict = {}
        self.index: dict[int, int] = {}
        self.pts: list[int] = []

    def comment(self, text: str) -> str:
        return _comment(text)

    def process_change(self, st: ProcessChange, arc: bool) -> list[str]:
        changed = [n for n in ("current", "voltage") if st.params.get(n) != self.params.get(n)]
        self.params = st.params
        out = [_comment(f"zone {st.zone_id or '-'}")]
        if arc and changed and _weld_fields(self.params, changed):
            out.append(f"ARCSET {_weld_fields(self.params, changed)}")
        return out

    def arc_on(self, ignition_s: float) -> list[str]:
        fields = _weld_fields(self.params)
        return ["ARCON" + (f" {fields}" if fields else "") + f" T={num(ignition_s, 2)}"]

    def arc_off(self) -> list[str]:
        return ["ARCOF"]

    def wait(self, seconds: float) -> str:
        return f"TIMER T={num(seconds, 2)}"

    def start_program(self) -> None:
        self.index, self.pts = {}, []

    def motion(self, st: Motion, speed: float) -> str:
        pl = 0 if st.stop else self.position_level
        if st.end not in self.index:
            self.index[st.end] = len(self.pts)
            self.pts.append(st.end)
        c = f"C{self.index[st.end]:05d}"
        if not self.coordinated:
            return f"MOVL {c} V={num(speed, 1)} PL={pl}"
        return f"SMOVL {c} V={num(speed, 1)} PL={pl} +MOVJ E{c}"  # the robot relative to station 1

    def positions(self) -> list[int]:
        return list(self.pts)


def write_inform(plan: Plan, settings: InformSettings = InformSettings()) -> dict[str, str]:
    """The main job {"JBI": ...} and one job per layer {"L003.JBI": ...} (see module doc)."""
    s = settings
    P = plan.moves.points
    R = fixed_xyz_angles(plan.moves.tool_axis)
    ec = (
        None
        if s.external_axes is None
        else station_pulses(np.asarray(s.external_axes, dtype=float).reshape(len(P), -1), s.station_pulses_per_deg)
    )
    jobs: list[tuple[str, str, list[str], list[int]]] = []  # (name, comment, lines, point indices)
    chunks = chunk_steps(plan.steps, max_points=s.max_points_per_job, distinct=True)
    for chunk, cur, cur_pts in walk_programs(plan, chunks, _Inform(s, ec is not None)):
        k = chunk.layer if chunk.layer is not None else 0
        jobs.append(
            (_name(s.program_name, k) + (f"_{chunk.part}" if chunk.part else ""), f"waamflow layer {k}", cur, cur_pts)
        )
    st_ = plan.stats
    main = [
        _comment(f"waamflow: {len(jobs)} jobs"),
        _comment(f"layers {st_['layers']}"),
        _comment(f"deposit {st_['deposition_length_mm']:.1f} mm"),
        _comment(f"travel {st_['travel_length_mm']:.1f} mm"),
        _comment("AC=current A AV=voltage V"),
    ]
    if ec is not None:
        main += [
            _comment("station ST1: EC in pulses"),
            _comment("pulse/deg " + " ".join(short(v) for v in s.station_pulses_per_deg[: ec.shape[1]])),
        ]
    main += [f"CALL JOB:{name}" for name, _, _, _ in jobs]
    files = {"JBI": _job(s.program_name.upper(), "waamflow main job", main, [], P, R, s)}
    for name, comment, lines, pts in jobs:
        files[name[len(s.program_name) + 1 :] + ".JBI"] = _job(name, comment, lines, pts, P, R, s, ec)
    return files
