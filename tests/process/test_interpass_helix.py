"""Interpass control cannot cool between the laps of a helix (one section welded through several
layers' heights in one go, e.g. thin-wall-panel's isolated tube): the node warns with the layer,
the section and how many laps, where it had planned dwells for the other layers and said nothing.
A rolling/peening treatment cannot reach a helix's lower laps: it had planned a stroke along the
whole helix from its first lap up, through the laps laid on it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.process.interpass import spanning_sections

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def _panel_with(node: dict) -> dict:
    rec = json.loads((GRAPHS / "thin-wall-panel.json").read_text())
    rec["nodes"].append(node)
    rec["edges"] = [e for e in rec["edges"] if e["to"] != "post.toolpath"] + [
        {"from": "sequence.toolpath", "to": f"{node['id']}.toolpath"},
        {"from": f"{node['id']}.toolpath", "to": "post.toolpath"},
    ]
    return rec


def test_a_helix_under_interpass_control_is_warned_with_its_layer_section_and_laps():
    heat = {"id": "heat", "type": "interpass", "params": {"interpass_c": 150, "bead_width": 4}}
    res = execute(build_graph(parse_recipe(_panel_with(heat))), resolver=FileResolver(GRAPHS), artifacts=False)
    tp = res.outputs["sequence"]["toolpath"]
    (span,) = spanning_sections(tp)
    assert span.layer == 0 and span.section == "tube0"
    assert span.laps == 15 and np.isclose(span.z_from, 2.0) and np.isclose(span.z_to, 30.0)
    (w,) = [w for w in res.warnings if w.get("node") == "heat"]
    assert w["layer"] == 0 and w["section"] == "tube0"
    assert "15 layers' heights" in w["message"] and "no dwell can cool between its laps" in w["message"]
    assert "tubular: aligned" in w["message"]


def test_layer_by_layer_sections_span_nothing():
    rec = json.loads((GRAPHS / "thin-wall-panel.json").read_text())
    for n in rec["nodes"]:
        if n["id"] == "walls":
            n["params"]["tubular"] = "scattered"
    rec.setdefault("inputs", {}).pop("tubular", None)
    res = execute(build_graph(parse_recipe(rec)), resolver=FileResolver(GRAPHS), artifacts=False)
    assert spanning_sections(res.outputs["sequence"]["toolpath"]) == []


def test_a_helix_is_not_rolled_the_other_walls_are():
    roll = {"id": "roll", "type": "treatment", "params": {"interleave": True}}
    res = execute(build_graph(parse_recipe(_panel_with(roll))), resolver=FileResolver(GRAPHS), artifacts=False)
    layer0 = res.outputs["roll"]["toolpath"].items[0]
    strokes = [sp for sp in layer0.sections if sp.strategy == "rolling"]
    assert strokes and not [sp for sp in strokes if sp.key.startswith("tube0/")]
    assert max(float(np.ptp(sp.points[:-1, 2])) for sp in strokes) < 1e-9  # every stroke on its layer's top
    row = res.outputs["roll"]["report"]["layers"][0]
    assert row["skipped_climbing"] == [{"section": "tube0", "laps": 15, "z_from": 2.0, "z_to": 30.0}]
    (w,) = [w for w in res.warnings if w.get("node") == "roll"]
    assert w["layer"] == 0 and w["section"] == "tube0" and "no rolling for it" in w["message"]


def test_a_helix_under_an_interlayer_dwell_is_warned():
    rec = json.loads((GRAPHS / "thin-wall-panel.json").read_text())
    next(n for n in rec["nodes"] if n["id"] == "sequence")["params"]["dwell"] = 30.0
    res = execute(build_graph(parse_recipe(rec)), resolver=FileResolver(GRAPHS), artifacts=False)
    (w,) = [w for w in res.warnings if w.get("node") == "sequence"]
    assert w["layer"] == 0 and w["section"] == "tube0"
    assert "the 30 s interlayer dwell comes after all its laps, none between them" in w["message"]
    quiet = json.loads((GRAPHS / "thin-wall-panel.json").read_text())  # no dwell asked: nothing to say
    res = execute(build_graph(parse_recipe(quiet)), resolver=FileResolver(GRAPHS), artifacts=False)
    assert [w for w in res.warnings if w.get("node") == "sequence"] == []
