"""Motions the preflight cannot place, and frames changed after the program has moved, fail the
preflight instead of being skipped. Before, each passed "ok": RAPID `ArcL Offs(p10,0,0,20)` (a
20 mm raise mid-weld) and `RelTool(p10,0,0,-20)` were skipped with a note, a weld move in another
work object read in the first one's frame, KRL `LIN_REL {Z 20}` and a `$BASE` change mid-weld
ignored, a G-code work offset change (G55) or a G53 machine-coordinate move read as program
coordinates. RAPID `Offs(p, dx, dy, dz)` is placed (its offset added in the work object)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.preflight.test_preflight import BEAD, box_part, gcode, good_layers
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set
from waamflow.preflight import run_preflight
from waamflow.preflight.check import check_program
from waamflow.preflight.read import read_gcode, read_rapid
from waamflow.preflight.settings import PreflightSettings

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


@pytest.fixture(scope="module", params=["krl", "rapid"])
def planned(request):
    g = build_graph(apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set([f"format={request.param}"])))
    return request.param, g, execute(g, resolver=FileResolver(GRAPHS), workers=1)


EDITS = {
    "krl": [
        ("LIN_REL", lambda t: t.replace("LIN P10 C_DIS", "LIN_REL {Z 20} C_DIS", 1)),
        ("$BASE", lambda t: t.replace("LIN P10 C_DIS", "$BASE=BASE_DATA[2]\nLIN P10 C_DIS", 1)),
        ("BAS(#TOOL", lambda t: t.replace("LIN P10 C_DIS", "BAS(#TOOL,2)\nLIN P10 C_DIS", 1)),
    ],
    "rapid": [
        ("RelTool", lambda t: t.replace("ArcL p10,", "ArcL RelTool(p10,0,0,-20),")),
        ("wobj1", lambda t: re.sub(r"(ArcL p10,[^;]*)wobj0", r"\1wobj1", t)),
        ("CRobT", lambda t: t.replace("ArcL p10,", "ArcL CRobT(),")),
    ],
}


def test_each_unplaceable_edit_fails_naming_its_line(planned):
    fmt, g, res = planned
    programs = [k for k in res.artifacts if k.endswith((".src", ".mod"))]
    for what, edit in EDITS[fmt]:
        arts = {k: (edit(v.decode()).encode() if k in programs else v) for k, v in res.artifacts.items()}
        assert any(arts[k] != res.artifacts[k] for k in programs), (fmt, what)
        rep = run_preflight(g, res.outputs, arts)
        (p,) = [p for p in rep["problems"] if p["check"] == "unreadable"]
        assert p["severity"] == "fail" and rep["verdict"] == "fail", (fmt, what)
        assert what in p["message"] and "line" in p["message"], (fmt, what, p["message"])


def test_rapid_offs_is_placed_where_the_controller_goes():
    text = "\n".join(
        [
            "MODULE m",
            "  CONST robtarget p1 := [[0,0,1.5],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];",
            "  CONST robtarget p2 := [[30,0,1.5],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];",
            "  PERS welddata wd1 := [6,0,[0,0,0,2.4,0,91,0,0,0],[0,0,0,0,0,0,0,0,0]];",
            "  PROC main()",
            "    ArcLStart p1, v100, sm1, wd1, fine, tool0\\WObj:=wobj0;",
            "    ArcL Offs(p2, 0, 5, 20), v100, sm1, wd1, z1, tool0\\WObj:=wobj0;",
            "    ArcLEnd p2, v100, sm1, wd1, fine, tool0\\WObj:=wobj0;",
            "  ENDPROC",
            "ENDMODULE",
        ]
    )
    prog = read_rapid(text)
    assert not prog.unplaced and prog.runs[0].points.tolist() == [[0, 0, 1.5], [30, 5, 21.5], [30, 0, 1.5]]


@pytest.mark.parametrize(
    "what, edit",
    [
        ("G55", lambda t: t.replace("; layer 2", "G55\n; layer 2")),
        ("G53", lambda t: t.replace("M3\n", "M3\nG53 G1 Z100\n", 3)),  # with the arc on
        ("G10", lambda t: t.replace("; layer 2", "G10 L2 P1 Z5\n; layer 2")),
    ],
)
def test_gcode_frame_changes_after_moving_fail(what, edit):
    rep = check_program(box_part(), read_gcode(edit(gcode(good_layers()))), "post", PreflightSettings(), BEAD)
    (p,) = [p for p in rep["problems"] if p["check"] == "unreadable"]
    assert p["severity"] == "fail" and what in p["message"]
    # before the first motion a work offset is the program's own frame, and a G53 retract between
    # layers (arc off) is a travel the preflight does not follow: neither is a problem
    ok = gcode(good_layers()).replace("G21\nG90", "G21\nG90\nG54").replace("; layer 2", "G53 G0 Z100\n; layer 2")
    assert check_program(box_part(), read_gcode(ok), "post", PreflightSettings(), BEAD)["verdict"] == "ok"


@pytest.fixture(scope="module")
def tp_planned():
    g = build_graph(apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set(["format=tp"])))
    return g, execute(g, resolver=FileResolver(GRAPHS), workers=1)


@pytest.mark.parametrize(
    "what, edit",
    [
        ("Offset", lambda t: t.replace("L P[10] 8mm/sec CNT100", "L P[10] 8mm/sec CNT100 Offset,PR[1]")),
        (
            "UFRAME_NUM=2",
            lambda t: t.replace("L P[10] 8mm/sec CNT100    ;", "UFRAME_NUM=2 ;\\n  19:L P[10] 8mm/sec CNT100    ;"),
        ),
    ],
)
def test_fanuc_offsets_and_frame_changes_fail(tp_planned, what, edit):
    g, res = tp_planned
    assert run_preflight(g, res.outputs, res.artifacts)["verdict"] == "ok"  # UFRAME_NUM=1 in every file: no change
    progs = [k for k in res.artifacts if k.endswith(".LS")]
    arts = {k: (edit(v.decode()).encode() if k in progs else v) for k, v in res.artifacts.items()}
    assert any(arts[k] != res.artifacts[k] for k in progs)
    (p,) = [p for p in run_preflight(g, res.outputs, arts)["problems"] if p["check"] == "unreadable"]
    assert p["severity"] == "fail" and what.split("=")[0] in p["message"]
