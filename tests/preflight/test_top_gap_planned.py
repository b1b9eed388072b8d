"""A top gap whose layers the plan has but welds nothing says so. compas_slicer's bunny (low res,
2 mm layers): its top layer is a 9.7 mm² ear tip, whose one 5.5 mm run the sequence drops as
shorter than min_arc_run_mm; the preflight failed "the deposit ends 2.00 mm short of the part's top
(200.00 mm); the last deposited layer is 98: add layers (slice `top: ceil`) or check for skipped
layers" — adding layers cannot help there."""

import json

import trimesh

from waamflow.cli import main


def _recipe(tmp) -> str:
    body = trimesh.creation.box((40, 40, 10))
    body.apply_translation((0, 0, 5))
    pin = trimesh.creation.box((3, 3, 2))  # the part's top: one 2 mm layer, narrower than a bead
    pin.apply_translation((0, 0, 11))
    trimesh.util.concatenate([body, pin]).export(tmp / "pin.stl")
    rec = {
        "format": "waamflow/1",
        "name": "pin",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "pin.stl"}},
            {"id": "layers", "type": "slice", "params": {"layer_height": 2.0}},
            {"id": "mask", "type": "mask", "params": {}},
            {"id": "strategy", "type": "strategy", "params": {"default": {"pattern": "contour", "bead_width": 5}}},
            {"id": "sequence", "type": "sequence", "params": {"order": "nearest", "retract_height": 5}},
            {"id": "post", "type": "post-process", "params": {"weld_values": {"wire_feed_speed": 4}}},
        ],
        "edges": [
            {"from": "part.mesh", "to": "layers.mesh"},
            {"from": "layers.layers", "to": "mask.layers"},
            {"from": "mask.sections", "to": "strategy.sections"},
            {"from": "strategy.toolpath", "to": "sequence.toolpath"},
            {"from": "sequence.toolpath", "to": "post.toolpath"},
        ],
    }
    (tmp / "pin.json").write_text(json.dumps(rec))
    return str(tmp / "pin.json")


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
