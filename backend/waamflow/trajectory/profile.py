"""Robot controller profile: every constant of the motion model, loaded from a JSON file.

Nothing the controller model uses is hard-coded in Python: path acceleration/jerk, corner limits,
the interpolation cycle, the smoothing filter, arc-switch timing, backlash all live in a profile
file under `waamflow/data/robots/<name>.json` (or any user file with the same keys).

Units: mm, s, mm/s, mm/s², mm/s³.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

from ..core.errors import InputFileError
from ..core.files import read_shipped

ROBOTS_DIR = Path(__file__).resolve().parent.parent / "data" / "robots"


@dataclass(frozen=True)
class RobotProfile:
    """Constants of the controller model (see `trajectory.controller` for how each one is used).

    path_acc: max tangential (path) acceleration when speeding up, mm/s². path_jerk: max path
        jerk when speeding up, mm/s³.
    path_dec / path_dec_jerk: the same when slowing down (0 = as when speeding up). The KRC2 of
        the study ramps up and down differently: its 10 mm/s stop takes longer than its start,
        its 40 mm/s stop shorter (robot-study.md, identified T/L_init_accel vs T/L_final_decel).
    ramp_speeds: () or (v_slow, v_fast) mm/s — when set, path_acc / path_dec hold at v_slow and
        path_acc·acc_ratio_fast / path_dec·dec_ratio_fast at v_fast, interpolated linearly in the
        programmed speed of the motion (clamped outside): the limits identified per measured
        speed (the ratios keep path_acc / path_dec the overall level a trace fit can adjust). A single
        acceleration cannot give the study's ramps: the start lengthens with speed (0.12 s of
        ramp at 10 mm/s, 0.21 s at 40 mm/s) while the stop hardly does (0.16 s, 0.19 s).
    normal_acc: max centripetal acceleration in blends, mm/s² (corner cap √(a_n·r)).
    normal_jerk: max normal jerk in blends, mm/s³ (corner cap (j_n·r²)^(1/3)).
    turn_radius_mm: ρ, mm (0 = off): the direction of motion turns no faster than v/ρ rad/s for a
        programmed speed v — as on an arc of radius ρ run at v — so a blend of radius r < ρ is
        run at v·r/ρ at most. Unlike √(a_n·r) and (j_n·r²)^(1/3) this cap scales with the
        programmed speed: a sharp corner costs time at 10 mm/s as it does at 40 (the study's
        45° apex: the 10 mm/s transition takes 1.2 s for an 11.6 mm link).
    smoothing_s: length of the controller's moving-average (FIR) position filter, s — the KRC's
        ramp smoothing / servo lag; it makes corner cuts grow with speed and adds a fixed
        time to every acceleration (the study's T_init_accel 0.144 s at 10 mm/s vs 0.204 s at
        40 mm/s cannot both come from an acceleration limit alone).
    apo_time_s / apo_min_mm: the approximation ("blend") starts no farther from the vertex than
        apo_min_mm + v·apo_time_s (v programmed speed), so d = min(CDIS, apo_min_mm +
        v·apo_time_s, L_prev/2, L_next/2), mm — the study's 2.95° corner error is 0.8 mm at
        10 mm/s but 1.8 mm at 40 mm/s with the same CDIS.
    interpolation_cycle_s: controller interpolation cycle (KRC2: 12 ms).
    arc_switch_dwell_s: standstill added at every arc ON/OFF switch (advance-run stop + I/O).
    arc_on_delay_s / arc_off_delay_s: delay from the switch command (issued at the stop) to the
        arc really being ON / OFF; positive values leak into the following motion.
    catchup: 0…1, the post-stop catch-up: in an arc-OFF block that starts at an arc switch (the
        travel outside the OR after the arc-OFF stop) the controller cuts the corners harder —
        the speed-dependent approximation limit is lifted by this fraction, and next to an exact
        stop the blend may use up to (0.5 + 0.5·catchup) of the segment instead of half of it
        (robot-study.md: "catches up after each stop by cutting the path outside the OR harder").
    backlash_start_mm / backlash_end_mm: transverse offset right after a start / before a stop
        (study: +0.2 / −0.1 mm on a 100 mm line at 40 mm/s), decaying over smoothing_s.
    travel_speed: speed of arc-OFF moves that carry no speed, mm/s.
    max_speed: robot's max TCP path speed, mm/s.
    description: robot model file (URDF) in the robots folder for kinematics, "" = none.
    tcp_offset_mm: TCP in the flange frame (tool0), mm; base_xyz_mm: robot base in the world, mm —
        defaults for simulate-robot's params of the same names.
    time_model: the study's identified parameters of the closed-form cycle-time model keyed by
        "<speed>_<protocol>" (protocol "on" = arc ON throughout, "off" = arc OFF outside), plus
        L_trans_ref (mm), the programmed length of the link they were identified on.
    controller: the controller family this profile models ("kuka_krc2", "kuka_krc4", "abb_irc5",
        "gcode_planner"; "" = not stated): reported with the simulation.
    junction_deviation_mm: δ, mm (0 = off). When set the profile is a G-code motion planner
        (grbl / Marlin JUNCTION_DEVIATION / Klipper / LinuxCNC-style): the tool follows the
        polyline exactly (no corner cut), each junction's speed is
        v_j = √(a·δ·sin(θ/2) / (1 − sin(θ/2))) for the interior angle θ between the two moves and
        a = path_acc (grbl planner.c), ramps are trapezoidal (path_jerk very large), and the
        node's cdis / blend do not apply.
    lookahead_blocks: N ≥ 0, the planner's block buffer (grbl / Marlin BLOCK_BUFFER_SIZE 16);
        every block's entry speed allows a stop at the end of the N blocks the planner sees
        (0 = the whole program is known, as a robot controller's advance run is not).
    notes: how the constants were obtained.
    """

    name: str
    path_acc: float = 500.0
    path_jerk: float = 50000.0
    path_dec: float = 0.0
    path_dec_jerk: float = 0.0
    ramp_speeds: tuple = ()
    acc_ratio_fast: float = 1.0
    dec_ratio_fast: float = 1.0
    normal_acc: float = 500.0
    normal_jerk: float = 20000.0
    turn_radius_mm: float = 0.0
    smoothing_s: float = 0.11
    apo_time_s: float = 0.1
    apo_min_mm: float = 0.0
    interpolation_cycle_s: float = 0.012
    arc_switch_dwell_s: float = 0.0
    arc_on_delay_s: float = 0.0
    arc_off_delay_s: float = 0.0
    catchup: float = 0.0
    backlash_start_mm: float = 0.0
    backlash_end_mm: float = 0.0
    travel_speed: float = 100.0
    max_speed: float = 2000.0
    description: str = ""
    tcp_offset_mm: tuple[float, float, float] = (0.0, 0.0, 400.0)
    base_xyz_mm: tuple[float, float, float] = (-1500.0, 0.0, -600.0)
    time_model: dict = field(default_factory=dict)
    controller: str = ""
    junction_deviation_mm: float = 0.0
    lookahead_blocks: int = 0
    notes: str = ""

    # names of the constants a calibration may fit (all positive floats)
    FITTABLE = (
        "path_acc",
        "path_jerk",
        "path_dec",
        "path_dec_jerk",
        "acc_ratio_fast",
        "dec_ratio_fast",
        "catchup",
        "normal_acc",
        "normal_jerk",
        "turn_radius_mm",
        "smoothing_s",
        "apo_time_s",
        "apo_min_mm",
        "arc_switch_dwell_s",
        "arc_on_delay_s",
        "arc_off_delay_s",
    )

    @property
    def dec(self) -> tuple[float, float]:
        """(slow-down acceleration mm/s², jerk mm/s³): path_dec / path_dec_jerk or the speed-up ones."""
        return (self.path_dec or self.path_acc, self.path_dec_jerk or self.path_jerk)

    def ramp_limits(self, speed):
        """Path limits for motions programmed at `speed` (array, mm/s): (acc, jerk, dec, dec_jerk)
        arrays — constants, or interpolated between the two `ramp_speeds`."""
        import numpy as np

        v = np.asarray(speed, dtype=float)
        dec, dj = self.dec
        acc = np.full(v.shape, self.path_acc)
        de = np.full(v.shape, dec)
        if len(self.ramp_speeds) == 2:
            lo, hi = (float(x) for x in self.ramp_speeds)
            w = np.clip((v - lo) / (hi - lo), 0.0, 1.0) if hi > lo else np.zeros(v.shape)
            acc = self.path_acc * (1.0 + w * (self.acc_ratio_fast - 1.0))
            de = dec * (1.0 + w * (self.dec_ratio_fast - 1.0))
        return acc, np.full(v.shape, self.path_jerk), de, np.full(v.shape, dj)

    def with_values(self, **kw) -> "RobotProfile":
        return replace(self, **kw)

    def to_json(self) -> dict:
        d = asdict(self)
        d["tcp_offset_mm"] = list(self.tcp_offset_mm)
        d["base_xyz_mm"] = list(self.base_xyz_mm)
        d["ramp_speeds"] = list(self.ramp_speeds)
        return d


def profile_from_dict(d: dict, source: str = "profile") -> RobotProfile:
    known = {f.name for f in fields(RobotProfile)}
    unknown = sorted(set(d) - known - {"comment", "fit"})
    if unknown:  # named by count only: an error never echoes a file's content (#26 fault 3)
        raise InputFileError(
            f"{source}: {len(unknown)} keys are not robot profile fields (a profile holds only: "
            f"{', '.join(sorted(known))}, comment, fit)"
        )
    kw = {k: v for k, v in d.items() if k in known}
    for k in ("tcp_offset_mm", "base_xyz_mm", "ramp_speeds"):
        if k in kw:
            try:
                kw[k] = tuple(float(x) for x in kw[k])
            except (TypeError, ValueError):
                raise InputFileError(f"{source}: robot profile value {k} must be a list of numbers") from None
    if len(kw.get("ramp_speeds", ())) not in (0, 2) or (
        kw.get("ramp_speeds") and kw["ramp_speeds"][0] >= kw["ramp_speeds"][1]
    ):
        raise InputFileError(f"{source}: ramp_speeds must be [] or [slow, fast] mm/s with slow < fast")
    kw.setdefault("name", Path(source).stem)
    try:
        prof = RobotProfile(**kw)
    except TypeError as e:  # pragma: no cover - guarded by the key check
        raise InputFileError(f"{source}: {e}") from e
    for k in RobotProfile.FITTABLE + ("interpolation_cycle_s", "travel_speed", "max_speed"):
        v = getattr(prof, k)
        if not isinstance(v, (int, float)) or v < 0:
            raise InputFileError(f"{source}: robot profile value {k}={v!r} must be a number ≥ 0")
    if prof.interpolation_cycle_s <= 0 or prof.path_acc <= 0 or prof.path_jerk <= 0:
        raise InputFileError(f"{source}: interpolation_cycle_s, path_acc and path_jerk must be > 0")
    if not isinstance(prof.junction_deviation_mm, (int, float)) or prof.junction_deviation_mm < 0:
        raise InputFileError(
            f"{source}: robot profile value junction_deviation_mm={prof.junction_deviation_mm!r} "
            f"must be a number ≥ 0 (mm)"
        )
    if (
        not isinstance(prof.lookahead_blocks, int)
        or isinstance(prof.lookahead_blocks, bool)
        or prof.lookahead_blocks < 0
    ):
        raise InputFileError(
            f"{source}: robot profile value lookahead_blocks={prof.lookahead_blocks!r} must be a whole number ≥ 0"
        )
    if prof.catchup > 1:
        raise InputFileError(f"{source}: robot profile value catchup={prof.catchup!r} must be within 0…1")
    return prof


def shipped_profiles() -> list[str]:
    """Names of the profiles shipped in waamflow/data/robots (files with a `path_acc` key)."""
    out = []
    for p in sorted(ROBOTS_DIR.glob("*.json")):
        try:
            if "path_acc" in json.loads(p.read_text()):
                out.append(p.stem)
        except (OSError, ValueError):
            continue
    return out


def load_profile(name_or_path: str, text: str | None = None) -> RobotProfile:
    """A shipped profile by name ("kuka_kr100ha_krc2"), or a JSON file's text (`text` given)."""
    if text is None:  # a shipped name, never a path (core.files)
        text = read_shipped(
            ROBOTS_DIR, f"{name_or_path}.json", "robot profile", shipped_profiles(), limit=1_000_000
        ).decode("utf-8")
    try:
        d = json.loads(text)
    except ValueError as e:
        raise InputFileError(f"robot profile {name_or_path}: invalid JSON ({e})") from e
    if not isinstance(d, dict):
        raise InputFileError(f"robot profile {name_or_path}: expected a JSON object")
    return profile_from_dict(d, source=str(name_or_path))
