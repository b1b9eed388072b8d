"""Layers welded in an order the torch cannot follow: a layer below (or at the height of) metal
welded before it at the same place. A program that swapped two layers (z 1.5, 3.0, 6.0, 4.5) or
welded one layer twice passed with a stacked-starts warning, the wire ratio at most 1.3 (a warning)."""

from __future__ import annotations

import pytest

from tests.preflight.test_preflight import BEAD, LAYER, YS, box_part, gcode, good_layers, passes
from waamflow.preflight.check import check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings


def _check(layers, **kw) -> dict:
    return check_program(box_part(), read_gcode(gcode(layers)), "post", PreflightSettings(**kw), BEAD)


def _order(rep: dict) -> list[dict]:
    return [p for p in rep["problems"] if p["check"] == "layer_order"]


def test_two_layers_swapped_fail_at_the_lower_one_welded_last():
    L = good_layers()
    rep = _check([L[0], L[1], L[3], L[2]])  # z 1.5, 3.0, 6.0, then 4.5 under the 6.0 layer
    (p,) = _order(rep)
    assert p["severity"] == "fail" and p["layer"] == 3 and p["value"] == pytest.approx(-LAYER)
    assert "z 4.500" in p["message"] and "layer 2 (z 6.000)" in p["message"] and "into" in p["message"]
    assert rep["verdict"] == "fail"
    assert _order(_check([L[0], L[1], L[3], L[2]], layer_order="warn"))[0]["severity"] == "warn"
    assert not _order(_check([L[0], L[1], L[3], L[2]], layer_order="off"))


def test_a_layer_welded_twice_fails():
    L = good_layers()
    (p,) = _order(_check([L[0], L[1], L[2], L[2], L[3]]))
    assert p["layer"] == 3 and p["value"] == pytest.approx(0.0) and "at its height" in p["message"]


def test_towers_built_one_after_the_other_and_thin_top_layers_pass():
    # two towers side by side (the box is 40 mm long: x < -2 and x > 2): the left one to the top, then
    # the right one from the plate — the torch never comes down where metal is
    left = [((i + 1) * LAYER, [passes(YS, x0=-19, x1=-3)]) for i in range(4)]
    right = [((i + 1) * LAYER, [passes(YS, x0=3, x1=19)]) for i in range(4)]
    assert not _order(_check(left + right))
    # a thin last layer (0.3 of a layer higher) is a rise, not a re-weld
    L = good_layers()
    thin = [*L[:3], (L[2][0] + 0.3 * LAYER, L[3][1])]
    assert not _order(_check(thin))
    assert not _order(_check(L))
