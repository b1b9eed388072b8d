"""graphs/bracket.json: the real-size bracket (300 x 90 x 450 mm, 300 layers) planned mesh → program.

The whole part runs in test_recipes; here a layer limit keeps it quick while still passing the
window that opens at layer 100 and closes after layer 219.
"""

import json
import re
from collections import Counter
from pathlib import Path

import pytest
import trimesh

from waamflow.cli import main

GRAPHS = Path(__file__).resolve().parents[1] / "graphs"


def test_bracket_part_is_the_documented_solid():
    m = trimesh.load(GRAPHS / "parts" / "bracket.stl")
    assert m.is_watertight
    assert m.bounds.tolist() == [[0, 0, 0], [300, 90, 450]]
    # foot 300·90·30 + web 300·20·420 − diamond window (2·90²)·20
    assert m.volume == pytest.approx(810_000 + 2_520_000 - 324_000, rel=1e-9)
    assert (GRAPHS / "parts" / "bracket.stl").stat().st_size <= 3 * 1024 * 1024


def _run(tmp_path, monkeypatch, layers):
    monkeypatch.setenv("WAAMFLOW_CACHE", str(tmp_path / "cache"))
    out = tmp_path / f"out{layers}"
    # the first N layers of a 300-layer part: the preflight fails the program (it stops below the
    # top), so the quick look accepts it; the failure must name the gap
    assert (
        main(
            [
                "run",
                str(GRAPHS / "bracket.json"),
                "--out",
                str(out),
                "--set",
                f"layers.layer_count={layers}",
                "--accept-preflight",
            ]
        )
        == 0
    )
    pf = json.loads((out / "preflight.json").read_text())
    assert pf["verdict"] == "fail" and pf["accepted"] is True
    assert pf["top_gap_mm"] == pytest.approx(450.0 - 1.5 * layers, abs=1e-6)
    return out


def test_bracket_sections_follow_the_masks_up_the_part(tmp_path, monkeypatch):
    out = _run(tmp_path, monkeypatch, 230)
    layers = json.loads((out / "strategy.toolpath.json").read_text())["layers"]
    assert len(layers) == 230 and layers[-1]["z"] == pytest.approx(345.0)
    keys = [tuple(s["key"] for s in L["sections"]) for L in layers]
    assert Counter(keys) == {("foot/plate",): 20, ("web/W",): 80, ("window/L", "window/R"): 120, ("top/W",): 10}
    assert keys[19] == ("foot/plate",) and keys[20] == ("web/W",)
    assert keys[99] == ("web/W",) and keys[100] == ("window/L", "window/R")  # the window opens
    assert keys[219] == ("window/L", "window/R") and keys[220] == ("top/W",)  # and closes
    for i in (100, 130, 160, 219):
        half = 90.0 - abs(1.5 * i + 0.75 - 240.0)  # the diamond's half-width at the layer's cut plane
        left, right = layers[i]["sections"]
        assert max(p[0] for p in left["points"]) == pytest.approx(150.0 - half, abs=1e-6)
        assert min(p[0] for p in right["points"]) == pytest.approx(150.0 + half, abs=1e-6)
    # the plate is 18 passes across 90 mm, the web 4 passes across 20 mm (6 mm bead, 5 mm spacing)
    assert len(layers[0]["sections"][0]["points"]) == 36
    assert len(layers[50]["sections"][0]["points"]) == 8
    gcode = (out / "post.gcode").read_text()
    assert gcode.count("; layer ") == 230
    assert gcode.count("M3 ; arc on") == 20 + 80 + 2 * 120 + 10


def test_bracket_quick_look_program(tmp_path, monkeypatch):
    out = _run(tmp_path, monkeypatch, 12)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "done" and summary["layer_count"] == 12
    gcode = (out / "post.gcode").read_text()
    head = re.search(r"; summary: layers (\d+), sections (\d+), points (\d+), deposition ([\d.]+) mm", gcode)
    assert head and (int(head[1]), int(head[2])) == (12, 12)
    # 18 passes of 300 mm joined by 17 steps of 5 mm per layer
    assert float(head[4]) == pytest.approx(12 * (18 * 300 + 17 * 5), rel=1e-9)
    assert gcode.count("\nG1 ") == 12 * (
        36 - 1 + 2
    )  # per layer: a G0 to the first of 36 points, then G1s with the start/end zone splits
