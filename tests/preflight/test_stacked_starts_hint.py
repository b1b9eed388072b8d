"""The stacked-starts warning names the parameter that staggers the seams of what was planned. On
a tube's ring laps (a mesh sliced into rings) it named wall-path's `seam`, which only places the
ignitions of walls: following it changed nothing. `tubular: scattered` does."""

from __future__ import annotations

import json

import trimesh

from waamflow.cli import main


def _tube_recipe(tmp, tubular: str | None) -> str:
    m = trimesh.creation.annulus(r_min=34.0, r_max=40.0, height=30.0, sections=64)
    m.apply_translation((0.0, 0.0, 15.0))
    m.export(tmp / "tube.stl")
    walls = {"speed": 10.0, "spacing": 1.0, "overlap": 5.0, "bead_width": 6.0}
    if tubular:
        walls["tubular"] = tubular
    rec = {
        "format": "waamflow/1",
        "name": "tube",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "tube.stl"}},
            {"id": "layers", "type": "slice", "params": {"layer_height": 1.5}},
            {"id": "walls", "type": "wall-path", "params": walls},
            {"id": "post", "type": "post-process", "params": {"weld_values": {"wire_feed_speed": 5.0}}},
        ],
        "edges": [
            {"from": "part.mesh", "to": "layers.mesh"},
            {"from": "layers.layers", "to": "walls.layers"},
            {"from": "walls.toolpath", "to": "post.toolpath"},
        ],
    }
    path = tmp / f"tube-{tubular}.json"
    path.write_text(json.dumps(rec))
    return str(path)


def _stacked(tmp, tubular):
    out = tmp / f"out-{tubular}"
    assert main(["run", _tube_recipe(tmp, tubular), "--out", str(out), "--no-cache", "--accept-preflight"]) == 0
    rep = json.loads((out / "preflight.json").read_text())
    return [p for p in rep["problems"] if p["check"] == "stacked_starts"], rep


def _node_warnings(tmp, tubular) -> list[dict]:
    summary = json.loads((tmp / f"out-{tubular}" / "summary.json").read_text())
    return [w for w in summary["warnings"] if w.get("node") == "walls"]


def test_the_hint_on_a_tubes_stacked_starts_is_the_parameter_that_staggers_them(tmp_path):
    (p,), _ = _stacked(tmp_path, None)  # rings: the default `helical` laps them with aligned seams
    assert p["severity"] == "warn" and p["layer"] == 1 and p["value"] < 6.0
    assert "`tubular: scattered` on rings and tubes" in p["message"]
    assert p["message"].startswith("19 ignitions")  # every layer's on the one below (20 layers)
    stacked, rep = _stacked(tmp_path, "scattered")
    assert stacked == [] and rep["verdict"] == "ok"
    assert rep["programs"][0]["start_spread_mm"] > 6.0


def test_helical_asked_aligned_laid_on_rings_is_said_once(tmp_path, capsys):
    """Rings (each layer its own centre line) are not laid as one helix: the default `helical`
    gave aligned laps without a word; now the node says so once, and `aligned` asked is quiet."""
    _stacked(tmp_path, None)
    assert ", 1 warning, preflight warn," in capsys.readouterr().out  # not "1 warnings"
    (w,) = _node_warnings(tmp_path, None)
    assert w["message"].startswith("`tubular: helical` is laid as aligned start-stop laps on ring layers")
    assert w["layer"] == 0
    (_p,), _rep = _stacked(tmp_path, "aligned")  # the same laps, asked for: the preflight's warning only
    assert _node_warnings(tmp_path, "aligned") == []
