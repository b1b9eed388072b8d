"""The torch as robot programs state it, against the way the part grows (`torch_axis`). Each edit
below leaves every point where it was and turns the torch: before, each program passed "ok" (the
preflight read positions only). mpp-cross's programs in each robot dialect, one weld target edited
as a slip would: KUKA B -90 (torch up), the header's tool direction Z where the controller points
X along the torch, an ABB quaternion left at the identity, a Fanuc W typed 90, a Yaskawa Rx in
radians; a lean of 40° only warns."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set
from waamflow.preflight import run_preflight
from waamflow.preflight.check import _planar, program_layers
from waamflow.preflight.read import read_krl
from waamflow.preflight.torch import build_directions

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def _plan(fmt: str):
    g = build_graph(apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set([f"format={fmt}"])))
    return g, execute(g, resolver=FileResolver(GRAPHS), workers=1)


@pytest.fixture(scope="module", params=["krl", "rapid", "tp", "inform"])
def planned(request):
    return (request.param, *_plan(request.param))


# (what, file the edit goes to, edit, the angle it makes, degrees)
EDITS = {
    "krl": [
        (
            "B -90",
            "post.dat",
            lambda t: re.sub(r"(DECL E6POS P10=\{[^}]*)B 90\.0000", r"\1B -90.0000", t),
            180,
        ),
        ("tool direction Z", "post.src", lambda t: t.replace("tool direction X", "tool direction Z", 1), 90),
    ],
    "rapid": [
        (
            "identity",
            "post.mod",
            lambda t: t.replace(
                "p10 := [[3.000,-36.000,1.500],[0.000000,0.000000,1.000000,0.000000]",
                "p10 := [[3.000,-36.000,1.500],[1,0,0,0]",
            ),
            180,
        ),
    ],
    "tp": [
        (
            "W 90",
            "POST_L001.LS",
            lambda t: re.sub(r"(P\[10\]\{.*?W =)\s+180\.000", r"\1     90.000", t, count=1, flags=re.S),
            90,
        )
    ],
    "inform": [
        (
            "Rx rad",
            "POST_L003.JBI",
            lambda t: t.replace("C00010=-3.000,39.000,6.000,180.0000", "C00010=-3.000,39.000,6.000,3.1416"),
            176.9,
        )
    ],
}


def test_as_written_every_torch_points_down_the_build(planned):
    fmt, g, res = planned
    rep = run_preflight(g, res.outputs, res.artifacts)
    (prog,) = rep["programs"]
    assert prog["torch_angle_max_deg"] == pytest.approx(0.0, abs=0.01) and prog["torch_axis_unjudged_layers"] == 0
    assert not [p for p in rep["problems"] if p["check"] == "torch_axis"]


def test_each_turned_torch_fails_with_its_angle(planned):
    fmt, g, res = planned
    for what, name, edit, angle in EDITS[fmt]:
        text = res.artifacts[name].decode()
        assert edit(text) != text, (fmt, what)
        rep = run_preflight(g, res.outputs, {**res.artifacts, name: edit(text).encode()})
        (p,) = [p for p in rep["problems"] if p["check"] == "torch_axis"]
        assert p["severity"] == "fail" and rep["verdict"] == "fail", (fmt, what)
        assert p["value"] == pytest.approx(angle, abs=0.1), (fmt, what, p["value"])
        assert p["layer"] is not None and f"layer {p['layer']}:" in p["message"]


def test_a_lean_of_40_degrees_warns():
    g, res = _plan("krl")
    text = re.sub(r"(DECL E6POS P10=\{[^}]*)B 90\.0000", r"\1B 50.0000", res.artifacts["post.dat"].decode())
    arts = {**res.artifacts, "post.dat": text.encode()}
    rep = run_preflight(g, res.outputs, arts)
    (p,) = [p for p in rep["problems"] if p["check"] == "torch_axis"]
    assert p["severity"] == "warn" and p["value"] == pytest.approx(40.0, abs=0.01) and rep["verdict"] == "warn"


def test_a_fan_of_layers_grows_along_each_layers_normal():
    """curved-duct's KRL (the 90° bend in 1.54° wedge layers on the positioner's base): every torch
    along its layer's normal; the last layers' normals lie near horizontal (turned by the step from the
    layer before, not by up)."""
    rec = apply_overrides(load_recipe(GRAPHS / "curved-duct.json"), parse_set(["dtheta_deg=6"]))
    rec.nodes = [n for n in rec.nodes if n.type != "simulate-robot"]
    rec.edges = [e for e in rec.edges if not e.to.startswith("sim.")]
    g = build_graph(rec)
    res = execute(g, resolver=FileResolver(GRAPHS), workers=1)
    files = {k: v.decode() for k, v in res.artifacts.items() if k.endswith((".src", ".dat"))}
    prog = read_krl(files)
    layers = program_layers(prog)
    grow = build_directions(layers, _planar(layers), None)
    tilt = np.degrees(np.arccos(np.clip(grow[:, 2], -1, 1)))  # the k-th wedge layer lies 6° (k + 1) over
    assert np.isfinite(grow).all() and tilt == pytest.approx(6.0 * np.arange(1, len(layers) + 1), abs=0.01)
    rep = run_preflight(g, res.outputs, res.artifacts)
    assert rep["programs"][0]["torch_angle_max_deg"] == pytest.approx(0.0, abs=0.01)


def test_layers_on_one_line_grow_across_it():
    """Non-planar layers that each lie on one line (a wall of sloped passes, z rising 0.2 mm per mm
    of x, one above the other 1.5 mm apart): each grows along the step from the layer before, taken
    across its line, (-0.2, 0, 1) normalised; a layer whose points coincide is not judged."""
    from waamflow.preflight.read.core import Run

    def run(z0, xs=np.linspace(0.0, 50.0, 11)):
        pts = np.column_stack([xs, np.zeros_like(xs), z0 + 0.2 * xs])
        n = len(pts) - 1
        return Run(pts, np.full(n, 8.0), np.full(n, 3.0), np.ones(n, bool), 0, "w", 0)

    layers = [(k, [run(1.5 * (k + 1))]) for k in range(4)]
    grow = build_directions(layers, False, 1.5)
    assert grow == pytest.approx(np.tile(np.array([-0.2, 0.0, 1.0]) / np.hypot(0.2, 1.0), (4, 1)), abs=1e-9)
    spot = [*layers, (4, [run(7.5, np.zeros(3))])]
    assert np.isnan(build_directions(spot, False, 1.5)[4]).all()


@pytest.fixture(scope="module")
def helix_krl():
    g = build_graph(apply_overrides(load_recipe(GRAPHS / "thin-wall-panel.json"), parse_set(["post.format=krl"])))
    return g, execute(g, resolver=FileResolver(GRAPHS), workers=1)


def _tube_points(src: str) -> list[int]:
    """The KRL point numbers of thin-wall-panel's tube (section tube0), in program order."""
    body = src.split(";- section tube0", 1)[1].split(";- section", 1)[0]
    return [int(n) for n in re.findall(r"^LIN P(\d+)", body, flags=re.M)]


