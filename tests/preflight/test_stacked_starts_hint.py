"""The stacked-starts warning names the parameter that staggers the seams of what was planned. On
a tube's ring laps (a mesh sliced into rings) it named wall-path's `seam`, which only places the
ignitions of walls: following it changed nothing. `tubular: scattered` does."""

from __future__ import annotations

import json

import pytest
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


def _open_tube(tmp, name: str, r0: float, r1: float) -> str:
    """An open surface of revolution (no caps), radius r0 at z 0 to r1 at z 30: a vase wall as an
    STL of one surface (compas_slicer's simple_vase is one)."""
    import numpy as np

    a = np.linspace(0, 2 * np.pi, 97)[:-1]
    zs = np.linspace(0.0, 30.0, 11)
    rings = [
        np.column_stack([(r0 + (r1 - r0) * z / 30) * np.cos(a), (r0 + (r1 - r0) * z / 30) * np.sin(a), np.full(96, z)])
        for z in zs
    ]
    v = np.vstack(rings)
    f = []
    for k in range(len(zs) - 1):
        for i in range(96):
            j = (i + 1) % 96
            p, q, r, s = k * 96 + i, k * 96 + j, (k + 1) * 96 + j, (k + 1) * 96 + i
            f += [(p, q, r), (p, r, s)]
    trimesh.Trimesh(v, np.array(f), process=False).export(tmp / f"{name}.stl")
    rec = json.loads(open(_tube_recipe(tmp, None)).read())
    rec["nodes"][0]["params"] = {"path": f"{name}.stl", "as": "surface"}
    rec["nodes"].insert(2, {"id": "features", "type": "features", "params": {}})
    rec["edges"] += [
        {"from": "layers.layers", "to": "features.layers"},
        {"from": "features.features", "to": "walls.features"},
    ]
    path = tmp / f"{name}.json"
    path.write_text(json.dumps(rec))
    return str(path)


def test_helical_on_a_surface_whose_ring_changes_every_layer_is_said_and_laid_as_laps(tmp_path):
    """compas_slicer's simple_vase (an open surface, its ring smaller every layer) through the
    default wall-path: each layer's ring made a "helix" of its own, one lap labelled `helical`,
    every lap starting beside the one below (99 stacked starts) and the node said nothing. Now the
    laps are what `aligned` lays (closed with the `overlap`) and the node says so once; a tube of
    one ring all the way up stays one helix."""
    out = tmp_path / "out-cone"
    assert (
        main(["run", _open_tube(tmp_path, "cone", 40.0, 30.0), "--out", str(out), "--no-cache", "--accept-preflight"])
        == 0
    )
    summary = json.loads((out / "summary.json").read_text())
    (w,) = [w for w in summary["warnings"] if w.get("node") == "walls"]
    assert w["message"].startswith("`tubular: helical` is laid as aligned start-stop laps") and w["layer"] == 0
    doc = json.loads((out / "walls.toolpath.json").read_text())
    laps = [s for L in doc["layers"] for s in L["sections"]]
    assert len(laps) == 20 and {s["strategy"] for s in laps} == {"aligned"}
    import math

    r = 40.0 - 10.0 * 1.5 / 30  # layer 0's ring, at z 1.5
    assert laps[0]["length_mm"] == pytest.approx(2 * math.pi * r + 5.0, rel=0.01)  # a lap and its overlap
    out2 = tmp_path / "out-cyl"
    assert (
        main(["run", _open_tube(tmp_path, "cyl", 40.0, 40.0), "--out", str(out2), "--no-cache", "--accept-preflight"])
        == 0
    )
    doc2 = json.loads((out2 / "walls.toolpath.json").read_text())
    (helix,) = [s for L in doc2["layers"] for s in L["sections"]]
    assert helix["strategy"] == "helical" and helix["length_mm"] > 19 * 2 * math.pi * 39
