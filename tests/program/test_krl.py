"""KUKA KRL: structure, one motion per point, declared points, speeds and blending from the zones."""

import re

import numpy as np
import pytest

from waamflow.core.moves import flatten
from waamflow.program import KrlSettings, PlanSettings, post_process
from waamflow.program.orientation import abc_matrix

from conftest import ZONE_PARAMS, build_toolpath
from helpers import arc_runs
from krl_check import arctech_seams, parse_program

DECL = re.compile(
    r"^DECL E6POS (P\d+)=\{X ([-\d.]+),Y ([-\d.]+),Z ([-\d.]+),A ([-\d.]+),B ([-\d.]+),C ([-\d.]+),"
    r"E1 [-\d.]+,E2 [-\d.]+,E3 [-\d.]+,E4 [-\d.]+,E5 [-\d.]+,E6 [-\d.]+\}$",
    re.M,
)


@pytest.fixture(scope="module")
def moves():
    return flatten(build_toolpath())


def _structure(src: str, dat: str, name: str) -> None:
    lines = [l.strip() for l in src.splitlines() if l.strip()]
    assert lines[2] == f"DEF {name}( )" and lines[-1] == "END"
    assert sum(l.startswith("DEF ") for l in lines) == 1 and sum(l == "END" for l in lines) == 1
    dl = [l.strip() for l in dat.splitlines() if l.strip()]
    assert dl[0] == f"DEFDAT {name}" and dl[-1] == "ENDDAT"
    assert all(DECL.match(l) for l in dl[1:-1])
    used = set(re.findall(r"\b(P\d+)\b", "\n".join(l for l in lines if l.startswith(("LIN", "CIRC")))))
    declared = set(DECL.findall(dat) and [m[0] for m in DECL.findall(dat)])
    assert used == declared


def test_single_program(moves):
    prog = post_process(
        moves, "krl", PlanSettings(ignition_dwell=0.5), KrlSettings(program_name="cross", blend_distance=2.0)
    )
    src, dat = prog.files["src"], prog.files["dat"]
    assert set(prog.files) == {"src", "dat"}
    _structure(src, dat, "cross")
    lin = re.findall(r"^LIN P(\d+)( C_DIS)?$", src, re.M)
    assert [int(p) for p, _ in lin] == list(range(1, len(moves.points) + 1))  # one LIN per point, in order
    assert "$APO.CDIS=2" in src and "BAS(#INITMOV,0)" in src and "BAS(#TOOL,1)" in src and "BAS(#BASE,1)" in src
    # speed in force at each LIN = programmed segment speed (m/s); travel at the travel speed
    vel, seen = None, []
    for line in src.splitlines():
        if line.startswith("$VEL.CP="):
            vel = float(line.split("=")[1].split()[0])
        elif line.startswith("LIN"):
            seen.append(vel)
    want = np.where(np.isfinite(moves.speed), moves.speed, 100.0) / 1000.0
    assert np.allclose(seen[1:], want) and seen[0] == pytest.approx(0.1)
    # exact stop (no C_DIS) exactly where an arc switch or dwell follows
    n_runs = len(arc_runs(moves))
    assert src.count("$OUT[1]=TRUE") == n_runs
    assert src.count("TRIGGER WHEN DISTANCE=1 DELAY=0 DO $OUT[1]=FALSE") == n_runs
    # every TRIGGER (arc off, and since issue 23 the weld values inside a run) arms the next line's motion
    lines = src.splitlines()
    trig = [i for i, l in enumerate(lines) if l.startswith("TRIGGER")]
    assert all(
        re.fullmatch(
            r"(LIN|CIRC) P\d+(,P\d+)?( C_DIS)?", next(x for x in lines[i + 1 :] if not x.startswith("TRIGGER"))
        )
        for i in trig
    )
    assert all(re.fullmatch(r"(LIN|CIRC) P\d+(,P\d+)?", lines[i + 1]) for i in trig if "$OUT[1]=FALSE" in lines[i])
    waits = re.findall(r"^WAIT SEC ([\d.]+) ; (\w+) dwell$", src, re.M)
    assert sum(r == "ignition" for _, r in waits) == n_runs
    assert [float(s) for s, r in waits if r == "interlayer"] == [20.0, 20.0]
    # orientation of a vertical torch, tool direction X: A 0, B 90, C 0
    decl = DECL.findall(dat)
    assert len(decl) == len(moves.points)
    assert {(float(a), float(b), float(c)) for *_, a, b, c in decl} == {(0.0, 90.0, 0.0)}
    xyz = np.array([[float(x), float(y), float(z)] for _, x, y, z, *_ in decl])
    assert np.allclose(xyz, moves.points, atol=1e-3)