def _turn(dat: str, numbers: list[int], b: str) -> str:
    for n in numbers:
        dat = re.sub(rf"(DECL E6POS P{n}=\{{[^}}]*)B 90\.0000", rf"\g<1>B {b}", dat)
    return dat


def test_a_helix_grows_from_the_turn_below(helix_krl):
    """thin-wall-panel's tube: one helix of 15 turns in layer 0's run, so layer 0 is not flat (it
    was not judged at all: every torch of the tube could point up and the program passed "ok").
    Each target now grows from the turn below it (the first two turns, within a layer of the plate,
    from the plate): as written every torch lies within the helix's own slope of the build
    (atan(2 / (2π · 8)) = 2.3°; 2.9° with its arcs fitted to 0.05 mm, read back as the controller
    runs them), none left unjudged; the tube's torches from the 5th turn on turned up (B -90) fail
    at layer 0 with 180°; a lean of 40° on the 8th turn warns."""
    g, res = helix_krl
    rep = run_preflight(g, res.outputs, res.artifacts)
    (prog,) = rep["programs"]
    assert prog["torch_axis_unjudged_layers"] == 0 and not [n for n in prog["notes"] if "torch axis" in n]
    assert prog["torch_angle_max_deg"] == pytest.approx(2.3, abs=0.2)
    assert not [p for p in rep["problems"] if p["check"] == "torch_axis"]
    g2 = build_graph(
        apply_overrides(
            load_recipe(GRAPHS / "thin-wall-panel.json"), parse_set(["post.format=krl", "post.arc_tolerance=0.05"])
        )
    )
    res2 = execute(g2, resolver=FileResolver(GRAPHS), workers=1)
    (arcs,) = run_preflight(g2, res2.outputs, res2.artifacts)["programs"]
    assert "CIRC " in res2.artifacts["post.src"].decode()
    assert arcs["torch_angle_max_deg"] == pytest.approx(2.9, abs=0.2) and arcs["torch_axis_unjudged_layers"] == 0
    tube = _tube_points(res.artifacts["post.src"].decode())
    per_turn = len(tube) // 15
    assert len(tube) > 15 * 40
    dat = res.artifacts["post.dat"].decode()
    up = _turn(dat, tube[4 * per_turn :], "-90.0000")
    rep = run_preflight(g, res.outputs, {**res.artifacts, "post.dat": up.encode()})
    (p,) = [p for p in rep["problems"] if p["check"] == "torch_axis"]
    assert p["severity"] == "fail" and p["layer"] == 0 and p["value"] == pytest.approx(180.0, abs=2.5)
    assert p["point"][2] > 6.0  # on the turns edited, not the first ones
    lean = _turn(dat, tube[7 * per_turn : 8 * per_turn], "50.0000")
    rep = run_preflight(g, res.outputs, {**res.artifacts, "post.dat": lean.encode()})
    (p,) = [p for p in rep["problems"] if p["check"] == "torch_axis"]
    assert p["severity"] == "warn" and p["value"] == pytest.approx(40.0, abs=2.5)


