"""ABB RAPID: module structure, ArcWare instructions per run, data from the zone parameters."""

import re

import numpy as np
import pytest

from waamflow.core.moves import flatten
from waamflow.program import PlanSettings, RapidSettings, post_process

from conftest import ZONE_PARAMS, build_toolpath
from helpers import arc_runs

MOTION = re.compile(r"^\s*(MoveL|MoveC|ArcLStart|ArcL|ArcLEnd|ArcC|ArcCEnd) (p\d+)(?:, (p\d+))?, (\w+), ", re.M)


@pytest.fixture(scope="module")
def moves():
    return flatten(build_toolpath())


def _lines(text):
    return [l.strip() for l in text.splitlines() if l.strip()]


def test_structure_and_motions(moves):
    text = post_process(moves, "rapid", PlanSettings(ignition_dwell=0.5), RapidSettings(program_name="cross")).files[
        "mod"
    ]
    lines = _lines(text)
    assert lines[0] == "MODULE cross" and lines[-1] == "ENDMODULE"
    assert lines.count("PROC main()") == 1 and lines.count("ENDPROC") == 1
    assert lines.index("PROC main()") < lines.index("ENDPROC")
    code = [l.split("!")[0].strip() for l in lines if not l.startswith("!")]
    assert all(l.endswith(";") or l in ("PROC main()", "ENDPROC", "ENDMODULE") or l.startswith("MODULE") for l in code)
    motions = MOTION.findall(text)
    kinds = [m[0] for m in motions]
    runs = arc_runs(moves)
    assert kinds.count("ArcLStart") == kinds.count("ArcLEnd") == len(runs)
    # one motion per point, plus one in-place ArcLStart where an interlayer dwell sits on the ignition point
    assert len(motions) == len(moves.points) + 2
    assert "ArcLStart p48, vw1, sm1, wd1, fine" in text  # ignite in place after the dwell at layer 1's start
    targets = [int(m[1][1:]) - 1 for m in motions]
    assert sorted(set(targets)) == list(range(len(moves.points)))
    # each run: ArcLStart into its first point, ArcL through, ArcLEnd at its last point, fine
    starts = [int(m[1][1:]) - 1 for m in motions if m[0] == "ArcLStart"]
    ends = [int(m[1][1:]) - 1 for m in motions if m[0] == "ArcLEnd"]
    assert starts == [a for a, _ in runs] and ends == [b for _, b in runs]
    assert re.findall(r"ArcLEnd p\d+, \w+, \w+, \w+, (\w+),", text) == ["fine"] * len(runs)
    # every referenced robtarget is declared, with the vertical-torch quaternion
    decl = dict(
        re.findall(r"CONST robtarget (p\d+) := \[\[([^\]]+)\],\[0\.000000,0\.000000,1\.000000,0\.000000\]", text)
    )
    assert set(decl) == {m[1] for m in motions} | {m[2] for m in motions if m[2]}
    xyz = np.array([list(map(float, decl[f"p{i + 1}"].split(","))) for i in range(len(moves.points))])
    assert np.allclose(xyz, moves.points, atol=1e-3)
    assert re.findall(r"WaitTime\\InPos, ([\d.]+);", text) == ["20", "20"]
    assert "CONST zonedata zw := [FALSE,1,1.5,1.5,0.15,1.5,0.15];" in text


def test_speeds_and_welddata_from_zones(moves):
    text = post_process(moves, "rapid", writer_settings=RapidSettings(blend_distance=0)).files["mod"]
    speeds = dict(re.findall(r"CONST speeddata (vw\d+) := \[([\d.]+),", text))
    welds = {
        n: (float(v), arc) for n, v, arc in re.findall(r"PERS welddata (wd\d+) := \[([\d.]+),0,\[([^\]]+)\]", text)
    }
    assert sorted(float(v) for v in speeds.values()) == [5.0, 6.0, 7.0, 100.0]
    # each welding motion: speeddata = welddata weld_speed = the segment's speed; arcdata = its zone
    zone_arc = {
        z: f"{int(p.get('job', 0))},0,{p['voltage']:g},{p['wire_feed_speed']:g},0,{p['current']:g},0,0,0"
        for z, p in ZONE_PARAMS.items()
    }
    speed_zone = {5.0: "start", 6.0: "z1", 7.0: "end"}
    weld = re.findall(r"^\s*Arc(?:L|LEnd|C|CEnd) (?:p\d+, )?p\d+, (vw\d+), (sm\d+), (wd\d+), (\w+),", text, re.M)
    assert len(weld) == int(moves.arc.sum())  # one welding instruction per arc-on segment
    for v, sm, wd, z in weld:
        assert welds[wd][0] == float(speeds[v])
        assert welds[wd][1] == zone_arc[speed_zone[float(speeds[v])]]
        assert z == "fine"  # blend distance 0: no zonedata
    seams = dict(re.findall(r"PERS seamdata (sm\d+) := \[0,0,\[[^\]]+\],([\d.]+),", text))
    assert sorted(map(float, seams.values())) == [0.5, 0.5, 0.8]  # ignition dwell in ign_move_delay


def test_arcc_with_fitting():
    moves = flatten(build_toolpath(1))
    text = post_process(moves, "rapid", PlanSettings(arc_tolerance=0.05)).files["mod"]
    assert len(re.findall(r"^\s*ArcC p\d+, p\d+,", text, re.M)) == 2
    assert len(re.findall(r"^\s*ArcCEnd p\d+, p\d+, \w+, \w+, \w+, fine,", text, re.M)) == 1
    with pytest.raises(ValueError):
        RapidSettings(program_name="1bad")
