"""An arc-ON move that leaves its layer's plane in a planar program: a robot point edited 20 mm up
in the middle of a weld (the arc stretches and breaks off), or down into the bead. Before, one such
point made the whole program "not planar", and the 3D checks let it pass with warnings (KRL P10 of
mpp-cross raised 20 mm: outside and uncovered warnings only). A helix (one continuous run rising a
layer a lap) and tilted fan layers are not jumps."""

from __future__ import annotations

import numpy as np
import pytest

from tests.preflight.test_preflight import BEAD, LAYER, box_part, gcode, good_layers
from waamflow.preflight.check import check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings


def _jumped(dz: float, nth_g1: int = 10) -> str:
    lines = gcode(good_layers()).splitlines()
    idx = [i for i, ln in enumerate(lines) if ln.startswith("G1")][nth_g1]
    head, z = lines[idx].split(" Z")
    zval, *rest = z.split(" ")
    lines[idx] = f"{head} Z{float(zval) + dz:.3f}" + (" " + " ".join(rest) if rest else "")
    return "\n".join(lines)


def _check(text: str, **kw) -> dict:
    return check_program(box_part(), read_gcode(text), "post", PreflightSettings(**kw), BEAD)


def _jumps(rep: dict) -> list[dict]:
    return [p for p in rep["problems"] if p["check"] == "z_jump"]


@pytest.mark.parametrize("dz", [20.0, -1.2])
def test_a_point_off_the_layers_plane_fails_with_the_layer_and_the_height(dz):
    rep = _check(_jumped(dz))
    (p,) = _jumps(rep)
    assert p["severity"] == "fail" and p["layer"] == 1 and p["section"] == "s0"
    assert p["value"] == pytest.approx(abs(dz), abs=1e-3) and p["limit"] == pytest.approx(max(0.5 * LAYER, 1.0))
    assert p["point"][2] == pytest.approx(2 * LAYER + dz, abs=1e-3)
    assert ("climbs" if dz > 0 else "drops") in p["message"] and "layer 1" in p["message"]
    assert rep["verdict"] == "fail"
    assert not _jumps(_check(_jumped(dz), z_jump="off"))


def test_small_steps_helices_and_fan_layers_are_no_jumps():
    assert not _jumps(_check(_jumped(0.6)))  # under half a layer and 1 mm
    assert not _jumps(_check(gcode(good_layers())))
    # a program of 4 flat layers and one helical run rising 1.5 mm a 120 mm lap, 3 laps
    t = np.linspace(0, 3 * 2 * np.pi, 400)
    helix = [(float(15 * np.cos(a)), float(7 * np.sin(a))) for a in t]
    text = gcode(good_layers())
    lines = text.splitlines()
    end = lines.index("M30")
    zs = 7.5 + 1.5 * t / (2 * np.pi)
    body = [
        "; layer 4 z=7.500",
        "; section helix",
        f"G0 X{helix[0][0]:.3f} Y{helix[0][1]:.3f} Z7.500",
        "M67 E0 Q1.0",
        "M3",
    ]
    body += [f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f} F480" for (x, y), z in zip(helix[1:], zs[1:])]
    rep = _check("\n".join(lines[:end] + body + ["M5", "M30"]))
    assert not _jumps(rep)
