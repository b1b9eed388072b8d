"""Arc-ON moves with no travel speed the controller would weld at: a rapid (G0) with the arc on
(the controller's rapid rate, metres a minute), a zero feed (F0: LinuxCNC refuses the line, others
stall with the arc burning). Before, such a program made the preflight itself fail with a bare
StopIteration (the wire balance looked for a move without wire feed; these have one)."""

from __future__ import annotations

import pytest

from tests.preflight.test_preflight import BEAD, box_part, gcode, good_layers
from waamflow.preflight.check import check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings


def _edit(nth_g1: int, fn) -> str:
    lines = gcode(good_layers()).splitlines()
    idx = [i for i, ln in enumerate(lines) if ln.startswith("G1")][nth_g1]
    lines[idx] = fn(lines[idx])
    return "\n".join(lines)


def _check(text: str, **kw) -> dict:
    return check_program(box_part(), read_gcode(text), "post", PreflightSettings(**kw), BEAD)


def _speed(rep: dict) -> list[dict]:
    return [p for p in rep["problems"] if p["check"] == "weld_speed"]


def test_a_rapid_with_the_arc_on_fails_with_its_layer_and_section():
    rep = _check(_edit(9, lambda ln: ln.replace("G1", "G0")))  # layer 1's third move
    (p,) = _speed(rep)
    assert p["severity"] == "fail" and p["layer"] == 1 and p["section"] == "s0" and p["value"] == 1
    assert "rapid" in p["message"] and "1 of 28 arc-ON moves" in p["message"]
    assert rep["verdict"] == "fail" and rep["wire_part_volume_ratio"] is None  # its metal is unknown
    assert not [q for q in rep["problems"] if q["check"] == "volume_ratio"]  # said once, by this check
    assert _speed(_check(_edit(9, lambda ln: ln.replace("G1", "G0")), weld_speed="warn"))[0]["severity"] == "warn"


def test_a_zero_feed_with_the_arc_on_fails():
    rep = _check(_edit(0, lambda ln: ln.split(" F")[0] + " F0"))  # the program's first weld move
    (p,) = _speed(rep)
    # F0 is modal: the 7 moves of layer 0's run, up to layer 1's first move, which states F480 again
    assert p["layer"] == 0 and p["value"] == 7 and "zero" in p["message"]


def test_the_right_program_has_no_weld_speed_problem():
    rep = _check(gcode(good_layers()))
    assert not _speed(rep) and rep["wire_part_volume_ratio"] == pytest.approx(1.0, abs=0.3)
