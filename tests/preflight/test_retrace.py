"""The same stretch welded twice within one layer (`retrace`). A program that welds a layer's run
twice at one height — a section sent twice, or a layer block copied with its `layer N` comment —
passed: grouped into one layer, both passes hold that layer's coverage and order, and the wire
balance only warns. Runs that cross, touch or lie side by side at a normal step-over pass."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from tests.preflight.test_preflight import BEAD, YS, box_part, gcode, good_layers, passes
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set
from waamflow.preflight import run_preflight
from waamflow.preflight.check import check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.read.core import Run
from waamflow.preflight.retrace import _layer_retrace
from waamflow.preflight.settings import PreflightSettings

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def _check(text: str, **kw) -> dict:
    return check_program(box_part(), read_gcode(text), "post", PreflightSettings(**kw), BEAD)


def _retrace(rep: dict) -> list[dict]:
    return [p for p in rep["problems"] if p["check"] == "retrace"]


def _twice(reverse: bool = False) -> list:
    """good_layers with layer 2's run welded a second time at its height (one layer: same z)."""
    L = good_layers()
    z, (run,) = L[2]
    return [*L[:2], (z, [run, run[::-1] if reverse else run]), L[3]]


@pytest.mark.parametrize("reverse", [False, True])
def test_a_run_welded_twice_in_its_layer_fails(reverse):
    rep = _check(gcode(_twice(reverse)))
    (p,) = _retrace(rep)
    assert p["severity"] == "fail" and rep["verdict"] == "fail" and p["layer"] == 2
    assert p["value"] == pytest.approx(1.0, abs=0.02) and p["limit"] == 0.5  # all of its 167 mm
    assert "167.0 mm" in p["message"] and "section s1" in p["message"]
    assert rep["retrace_share"] == pytest.approx(1.0, abs=0.02)
    assert _retrace(_check(gcode(_twice(reverse)), retrace="warn"))[0]["severity"] == "warn"
    assert not _retrace(_check(gcode(_twice(reverse)), retrace="off"))


def test_without_layer_comments_too():
    text = "\n".join(ln for ln in gcode(_twice()).splitlines() if not ln.startswith("; layer"))
    (p,) = _retrace(_check(text))
    assert p["severity"] == "fail" and p["value"] == pytest.approx(1.0, abs=0.02)


def test_crossings_neighbours_a_step_over_pass_and_shares():
    w = BEAD
    along = np.array([[-40.0, 0, 0], [40.0, 0, 0]])

    def run(pts):
        pts = np.asarray(pts, float)
        n = len(pts) - 1
        return Run(pts, np.full(n, 8.0), np.full(n, 3.0), np.ones(n, bool), 0, "s", 0)

    def share(other) -> float:
        found = _layer_retrace([run(along), run(other)], w)
        return 0.0 if found is None else found[0]

    for deg in (90, 45, 20):  # a crossing retraces nothing: the beads do not run together
        t = np.radians(deg)
        assert share([[-40 * np.cos(t), -40 * np.sin(t), 0], [40 * np.cos(t), 40 * np.sin(t), 0]]) == 0.0
    assert share([[-40, 0.5 * w, 0], [40, 0.5 * w, 0]]) == 0.0  # a neighbour at half a bead's step-over
    assert share([[-40, 0.3 * w, 0], [40, 0.3 * w, 0]]) == pytest.approx(1.0)  # 70 % overlap: the same bead
    assert share([[-40, 0, 3.0], [40, 0, 3.0]]) == 0.0  # 3 mm higher (sampled in 3D)
    # part of a run on the first: by its share, 50 of 90 mm (0.56) or 40 of 90 (0.44)
    assert share([[-40, 0, 0], [10, 0, 0], [10, -40, 0]]) == pytest.approx(50 / 90, abs=1e-9)
    assert share([[-40, 0, 0], [0, 0, 0], [0, -50, 0]]) == pytest.approx(40 / 90, abs=1e-9)
    assert share([[40, 0, 0], [30, 0, 0], [30, 30, 0]]) == pytest.approx(10 / 40, abs=1e-9)  # a back-step start
    # a stretch ends where the run leaves the other's bead: 25 mm along, then 12.5 mm off to the side
    assert share([[-40, 0, 0], [-15, 0, 0], [-15, 12.5, 0], [40, 12.5, 0]]) == pytest.approx(25 / 92.5, abs=1e-9)


