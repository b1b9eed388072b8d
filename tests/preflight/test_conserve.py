"""Preflight `deposit_changed`: a sequence node welds, section by section, what it was given."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set
from waamflow.preflight.conserve import deposit_changes
from waamflow.preflight.read import read_toolpath
from waamflow.sequencing import seams
from waamflow.sequencing.arc_runs import arc_runs
from waamflow.zoning.zones import path_axis

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def doc(*sections, index=0):
    """A toolpath.json with one layer; sections: (key, points [(x, y)], arc flags)."""
    return {
        "layers": [
            {
                "index": index,
                "sections": [
                    {
                        "key": k,
                        "points": [[x, y, 2.0] for x, y in pts],
                        "arc": list(arc),
                        "speed": [5.0] * len(arc),
                        "zone": [""] * len(arc),
                    }
                    for k, pts, arc in sections
                ],
            }
        ]
    }


def test_reordered_reversed_and_short_run_fixes_pass_a_changed_length_does_not():
    wall = ("W", [(0, 0), (40, 0), (40, 30)], [True, True])  # 70 mm
    runs = ("R", [(0, 10), (20, 10), (21, 10), (30, 10)], [True, False, True])  # 20 + 9 mm, two runs
    before = read_toolpath(doc(wall, runs))
    same = read_toolpath(
        doc(
            ("R", [(30, 10), (21, 10), (20, 10), (0, 10)], [True, False, True]),
            ("W", [(40, 30), (40, 0), (0, 0)], [True, True]),
        )
    )
    assert deposit_changes(before, same) == []
    bridged = read_toolpath(doc(wall, ("R", [(0, 10), (20, 10), (21, 10), (30, 10)], [True, True, True])))
    assert deposit_changes(before, bridged) == []  # 30 mm in one run: the node's own fix
    cut = read_toolpath(doc(("W", [(0, 0), (40, 30)], [True]), runs))  # the corner cut: 50 mm
    assert deposit_changes(before, cut) == [{"layer": 0, "section": "W", "before_mm": 70.0, "after_mm": 50.0}]


def passes_before_the_fix(sp):
    """seams._passes as it was: runs along the axis, any link, passes merely opposite."""
    pts = np.asarray(sp.points, dtype=float)
    d = np.diff(pts, axis=0)
    along = np.abs(d @ path_axis(pts)) >= seams.PASS_COS * np.maximum(np.linalg.norm(d, axis=1), 1e-12)
    runs = arc_runs(along)
    if len(runs) < 2 or runs[0][0] != 0 or runs[-1][1] != len(along):
        return None
    for (a0, a1), (b0, b1) in zip(runs[:-1], runs[1:]):
        if float((pts[a1] - pts[a0]) @ (pts[b1] - pts[b0])) >= 0:
            return None
    return runs


def run_panel():
    r = apply_overrides(load_recipe(GRAPHS / "thin-wall-panel.json"), parse_set(["fillet_radius=3"]))
    return execute(build_graph(r), resolver=FileResolver(GRAPHS), workers=1)


def test_filleted_panel_preflight_is_ok_and_catches_the_lost_corner(monkeypatch):
    res = run_panel()
    assert res.preflight["verdict"] == "ok"
    assert not [p for p in res.preflight["problems"] if p["check"] == "deposit_changed"]
    monkeypatch.setattr(seams, "_passes", passes_before_the_fix)
    monkeypatch.setattr(seams, "WALL_PATH", frozenset())  # walls re-threaded like fills, as they were then
    res = run_panel()
    found = [p for p in res.preflight["problems"] if p["check"] == "deposit_changed"]
    assert res.preflight["verdict"] == "fail"
    assert [p["layer"] for p in found] == [1, 3, 5, 7, 9, 11, 13]
    # wall2 and wall6 (the two filleted L walls): 138.558 mm each instead of 114.986 on every odd layer
    # (1459.479 vs 1412.334 mm in the layer); read from the artifacts, coordinates to 1e-4 mm
    assert all(p["value"] == pytest.approx(47.1443, abs=1e-4) and p["node"] == "sequence" for p in found)
    assert "wall2, wall6" in found[0]["message"] or "wall6, wall2" in found[0]["message"]


def test_the_two_read_backs_of_a_node_are_two_tasks_with_the_same_problems():
    """With the run's workers, each of a sequence node's two toolpath.json is read back in its own
    task (`arc_on_of_doc`), so the two run side by side; the problems are the serial check's (a
    changed length found, the reordered layer passes)."""
    import json
    from concurrent.futures import Future
    from types import SimpleNamespace

    from waamflow.preflight.conserve import arc_on_of_doc, check_conservation, start_conservation

    wall = ("W", [(0, 0), (40, 0), (40, 30)], [True, True])
    before = {"layers": doc(wall)["layers"] + doc(wall, index=1)["layers"]}
    after = {"layers": doc(wall)["layers"] + doc(("W", [(0, 0), (40, 30)], [True]), index=1)["layers"]}
    artifacts = {"zone.toolpath.json": json.dumps(before).encode(), "seq.toolpath.json": json.dumps(after).encode()}
    graph = SimpleNamespace(
        order=["zone", "seq"],
        nodes={
            "zone": SimpleNamespace(type="zone", inputs={}),
            "seq": SimpleNamespace(type="sequence", inputs={"toolpath": ("zone", "toolpath")}),
        },
    )

    class Pool:
        def __init__(self):
            self.tasks = []

        def submit(self, fn, item):
            self.tasks.append((fn, item))
            fut = Future()
            fut.set_result(fn(item))
            return fut

    pool = Pool()
    got = start_conservation(graph, artifacts, "fail", pool)()
    assert [fn for fn, _ in pool.tasks] == [arc_on_of_doc, arc_on_of_doc]
    assert [item for _, item in pool.tasks] == [artifacts["zone.toolpath.json"], artifacts["seq.toolpath.json"]]
    assert got == check_conservation(graph, artifacts, "fail")
    assert len(got) == 1 and got[0]["layer"] == 1 and got[0]["section"] == "W"
    assert got[0]["value"] == pytest.approx(-20.0, abs=1e-6)  # 50 mm welded where 70 were planned
    # the document the preflight reads back itself is summed from that read: not sent, not parsed again
    from waamflow.preflight.conserve import arc_on_by_section
    from waamflow.preflight.read import read_toolpath

    pool = Pool()
    finish = start_conservation(graph, artifacts, "fail", pool, frozenset(["seq.toolpath.json"]))
    assert [item for _, item in pool.tasks] == [artifacts["zone.toolpath.json"]]
    own = arc_on_by_section(read_toolpath(json.loads(artifacts["seq.toolpath.json"])))
    assert finish({"seq.toolpath.json": own}) == got
    # not handed its sums after all (the preflight read something else): read here, the same problems
    assert start_conservation(graph, artifacts, "fail", Pool(), frozenset(["seq.toolpath.json"]))() == got
