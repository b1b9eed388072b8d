"""A top gap whose layers the plan has but welds nothing says so. compas_slicer's bunny (low res,
2 mm layers): its top layer is a 9.7 mm² ear tip, whose one 5.5 mm run the sequence drops as
shorter than min_arc_run_mm; the preflight failed "the deposit ends 2.00 mm short of the part's top
(200.00 mm); the last deposited layer is 98: add layers (slice `top: ceil`) or check for skipped
layers" — adding layers cannot help there."""

import json

import trimesh

from waamflow.cli import main

from tests.preflight.solid_recipe import solid_recipe


def _recipe(tmp) -> str:
    body = trimesh.creation.box((40, 40, 10))
    body.apply_translation((0, 0, 5))
    pin = trimesh.creation.box((3, 3, 2))  # the part's top: one 2 mm layer, narrower than a bead
    pin.apply_translation((0, 0, 11))
    trimesh.util.concatenate([body, pin]).export(tmp / "pin.stl")
    return solid_recipe(tmp, "pin", "pin.stl", {"pattern": "contour", "bead_width": 5})


def test_a_planned_top_layer_that_welds_nothing_is_named(tmp_path):
    out = tmp_path / "out"
    assert main(["run", _recipe(tmp_path), "--out", str(out), "--no-cache"]) == 4
    rep = json.loads((out / "preflight.json").read_text())
    (gap,) = [p for p in rep["problems"] if p["check"] == "top_gap"]
    assert gap["layer"] == 4 and rep["top_gap_mm"] == 2.0
    msg = gap["message"]
    assert "the plan has layer 5 above it, which welds nothing" in msg
    assert "min_arc_run_mm" in msg and "add layers" not in msg
    summary = json.loads((out / "summary.json").read_text())
    assert summary["nodes"]["sequence"]["report"]["short_runs_dropped"] >= 1


def test_a_planned_bottom_layer_that_welds_nothing_is_named(tmp_path):
    """3MF Consortium's heartgears.3mf: the heart's bottom tip (11 mm², layer 0) welded nothing and
    the preflight said "slice from the part's bottom (clear the slice's `z_min`)", which the slice
    already did."""
    pin = trimesh.creation.box((3, 3, 2))  # the part's bottom: one 2 mm layer, narrower than a bead
    pin.apply_translation((0, 0, 1))
    body = trimesh.creation.box((40, 40, 10))
    body.apply_translation((0, 0, 7))
    trimesh.util.concatenate([pin, body]).export(tmp_path / "foot.stl")
    path = solid_recipe(tmp_path, "foot", "foot.stl", {"pattern": "contour", "bead_width": 5})
    out = tmp_path / "out"
    assert main(["run", path, "--out", str(out), "--no-cache"]) == 4
    rep = json.loads((out / "preflight.json").read_text())
    (gap,) = [p for p in rep["problems"] if p["check"] == "bottom_gap"]
    assert gap["layer"] == 1 and rep["bottom_gap_mm"] == 2.0
    assert "the plan has layer 0 below it, which welds nothing" in gap["message"]
    assert "z_min" not in gap["message"]