def test_shipped_mpp_cross_in_gcode_passes_and_a_copied_layer_block_fails():
    """mpp-cross as shipped (an oscillated section crossed by the parallel ones' U-turns):
    retrace_share 0. Layer 3's block pasted a second time after itself, its `layer 3` comment and
    all: layer_order does not see it (one layer 3), retrace does."""
    g = build_graph(apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set([])))
    res = execute(g, resolver=FileResolver(GRAPHS), workers=1)
    rep = run_preflight(g, res.outputs, res.artifacts)
    assert rep["verdict"] == "ok" and rep["programs"][0]["retrace_share"] == 0.0
    (name,) = [k for k in res.artifacts if k.endswith(".gcode")]
    text = res.artifacts[name].decode()
    block = re.search(r"^; layer 3 .*?(?=^; layer 4 )", text, re.DOTALL | re.MULTILINE)
    assert block is not None
    arts = {**res.artifacts, name: text.replace(block.group(0), block.group(0) * 2).encode()}
    rep = run_preflight(g, res.outputs, arts)
    (p,) = [p for p in rep["problems"] if p["check"] == "retrace"]
    assert p["severity"] == "fail" and p["layer"] == 3 and p["value"] > 0.9
    assert not [p for p in rep["problems"] if p["check"] == "layer_order"]


def test_each_pass_of_the_shipped_boustrophedon_is_its_own_ground():
    """good_layers: one run a layer, no retrace; YS passes 5 mm apart in one run are not compared."""
    rep = _check(gcode(good_layers()))
    assert rep["retrace_share"] == 0.0 and not _retrace(rep)
    two = [(z, [passes(YS[:2]), passes(YS[2:])]) for z, _ in good_layers()]  # two runs side by side
    assert _check(gcode(two))["retrace_share"] == 0.0


def test_many_walls_a_layer_and_layers_apart():
    """40 walls a bead apart in one layer (the search without the box filter) and one of them sent
    twice; the same walls a layer higher (1.5 mm, closer than the search's reach) are not compared
    with the layer below."""
    from waamflow.preflight.retrace import _retraced_runs

    def wall(y, z=0.0):
        return Run(
            np.array([[-50.0, y, z], [50.0, y, z]]), np.full(1, 8.0), np.full(1, 3.0), np.ones(1, bool), 0, "w", 0
        )

    walls = [wall(BEAD * k) for k in range(40)]
    assert _retraced_runs([(0, walls)], BEAD) == []
    ((share, length, li, run, _pt),) = _retraced_runs([(0, [*walls, wall(BEAD * 20)])], BEAD)
    assert share == pytest.approx(1.0) and length == pytest.approx(100.0) and li == 0 and run is not walls[20]
    upper = [wall(BEAD * k, 1.5) for k in range(40)]
    assert _retraced_runs([(0, walls), (1, upper)], BEAD) == []


def test_a_thin_solid_read_as_a_surface_is_named_as_a_cause(tmp_path):
    """pythonocc-demos' Ventilator.stp read as a surface: a blade's two faces lie closer than a bead
    width, wall-path laid a wall on each, and the retrace message blamed 'a section or layer sent
    twice (the sequence, or a program edited by hand)'. It names that cause too: a blade's two faces
    1.5 mm apart get two walls 1.5 mm apart, which fail with it."""
    import sys

    import trimesh

    from waamflow.cli import main

    def quad(a, b, c, d):
        return [a, b, c, a, c, d]

    # a blade's two faces 1.5 mm apart, open at its edges (a surface model's patches)
    v = np.array(
        quad((0, 0, 0), (60, 0, 0), (60, 0, 20), (0, 0, 20))
        + quad((0, 1.5, 0), (60, 1.5, 0), (60, 1.5, 20), (0, 1.5, 20)),
        float,
    )
    trimesh.Trimesh(v, np.arange(len(v)).reshape(-1, 3)).export(tmp_path / "plate.stl")
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
    from bench_vase import _recipe

    import json

    rec = _recipe()
    rec["nodes"][0]["params"].update({"path": "plate.stl", "as": "surface"})
    rec["nodes"][1]["params"].update({"layer_height": 2.0})
    (tmp_path / "plate.json").write_text(json.dumps(rec))
    out = tmp_path / "out"
    assert main(["run", str(tmp_path / "plate.json"), "--out", str(out), "--no-cache"]) == 4
    rep = json.loads((out / "preflight.json").read_text())
    (p,) = [p for p in rep["problems"] if p["check"] == "retrace"]
    assert "two walls of the part closer than a bead width" in p["message"] and "read it as a solid" in p["message"]