def test_a_bead_beside_is_not_the_one_below():
    """Two wavy rings side by side in each layer (r 20 and 24 mm, z = 1.5 k + 1.4 (1 + sin 3θ):
    layers that are not flat), three layers: each target of layers 1 and 2 grows from its own ring's
    bead below, within the waves' slope of vertical (the 24 mm ring, laid after the 20 mm one 4 mm
    beside it, never from that one); layer 0 stands on the plate (+z)."""
    from waamflow.preflight.read.core import Run
    from waamflow.preflight.torch import local_directions

    th = np.linspace(0.0, 2 * np.pi, 241)
    runs = []
    for k in range(3):
        for r in (20.0, 24.0):
            pts = np.column_stack([r * np.cos(th), r * np.sin(th), 1.5 * k + 1.4 * (1.0 + np.sin(3 * th))])
            n = len(pts) - 1
            runs.append((k, Run(pts, np.full(n, 8.0), np.full(n, 3.0), np.ones(n, bool), k, f"r{r:g}", 0)))
    pts = np.vstack([r.points for _k, r in runs])
    own = np.repeat(np.arange(len(runs)), [len(r.points) for _k, r in runs])
    index = np.concatenate([np.arange(len(r.points)) for _k, r in runs])
    grow = local_directions(runs, pts, own, index, np.ones(len(pts), bool), 1.5)
    assert np.isfinite(grow).all()
    layer = np.array([k for k, _r in runs])[own]
    # the steepest wave: slope 1.4 · 3 / 20 along the inner ring, atan 0.21 = 11.9°
    tilt = np.degrees(np.arccos(np.clip(grow[:, 2], -1, 1)))
    assert 11.0 < tilt[layer > 0].max() < 12.0 and np.all(tilt[layer == 0] == 0.0)
    radial = np.einsum("ij,ij->i", grow[:, :2], pts[:, :2] / np.linalg.norm(pts[:, :2], axis=1)[:, None])
    assert np.abs(radial).max() < 0.01  # never across to the other ring (that were 0.94); the chords below: 0.003
