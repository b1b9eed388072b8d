"""Travel moves (arc off) through metal welded before them (`travel_collision`). A machine
profile's end code parking the torch at the origin 5 mm up (`G0 X0 Y0 Z5`, after mpp-cross's last
layer at z 12 whose cross stands there) and towers built one after the other with a straight move
from the top of one to the foot of the next passed "ok": travels were only checked against the
plate. A hop at the height of the layer just welded, and lifts as our posts write them, pass."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.preflight.test_preflight import BEAD, LAYER, YS, box_part, gcode, good_layers, passes
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set
from waamflow.preflight import run_preflight
from waamflow.preflight.check import check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def _check(text: str, **kw) -> dict:
    return check_program(box_part(), read_gcode(text), "post", PreflightSettings(**kw), BEAD)


def _travel(rep: dict) -> list[dict]:
    return [p for p in rep["problems"] if p["check"] == "travel_collision"]


def _cross(*sets: str):
    g = build_graph(apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set(list(sets))))
    res = execute(g, resolver=FileResolver(GRAPHS), workers=1, preflight=False)
    return run_preflight(g, res.outputs, res.artifacts)


@pytest.mark.parametrize(
    "sets, depth",
    [
        (['post.end_code=["G0 X0 Y0 Z5"]'], 7.0),  # from the last point (60, -3, 12) straight to the park
        (["post.final_lift=50", 'post.end_code=["G0 X0 Y0 Z5"]'], 7.0),  # up 50 first, then down into it
    ],
)
def test_a_park_move_into_the_part_fails(sets, depth):
    rep = _cross(*sets)
    (p,) = _travel(rep)
    assert p["severity"] == "fail" and rep["verdict"] == "fail"
    assert p["value"] == pytest.approx(depth, abs=0.01) and p["point"] == [0.0, 0.0, 5.0]
    assert p["layer"] == 7 and p["section"] == "bs1/C" and "after layer 7" in p["message"]
    assert rep["programs"][0]["travel_collisions"] == 1


def test_lifts_as_written_and_a_park_above_the_part_pass():
    rep = _cross()
    assert rep["verdict"] == "ok" and rep["programs"][0].get("travel_collisions", 0) == 0
    rep = _cross("post.final_lift=50", 'post.end_code=["G0 X0 Y0 Z80"]')
    assert rep["verdict"] == "ok" and not _travel(rep)


def _towers(lift: bool) -> str:
    left = [((i + 1) * LAYER, [passes(YS, x0=-19, x1=-3)]) for i in range(4)]
    right = [((i + 1) * LAYER, [passes(YS, x0=3, x1=19)]) for i in range(4)]
    text = gcode(left + right)
    if lift:  # up to 20 over the left tower's last point, across at 20, then down onto the right one's start
        first = f"G0 X3.000 Y{YS[0]:.3f} Z{LAYER:.3f}"
        assert text.count(first) == 1
        text = text.replace(first, f"G0 Z20.000\nG0 X3.000 Y{YS[0]:.3f} Z20.000\n{first}")
    return text


def test_towers_one_after_the_other_need_a_lift_between():
    rep = _check(_towers(lift=False))
    (p,) = _travel(rep)
    # from the left tower's top (-19, 7.5, 6) straight to the right one's foot (3, -7.5, 1.5): in the left
    # tower's metal until half a bead past its last link (x = -3): x = 0, z 2.11, 3.89 mm below its top;
    # the last sample in it (every quarter bead along the move: 0.25 mm of drop) 3.64-3.89
    assert p["severity"] == "fail" and p["layer"] == 3 and 3.64 <= p["value"] <= 3.89
    assert -19 <= p["point"][0] <= 0
    assert not _travel(_check(_towers(lift=True)))
    assert _travel(_check(_towers(lift=False), travel_collision="warn"))[0]["severity"] == "warn"
    assert not _travel(_check(_towers(lift=False), travel_collision="off"))


def test_a_hop_at_the_height_just_welded_passes():
    """Two runs a layer, the travel between them at the layer's height over the first one's metal."""
    two = [(z, [passes(YS[:2]), passes(YS[2:])]) for z, _ in good_layers()]
    rep = _check(gcode(two))
    assert rep["travel_collisions"] == 0 and not _travel(rep)


@pytest.fixture(scope="module")
def duct_krl():
    """curved-duct posted to KRL (without its simulation)."""
    rec = apply_overrides(load_recipe(GRAPHS / "curved-duct.json"), parse_set(["post.format=krl"]))
    rec.nodes = [n for n in rec.nodes if n.type != "simulate-robot"]
    rec.edges = [e for e in rec.edges if not e.to.startswith("sim.")]
    g = build_graph(rec)
    return g, execute(g, resolver=FileResolver(GRAPHS), workers=1, preflight=False)


def test_a_travel_back_down_a_fan_of_layers_fails(duct_krl):
    """curved-duct's KRL (wedge layers about the bend: each grows along its own normal, not up): as
    written its travels pass (0 in the metal); a move from layer 10's end back to layer 6's start
    and on to layer 11's crosses the four layers between, and fails at layer 10 with a depth of
    more than half a layer along the build direction. Programs whose layers are not horizontal
    planes had their travels unchecked: this passed "ok"."""
    import re

    g, res = duct_krl
    rep = run_preflight(g, res.outputs, res.artifacts)
    assert rep["programs"][0]["travel_collisions"] == 0 and not _travel(rep)
    src = res.artifacts["post.src"].decode()
    layer6 = src.split(";- layer 6 ", 1)[1]
    first = re.search(r"\$OUT\[1\]=TRUE ; arc on.*?\nLIN (P\d+)", ";- layer 6 " + layer6, flags=re.S)
    start = re.search(r"\nLIN (P\d+)\n;- zone", layer6)  # the arc-on point: where layer 6 starts
    assert start is not None and first is not None
    end10 = re.search(r";- arc off at P\d+ \(trigger\)\n;- layer 11 ", src)
    assert end10 is not None
    cut = end10.start() + src[end10.start() :].index("\n") + 1
    edited = src[:cut] + f"LIN {start.group(1)} ; back down to layer 6's start\n" + src[cut:]
    rep = run_preflight(g, res.outputs, {**res.artifacts, "post.src": edited.encode()})
    (p,) = _travel(rep)
    assert p["severity"] == "fail" and p["layer"] == 10 and rep["verdict"] == "fail"
    assert rep["programs"][0]["travel_collisions"] == 2  # down to layer 6, and from there up to layer 11
    assert p["value"] > p["limit"] > 0


def test_two_fan_layers_swapped_fail(duct_krl):
    """curved-duct's KRL with layers 5 and 6 welded the other way round (their blocks swapped, each
    layer intact): layer 5 goes under layer 6's bead, and the travel there runs through it. Each
    layer's plane, coverage and wire held, so this passed "ok" before fan programs' travels were
    checked."""
    g, res = duct_krl
    src = res.artifacts["post.src"].decode()
    a5, a6, a7 = (src.index(f";- layer {k} ") for k in (5, 6, 7))
    swapped = src[:a5] + src[a6:a7] + src[a5:a6] + src[a7:]
    rep = run_preflight(g, res.outputs, {**res.artifacts, "post.src": swapped.encode()})
    (p,) = _travel(rep)
    assert p["severity"] == "fail" and rep["verdict"] == "fail"
    assert p["layer"] == 5 and "layer 6's bead" in p["message"]