def test_tilted_tool_axis_and_circ():
    tp = build_toolpath(1)
    from dataclasses import replace
    from waamflow.core.model import LayerPaths, Layered

    lp = tp[0]
    sp = lp.sections[0]
    axis = np.tile([0.0, np.sin(np.radians(15)), -np.cos(np.radians(15))], (len(sp.points), 1))
    tp = Layered((LayerPaths(lp.layer, (replace(sp, tool_axis=axis),) + lp.sections[1:]),))
    moves = flatten(tp)
    prog = post_process(moves, "krl", PlanSettings(arc_tolerance=0.05))
    src, dat = prog.files["src"], prog.files["dat"]
    _structure(src, dat, "waamflow")
    circ = re.findall(r"^CIRC P(\d+),P(\d+)( C_DIS)?$", src, re.M)
    assert len(circ) == 3 and circ[-1][2] == ""  # the last arc ends the run: exact stop
    decl = {m[0]: tuple(map(float, m[4:])) for m in DECL.findall(dat)}
    R = abc_matrix(np.array([decl["P2"]]))[0]
    assert np.allclose(R[:, 0], axis[0], atol=1e-4)  # tool X = the torch axis


def test_split_per_layer_and_points(moves):
    s = KrlSettings(program_name="part", split_per_layer=True, max_points_per_file=30)
    files = post_process(moves, "krl", writer_settings=s).files
    subs = sorted(k[:-4] for k in files if k.endswith(".src") and k != "src")
    assert subs == ["L000_1", "L000_2", "L001_1", "L001_2", "L002_1", "L002_2"]
    calls = re.findall(r"^(part_\w+)\( \)$", files["src"], re.M)
    assert calls == [f"part_{s}" for s in subs]
    _structure(files["src"], files["dat"], "part")
    total = 0
    for sfx in subs:
        src, dat = files[f"{sfx}.src"], files[f"{sfx}.dat"]
        _structure(src, dat, f"part_{sfx}")
        n = len(re.findall(r"^(LIN|CIRC) ", src, re.M))
        assert 0 < n <= 30
        total += n
    assert total == len(moves.points)
    # L000_1 is cut mid-run (the first arc OFF leaves it under half full): the arc stays on into L000_2
    assert files["L000_1.src"].count("$OUT[1]=TRUE") == 2 and files["L000_1.src"].count("DO $OUT[1]=FALSE") == 1
    assert files["L000_2.src"].count("$OUT[1]=TRUE") == 3 and files["L000_2.src"].count("DO $OUT[1]=FALSE") == 4
    # with room for it, files end after an arc OFF: every file switches the arc on and off equally
    files40 = post_process(
        moves, "krl", writer_settings=KrlSettings(split_per_layer=True, max_points_per_file=40)
    ).files
    subs40 = [k for k in files40 if k.endswith(".src") and k != "src"]
    assert len(subs40) == 6
    for k in subs40:
        src = files40[k]
        assert src.count("$OUT[1]=TRUE") == src.count("DO $OUT[1]=FALSE") > 0
        assert len(re.findall(r"^LIN ", src, re.M)) <= 40
    only_points = post_process(moves, "krl", writer_settings=KrlSettings(max_points_per_file=50)).files
    subs50 = sorted(k for k in only_points if k.endswith(".src"))
    assert subs50 == [f"P{i:03d}.src" for i in range(1, len(subs50) + 1)] and len(subs50) >= 3
    counts = [len(re.findall(r"^LIN ", only_points[k], re.M)) for k in subs50]
    assert max(counts) <= 50 and sum(counts) == len(moves.points)
    assert min(counts[:-1]) >= 25  # cuts after an arc OFF only where the file is at least half full
    with pytest.raises(ValueError):
        KrlSettings(program_name="a_very_long_program_nm", split_per_layer=True)


