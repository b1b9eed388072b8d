"""The G-code dialect table (#14 item 5): comment style, feed units, start / layer-change / end
code, final lift, program end, preamble and postamble; read back by our parser and by pygcode."""

import re

import numpy as np
import pytest
from program_checkers import check_gcode
from pydantic import ValidationError

from waamflow.core.errors import RecipeError
from waamflow.core.moves import flatten
from waamflow.engine.node import load_nodes
from waamflow.program import GcodeSettings, PlanSettings, parse_gcode, post_process

from conftest import PostCtx, build_toolpath


class Ctx(PostCtx):
    def trace(self):
        return {
            "date": "2026-11-23T10:00:00Z",
            "waamflow": "0.1.0",
            "recipe": "t",
            "recipe_sha256": "0" * 64,
            "inputs": {"parts/p.stl": "1" * 64},
        }


def _node(**params):
    node_cls = load_nodes()["post-process"]
    node = node_cls()
    p = node_cls.Params(**params)
    out = node.run(Ctx(), p, {"toolpath": build_toolpath(3)})
    return out["program"], node.artifacts(Ctx(), p, out)["gcode"], p


def test_fanuc_profile_parentheses_only_percent_and_program_number():
    prog, text, p = _node(profile="fanuc")
    lines = text.splitlines()
    assert lines[:2] == ["%", "O0001"] and lines[-1] == "%" and lines[-2].startswith("M30")
    assert ";" not in text  # no semicolon anywhere, trace included
    assert "(waamflow trace: recipe sha256 " + "0" * 64 + ")" in text
    assert re.search(r"^G4 P800 \(ignition dwell 0\.8 s\)$", text, re.M)  # ms on Fanuc
    parsed = parse_gcode(text)
    assert parsed.ended and parsed.ignitions == 15
    got = check_gcode({"gcode": text}, p.model_dump())
    assert got["points"] == prog.stats["motions"]
    assert got["final_z"] == pytest.approx(flatten(build_toolpath(3)).points[-1, 2] + 10.0)


def test_marlin_layer_code_lift_and_end():
    prog, text, _ = _node(profile="marlin")
    assert len(re.findall(r"^;LAYER:(\d+)$", text, re.M)) == 3
    assert re.findall(r"^;LAYER:(\d+)$", text, re.M) == ["0", "1", "2"]
    tail = text.splitlines()[-3:]
    last_z = flatten(build_toolpath(3)).points[-1, 2]
    # issue 23: Marlin's G0 moves at the modal feed, so the lift carries F = travel_speed (100 mm/s)
    assert (
        tail[0] == f"G0 Z{last_z + 10:.3f} F6000 ; final lift 10 mm" and tail[1] == "M107" and tail[2].startswith("M84")
    )
    assert not re.search(r"^M30", text, re.M)  # Marlin's M30 deletes an SD file
    assert parse_gcode(text).ended


def test_feed_in_mm_per_s_and_start_code_and_templates():
    moves = flatten(build_toolpath(2))
    s = GcodeSettings(
        feed_units="mm/s", start_code=("G28", "M8"), layer_code=("M117 z{z:.1f}",), final_lift=5.0, program_end="M2"
    )
    prog = post_process(moves, "gcode", PlanSettings(), s)
    text = prog.files["gcode"]
    feeds = {float(f) for f in re.findall(r"^G1 .* F([\d.]+)$", text, re.M)}
    assert feeds == {5.0, 6.0, 7.0}  # the zones' speeds, in mm/s
    assert "G94" not in text and "feed F in mm/s" in text
    head = text.splitlines()
    assert head[head.index("G90 ; absolute coordinates") + 1 : head.index("G90 ; absolute coordinates") + 3] == [
        "G28",
        "M8",
    ]
    assert re.findall(r"^M117 z([\d.]+)$", text, re.M) == ["1.5", "3.0"]
    parsed = parse_gcode(text)  # reads F back in mm/min
    assert {round(float(f), 3) for r in parsed.runs for f in r.feed_mm_min} == {300.0, 360.0, 420.0}
    assert prog.stats["travel_length_mm"] == pytest.approx(post_process(moves, "gcode").stats["travel_length_mm"] + 5.0)


@pytest.mark.parametrize(
    "params, words",
    [
        ({"layer_code": ["M117 {layr}"]}, "layer_code"),
        ({"start_code": ["G28\nG0"]}, "start_code"),
        ({"program_end": "M30 ; end"}, "program_end"),
    ],
)
def test_bad_dialect_settings_are_clear_errors(params, words):
    with pytest.raises(RecipeError, match=words):
        _node(**params)


def test_rotary_axes_units_letters_and_only_on_change():
    moves = flatten(build_toolpath(2))
    n = len(moves.points)
    ang = np.zeros((n, 2))
    layer = np.concatenate([moves.layer[:1], moves.layer])  # layer of the motion to each point
    ang[:, 0] = np.where(layer == 1, 30.0, 10.0)  # layer 1 tilted further
    ang[:, 1] = -90.0
    text = post_process(
        moves, "gcode", PlanSettings(), GcodeSettings(rotary_axes=("B", "C"), rotary_units="rad", external_axes=ang)
    ).files["gcode"]
    b = [float(v) for v in re.findall(r"^G[01] .*\bB(-?[\d.]+)", text, re.M)]
    c = [float(v) for v in re.findall(r"^G[01] .*\bC(-?[\d.]+)", text, re.M)]
    assert b == pytest.approx([np.radians(10.0), np.radians(30.0)], abs=1e-6)  # written where they change
    assert c == pytest.approx([np.radians(-90.0)], abs=1e-6)
    assert "B = positioner E1 (tilt), C = positioner E2 (turn) in radians" in text
    with pytest.raises(ValueError, match="rotary_axes"):
        GcodeSettings(rotary_axes=("A", "A"))
    with pytest.raises(ValueError, match="names only 1"):
        post_process(moves, "gcode", PlanSettings(), GcodeSettings(rotary_axes=("A",), external_axes=ang))
    with pytest.raises(ValidationError, match="rotary_axes"):  # the engine's 422 / exit 2
        _node(rotary_axes=["A", "X"])
