"""A stretch of a layer that lays far less (or more) metal per millimetre than the rest of it: a KRL
weld started before its welding speed was set (the travel's $VEL.CP = 0.1 m/s held: 100 mm/s where
the layer welds at 6-8), a wire feed typed ten times too high in one zone. The part's wire balance
hides a stretch (mpp-cross's KRL with layer 0's first 2 weld moves at 100 mm/s passed "ok"); the
bead there is a sixteenth of the layer's, a dip the next layer bridges or not."""

from __future__ import annotations

import pytest

from tests.preflight.test_preflight import BEAD, SPEED, WFS, box_part, gcode, good_layers
from waamflow.preflight.check import check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings


def _check(text: str, **kw) -> dict:
    return check_program(box_part(), read_gcode(text), "post", PreflightSettings(**kw), BEAD)


def _local(rep: dict) -> list[dict]:
    return [p for p in rep["problems"] if p["check"] == "local_deposit"]


def _fast_first_pass(factor: float) -> str:
    """Layer 1's first pass (38 mm) welded at `factor` × the speed, the rest as planned."""
    lines = gcode(good_layers()).splitlines()
    g1 = [i for i, ln in enumerate(lines) if ln.startswith("G1")]
    first, second = g1[7], g1[8]  # layer 1's first and second weld moves
    lines[first] = lines[first].split(" F")[0] + f" F{SPEED * 60 * factor:.0f}"
    lines[second] += f" F{SPEED * 60:.0f}"
    return "\n".join(lines)


def test_a_stretch_welded_at_the_travel_speed_fails_with_its_length_and_ratio():
    rep = _check(_fast_first_pass(100 / 8))  # 100 mm/s where the layer welds at 8
    (p,) = _local(rep)
    assert p["severity"] == "fail" and p["layer"] == 1 and p["section"] == "s0"
    assert p["value"] == pytest.approx(8 / 100, rel=1e-3) and p["limit"] == pytest.approx(0.1)
    assert "38.0 mm" in p["message"] and "0.08×" in p["message"] and "100.0 mm/s" in p["message"]
    assert rep["verdict"] == "fail"
    assert not _local(_check(_fast_first_pass(100 / 8), local_deposit="off"))


def test_ten_times_the_wire_in_one_zone_fails():
    lines = gcode(good_layers()).splitlines()
    g1 = [i for i, ln in enumerate(lines) if ln.startswith("G1")]
    lines.insert(g1[9], f"M67 E0 Q{10 * WFS:.3f}")  # layer 1, from its third move on: 10× the wire
    (p,) = _local(_check("\n".join(lines)))
    assert p["layer"] == 1 and p["value"] == pytest.approx(10.0, rel=1e-3) and p["limit"] == pytest.approx(8.0)
    assert p["severity"] == "fail" and "10.00×" in p["message"]


def test_between_the_bands_it_warns():
    # a fifth of the speed: 5× the metal a mm, past the 4× of a zone's or a compensation's choice, short of 8×
    (p,) = _local(_check(_fast_first_pass(1 / 5)))
    assert p["severity"] == "warn" and p["value"] == pytest.approx(5.0, rel=1e-2) and p["limit"] == pytest.approx(4.0)


def test_zones_within_the_band_and_the_right_program_pass():
    assert not _local(_check(gcode(good_layers())))
    assert not _local(_check(_fast_first_pass(2.0)))  # a zone at twice the speed: half the metal, a zone's choice
    assert not _local(_check(_fast_first_pass(1 / 3.5)))