def test_arctech_mode(moves):
    """KUKA.ArcTech: every run is ARC ON (the motion into its first point), ARC SWI per welding
    motion, ARC OFF (its last motion), each wrapped in ArcMainNG calls of one data set; the data
    sets in the .dat carry the zone's channels, speed (m/min) and ignition dwell."""
    prog = post_process(moves, "krl", writer_settings=KrlSettings(arc_control="arctech"))
    src, dat = prog.files["src"], prog.files["dat"]
    assert "$OUT[" not in src and "ARC_ON(" not in src and "WAIT SEC 0.8" not in src  # no placeholder calls
    parsed = parse_program(src, dat)
    seams = arctech_seams(parsed)
    runs = arc_runs(moves)
    assert len(seams) == len(runs) == 15
    for seam, (a, b) in zip(seams, runs):
        phases = [ph for ph, _, _ in seam]
        assert phases == ["On"] + ["Swi"] * (b - a - 1) + ["Off"]
        assert [m.args[0] for _, _, m in seam] == [f"P{i + 1}" for i in range(a, b + 1)]  # On: into the start point
    sets = {n: dict(v) for n, (t, v) in parsed.data.items() if t == "stArcDat_T" and n.startswith("WDAT")}
    zone_of_speed = {5.0: "start", 6.0: "z1", 7.0: "end"}
    for seam, (a, _) in zip(seams, runs):
        on = dict(sets[seam[0][1]]["Strike"])
        first_zone = ZONE_PARAMS[zone_of_speed[float(moves.speed[a])]]
        assert on["StartTime"] == pytest.approx(first_zone.get("dwell", 0.5))  # the zone's dwell, else the default
        for ph, wdat, m in seam[1:]:
            i = int(m.args[0][1:]) - 2  # segment index into moves
            weld = dict(sets[wdat]["Weld"])
            assert weld["Velocity"] == pytest.approx(moves.speed[i] * 0.06)  # m/min
            z = ZONE_PARAMS[zone_of_speed[float(moves.speed[i])]]
            assert (weld["Channel1"], weld["Channel2"], weld["Channel3"]) == (
                z.get("job", 0),
                z["wire_feed_speed"],
                z["voltage"],
            )
            assert dict(sets[wdat]["Strike"])["StartTime"] == 0.0
    ignitions = {float(moves.speed[a]) for a, _ in runs}
    assert len(sets) == len(ignitions) + 3  # one ignition set per starting zone, one per zone welding
    assert [float(s) for s in re.findall(r"^WAIT SEC ([\d.]+) ; interlayer dwell$", src, re.M)] == [20.0, 20.0]
    # the zones without a job number leave channel 1 at 0: reported per zone
    issues = {(i.zone, i.section) for i in prog.weld_issues}
    assert issues == {(z, s) for z in ("z1", "end") for s in ("bs1/A", "bs1/B", "bs1/C")}
    assert all("job missing" in i.message for i in prog.weld_issues)
    # configurable: routine name, channel map, velocity unit
    s2 = KrlSettings(
        arc_control="arctech",
        arctech_routine="WaamArc",
        arctech_velocity_unit="m/s",
        arctech_channels={"current": 1, "voltage": 2},
    )
    p2 = post_process(moves, "krl", writer_settings=s2)
    parsed2 = parse_program(p2.files["src"], p2.files["dat"])
    assert len(arctech_seams(parsed2, "WaamArc")) == 15 and "ArcMainNG" not in p2.files["src"]
    w = {n: dict(dict(v)["Weld"]) for n, (t, v) in parsed2.data.items() if n.startswith("WDAT")}
    assert sorted({(x["Velocity"], x["Channel1"], x["Channel2"]) for x in w.values()}) == [
        (0.005, 220.0, 21.0),
        (0.006, 200.0, 20.0),
        (0.007, 180.0, 19.0),
    ]
    # issue 23: this map has no channel for wire feed and job: reported per zone, no longer dropped silently
    assert {i.message for i in p2.weld_issues} == {
        "wire_feed_speed 11 m/min, job 12 not commanded: the program has no command for them (map it to a channel in arctech_channels)",
        "wire_feed_speed 10 m/min not commanded: the program has no command for it (map it to a channel in arctech_channels)",
        "wire_feed_speed 8.5 m/min not commanded: the program has no command for it (map it to a channel in arctech_channels)",
    }
    with pytest.raises(ValueError, match="channel"):
        KrlSettings(arctech_channels={"voltage": 9})


def test_arctech_split_declares_data_per_file(moves):
    files = post_process(
        moves, "krl", writer_settings=KrlSettings(program_name="part", arc_control="arctech", split_per_layer=True)
    ).files
    total = 0
    for k in (k for k in files if k.endswith(".src") and k != "src"):
        parsed = parse_program(files[k], files[k[:-3] + "dat"])  # every WDAT used is declared here
        total += len(arctech_seams(parsed))
    assert total == 15
