"""Dwells with the arc on lay metal in one spot (`dwell_metal`) and count in the wire balance. An
ignition dwell typed 50 for 0.5 (s), or 500 read as seconds where the controller's unit was ms,
passed "ok": the wire balance counted the moves only. A dwell with the arc off (interlayer) lays
nothing."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.preflight.test_preflight import BEAD, LAYER, SPEED, STEP, box_part, gcode, good_layers
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


def _dwell(rep: dict) -> list[dict]:
    return [p for p in rep["problems"] if p["check"] == "dwell_metal"]


def _layer2(text: str, dwell: str) -> str:
    """The program with layer 2's ignition dwell (the third `G4 P0.5`) replaced."""
    parts = text.split("G4 P0.5")
    assert len(parts) == 5  # 4 layers, one ignition each
    return "G4 P0.5".join(parts[:3]) + dwell + "G4 P0.5".join(parts[3:])


def test_the_ignition_dwells_count_and_pass():
    rep = _check(gcode(good_layers()))
    # 0.5 s at the feed that lays STEP·LAYER mm³ per mm at SPEED: the metal of 4 mm of bead, 2/3 of a width
    assert rep["dwell_max_widths"] == pytest.approx(0.5 * SPEED / BEAD, rel=1e-3) and not _dwell(rep)
    assert rep["dwell_mm3"] == pytest.approx(4 * 0.5 * SPEED * STEP * LAYER, rel=1e-3)


@pytest.mark.parametrize(
    "dwell, severity, widths",
    [
        ("G4 P50", "fail", 50 * SPEED / BEAD),  # 50 for 0.5: the metal of 400 mm of bead on one spot
        ("G4 P500", "fail", 500 * SPEED / BEAD),  # ms written, s read (the header says s)
        ("G4 P3", "warn", 3 * SPEED / BEAD),  # 24 mm of bead: 4 widths, a warning
    ],
)
def test_a_long_dwell_with_the_arc_on(dwell, severity, widths):
    rep = _check(_layer2(gcode(good_layers()), dwell))
    (p,) = _dwell(rep)
    assert p["severity"] == severity and p["layer"] == 2 and p["value"] == pytest.approx(widths, rel=1e-3)
    assert rep["verdict"] == severity
    assert p["point"] == [-19.0, -7.5, 4.5]  # layer 2 ignites at its first pass's start


def test_the_header_unit_and_a_dwell_with_the_arc_off():
    ms = gcode(good_layers()).replace("dwell_units=s", "dwell_units=ms").replace("G4 P0.5", "G4 P500")
    assert _check(ms)["dwell_max_widths"] == pytest.approx(0.5 * SPEED / BEAD, rel=1e-3)  # 500 ms
    # a 50 s interlayer dwell after the arc goes off: nothing laid
    text = gcode(good_layers())
    off = text.replace("M5\n; layer 2", "M5\nG4 P50\n; layer 2", 1)
    assert off != text
    rep = _check(off)
    assert rep["verdict"] == "ok" and rep["dwell_mm3"] == pytest.approx(4 * 0.5 * SPEED * STEP * LAYER, rel=1e-3)


@pytest.mark.parametrize(
    "fmt, name, edit",
    [
        ("krl", "post.src", lambda t: t.replace("WAIT SEC 0.5 ; ignition dwell", "WAIT SEC 20 ; ignition dwell", 1)),
        ("rapid", "post.mod", lambda t: re.sub(r"(PERS seamdata sm1 := \[0,0,\[[^\]]*\]),0\.5,", r"\1,20,", t)),
        ("tp", "POST_L001.LS", lambda t: t.replace("WAIT   0.50(sec)", "WAIT  20.00(sec)", 1)),
    ],
)
def test_robot_dialects_dwell_as_written(fmt, name, edit):
    g = build_graph(apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set([f"format={fmt}"])))
    res = execute(g, resolver=FileResolver(GRAPHS), workers=1)
    rep = run_preflight(g, res.outputs, res.artifacts)
    assert rep["verdict"] == "ok" and rep["programs"][0]["dwell_max_widths"] < 1
    text = res.artifacts[name].decode()
    assert edit(text) != text
    rep = run_preflight(g, res.outputs, {**res.artifacts, name: edit(text).encode()})
    (p,) = [p for p in rep["problems"] if p["check"] == "dwell_metal"]
    assert p["severity"] == "fail" and "a 20 s dwell" in p["message"]


def test_a_spot_weld_with_no_motion_counts_where_it_stands():
    """Arc on, 5 s, arc off at (0, 0) of layer 2, with no motion between: no run (nothing moved), the
    metal counted all the same (40 mm of bead: 6.7 widths, a warning) in the layer of its place."""
    text = gcode(good_layers())
    spot = "M5\nG0 X0.000 Y0.000 Z4.500\nM3\nG4 P5\nM5\n; layer 3"
    rep = _check(text.replace("M5\n; layer 3", spot, 1))
    (p,) = _dwell(rep)
    assert p["severity"] == "warn" and p["layer"] == 2 and p["value"] == pytest.approx(5 * SPEED / BEAD, rel=1e-3)
    assert rep["dwell_mm3"] == pytest.approx((4 * 0.5 + 5) * SPEED * STEP * LAYER, rel=1e-3)
