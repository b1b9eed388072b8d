"""The preflight's new checks on programs of every robot dialect as our posts write them, each
edited the way a hand or a bug would (mpp-cross as shipped, read back from the edited files):
a weld begun at the travel's speed, a point raised or lowered mid-weld, a joint move with the arc
on. Each passed the preflight ("ok" or warnings only) before bottom/plate, z_jump, weld_speed and
local_deposit; unedited, each program still passes."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set
from waamflow.preflight import run_preflight

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


@pytest.fixture(scope="module", params=["krl", "rapid", "tp", "csv"])
def planned(request):
    g = build_graph(apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set([f"format={request.param}"])))
    return request.param, g, execute(g, resolver=FileResolver(GRAPHS), workers=1)


def _csv_fast(text: str) -> str:
    """Three arc-ON rows of layer 2 at 100 mm/s (speed column 6, arc 7, layer 8)."""
    out, n = [], 0
    for ln in text.splitlines():
        cols = ln.split(",")
        if len(cols) > 8 and cols[7] == "1" and cols[8] == "2" and n < 3:
            cols[6], n = "100", n + 1
        out.append(",".join(cols))
    return "\n".join(out)


EDITS = {
    "krl": [
        ("weld_speed", lambda t: t.replace("LIN P10 C_DIS", "PTP P10 C_DIS", 1)),
        ("local_deposit", lambda t: t.replace("$VEL.CP=0.006000 ; 6 mm/s\n", "", 1)),
        ("z_jump", lambda t: re.sub(r"(DECL E6POS P10=\{X [-\d.]+,Y [-\d.]+,Z )([-\d.]+)", r"\g<1>21.500", t)),
    ],
    "rapid": [
        ("local_deposit", lambda t: re.sub(r"(welddata wd1 := \[)6,", r"\g<1>100,", t)),
        ("z_jump", lambda t: t.replace("p10 := [[3.000,-36.000,1.500]", "p10 := [[3.000,-36.000,21.500]")),
        ("plate", lambda t: t.replace("p10 := [[3.000,-36.000,1.500]", "p10 := [[3.000,-36.000,-1.500]")),
    ],
    "tp": [
        ("local_deposit", lambda t: re.sub(r"L P\[(1[0-2])\] 8mm/sec", r"L P[\1] 100mm/sec", t)),
    ],
    "csv": [("local_deposit", _csv_fast)],
}


def test_each_edit_fails_its_check_and_the_program_as_written_passes(planned):
    fmt, g, res = planned
    assert run_preflight(g, res.outputs, res.artifacts)["verdict"] == "ok"
    programs = [k for k in res.artifacts if not k.endswith((".json", ".xml"))]
    for check, edit in EDITS[fmt]:
        arts = {k: (edit(v.decode()).encode() if k in programs else v) for k, v in res.artifacts.items()}
        assert any(arts[k] != res.artifacts[k] for k in programs), f"{fmt}: the edit for {check} matched nothing"
        rep = run_preflight(g, res.outputs, arts)
        fails = {p["check"] for p in rep["problems"] if p["severity"] == "fail"}
        assert rep["verdict"] == "fail" and check in fails, (fmt, check, rep["problems"])
