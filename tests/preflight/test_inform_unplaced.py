"""Yaskawa INFORM motions the preflight cannot place, and frames changed after the program has
moved, fail the preflight. Before, each passed "ok" (mpp-cross's INFORM jobs, one layer job edited
as a hand would): an incremental `IMOV`, a move to a position variable and a `MOVJ ... VJ=` were
skipped without a word (the run went straight past them), a move under a parallel shift (`SFTON`)
was read unshifted, a job declared in another user frame or tool, a C position in joint pulses
and a `MFRAME` of the user frame in use mid-program were read in the first job's frame."""

from __future__ import annotations

from pathlib import Path

import pytest

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set
from waamflow.preflight import run_preflight
from waamflow.preflight.read import read_inform

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"
JOB = "POST_L003.JBI"  # layer 3's job: the edits go there (layers 0-2 have moved the robot)
WELD = "MOVL C00010 V=8.0 PL=1"  # a weld move of its first section (after ARCON, before ARCOF)


@pytest.fixture(scope="module")
def planned():
    g = build_graph(apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set(["format=inform"])))
    return g, execute(g, resolver=FileResolver(GRAPHS), workers=1)


def _edited(res, edit):
    text = res.artifacts[JOB].decode()
    new = edit(text)
    assert new != text, "the edit matched nothing"
    return {**res.artifacts, JOB: new.encode()}


def test_as_written_passes_and_reads_every_weld(planned):
    g, res = planned
    rep = run_preflight(g, res.outputs, res.artifacts)
    # INFORM carries current and voltage, not the wire feed: the wire balance is a warning
    assert rep["verdict"] == "warn" and {p["check"] for p in rep["problems"]} == {"volume_ratio"}
    files = {k: v.decode() for k, v in res.artifacts.items() if k.endswith(".JBI")}
    prog = read_inform(files)
    assert not prog.unplaced and not prog.notes
    assert len(prog.runs) == 24  # 8 layers × 3 sections
    dep = sum(r.length for r in prog.runs)
    assert dep == pytest.approx(res.outputs["post"]["program"].stats["deposition_length_mm"], abs=0.01)


@pytest.mark.parametrize(
    "what, edit",
    [
        ("IMOV", lambda t: t.replace(WELD, "IMOV P000 V=8.0 PL=1 RF")),
        ("P001", lambda t: t.replace(WELD, "MOVL P001 V=8.0 PL=1")),
        ("SFTON", lambda t: t.replace(WELD, "SFTON P000 UF#(1)\n" + WELD + "\nSFTOF")),
        ("USER 2", lambda t: t.replace("///USER 1", "///USER 2")),
        ("TOOL 2", lambda t: t.replace(WELD, WELD + " TOOL#(2)")),
        ("MFRAME", lambda t: t.replace(WELD, "MFRAME UF#(1) P010 P011 P012\n" + WELD)),
        ("pulse", lambda t: t.replace("///POSTYPE USER", "///POSTYPE PULSE")),
    ],
)
def test_each_unplaceable_edit_fails_naming_the_job_and_line(planned, what, edit):
    g, res = planned
    rep = run_preflight(g, res.outputs, _edited(res, edit))
    (p,) = [p for p in rep["problems"] if p["check"] == "unreadable"]
    assert p["severity"] == "fail" and rep["verdict"] == "fail", what
    assert what in p["message"] and "POST_L003 line " in p["message"], p["message"]


def test_the_line_named_is_the_files_line(planned):
    _, res = planned
    files = {k: v.decode() for k, v in res.artifacts.items() if k.endswith(".JBI")}
    files[JOB] = files[JOB].replace(WELD, "IMOV P000 V=8.0 PL=1 RF")
    (msg,) = read_inform(files).unplaced
    k = int(msg.split("POST_L003 line ", 1)[1].split(":")[0])
    assert files[JOB].splitlines()[k - 1] == "IMOV P000 V=8.0 PL=1 RF"


def test_a_joint_move_with_the_arc_on_fails_weld_speed(planned):
    """`MOVJ C00010 VJ=50.00` with the arc on: before, the motion was dropped (the regex wanted
    V=) and the run went straight past it; now it is a weld at no tool speed."""
    g, res = planned
    rep = run_preflight(g, res.outputs, _edited(res, lambda t: t.replace(WELD, "MOVJ C00010 VJ=50.00")))
    fails = [p for p in rep["problems"] if p["severity"] == "fail"]
    assert rep["verdict"] == "fail" and {p["check"] for p in fails} == {"weld_speed"}
    assert fails[0]["layer"] == 3


def test_a_shift_with_the_arc_off_is_a_note_and_the_welds_are_read(planned):
    """SFTON … SFTOF around a travel only: the travel's end is unknown (a note), the next weld's
    start is an absolute C position again; nothing fails (the wire balance warns as unedited)."""
    g, res = planned
    travel = "MOVL C00001 V=100.0 PL=1"
    assert travel in res.artifacts[JOB].decode()
    arts = _edited(res, lambda t: t.replace(travel, "SFTON P000\n" + travel + "\nSFTOF"))
    files = {k: v.decode() for k, v in arts.items() if k.endswith(".JBI")}
    prog = read_inform(files)
    assert not prog.unplaced and len(prog.runs) == 24
    assert any("parallel shift" in n and "arc off" in n for n in prog.notes)
    rep = run_preflight(g, res.outputs, arts)
    assert rep["verdict"] == "warn" and {p["check"] for p in rep["problems"]} == {"volume_ratio"}
