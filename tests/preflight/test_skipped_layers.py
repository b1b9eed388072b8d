"""Deposited layers with nothing deposited below them where the part has metal (preflight/gaps.py).
libigl's screwdriver at 4 mm layers: the sequence dropped every contour run of the shaft (shorter
than its min_arc_run), layers 24-39 were empty, and the preflight checked layer 40 as one 68 mm slab:
exit 0, uncovered 0.0, 64 mm of the shaft without metal."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from waamflow.core.process import deposit_rate_mm3_s
from waamflow.preflight.check import Part, check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings

L, W, H = 40.0, 20.0, 30.0  # box part, mm
LAYER, N = 1.5, 20
BEAD, STEP, SPEED = 6.0, 5.0, 8.0
WFS = STEP * LAYER * SPEED / deposit_rate_mm3_s(1.0)  # the metal of one layer per mm of path
YS = [-7.5, -2.5, 2.5, 7.5]


def _part() -> Part:
    m = trimesh.creation.box(extents=(L, W, H))
    m.apply_translation((0, 0, H / 2))
    return Part("solid", "part", vertices=np.asarray(m.vertices), faces=np.asarray(m.faces))


def _program(skip=()) -> str:
    out = ["; waamflow-post: arc_on=M3 arc_off=M5 dwell_units=s feed_units=mm/min end=M30"]
    out.append('; waamflow-weld: wire_feed_speed[m/min]="M67 E0 Q{value:.2f}" current[A]="M67 E1 Q{value:.1f}"')
    out += ["G21", "G90"]
    for i in range(N):
        if i in skip:
            continue
        z = (i + 1) * LAYER
        ys = YS[::-1] if i % 2 else YS
        pts = []
        for k, y in enumerate(ys):
            a, b = (-19.0, 19.0) if (k % 2 == 0) != (i % 2 == 1) else (19.0, -19.0)
            pts += [(a, y), (b, y)]
        out.append(f"; layer {i} z={z:.3f}")
        out.append(f"G0 X{pts[0][0]:.3f} Y{pts[0][1]:.3f} Z{z:.3f}")
        out += [f"M67 E0 Q{WFS:.3f}", "M67 E1 Q180.0", "M3", "G4 P0.5"]
        out += [f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f} F{SPEED * 60:.0f}" for x, y in pts[1:]]
        out.append("M5")
    out.append("M30")
    return "\n".join(out)


def _check(text, **kw):
    return check_program(_part(), read_gcode(text), "post", PreflightSettings(**kw), BEAD)


def _gaps(rep):
    return [p for p in rep["problems"] if p["check"] == "skipped_layers"]


def test_every_layer_deposited_has_no_gap():
    rep = _check(_program())
    assert _gaps(rep) == [] and rep["uncovered_share"] < 0.02
    assert all("gap_below_mm" not in L for L in rep["layers"])


def test_six_layers_skipped_fail_and_count_as_uncovered():
    rep = _check(_program(skip=range(6, 12)))
    (gap,) = _gaps(rep)
    assert gap["severity"] == "fail" and gap["layer"] == 12 and rep["verdict"] == "fail"
    assert gap["value"] == pytest.approx(7.0)  # the slab under layer 12: 7 layer heights
    assert "between layer 5 (top 9.00 mm) and layer 12 (top 19.50 mm)" in gap["message"]
    assert "9.0 mm of the part (800 mm² in section), about 6 layers of 1.50 mm" in gap["message"]
    # the 9 mm of the 30 mm box the six layers lack (it had counted the 10.5 mm slab as covered: 0.0)
    assert rep["uncovered_share"] == pytest.approx(9.0 / 30.0, abs=0.01)
    (twelve,) = [L for L in rep["layers"] if L["index"] == 12]
    assert twelve["gap_below_mm"] == pytest.approx(9.0)


def test_one_layer_skipped_is_a_warning_and_the_bands_are_settings():
    rep = _check(_program(skip=[8]))
    (gap,) = _gaps(rep)
    assert gap["severity"] == "warn" and gap["layer"] == 9 and gap["value"] == pytest.approx(2.0)
    assert "about 1 layer of 1.50 mm" in gap["message"]
    assert _gaps(_check(_program(skip=[8]), layer_gap_warn_layers=2.2, layer_gap_fail_layers=3)) == []
    (strict,) = _gaps(_check(_program(skip=[8]), layer_gap_warn_layers=1.5, layer_gap_fail_layers=1.9))
    assert strict["severity"] == "fail"
    with pytest.raises(ValueError, match="layer_gap_warn_layers must not exceed"):
        PreflightSettings(layer_gap_warn_layers=3, layer_gap_fail_layers=2)


def test_every_other_pair_of_layers_skipped_is_measured_on_the_planned_layer_height():
    """3MF Consortium's dodeca_chain_loop.3mf (contour, 5 mm beads, 2 mm layers): the links' thin
    sections at layers 1-2 and 5-6 welded nothing, the program held layers 0, 3, 4 and 7, and the
    preflight took the median slab (4 mm) for the layer height: no skipped layers, "17.7 % of the
    part gets no bead; worst layer 7: 1.3 %". The program's layer numbers count the planned layers:
    a slab under a layer 3 numbers above the last is 3 layers high."""
    skip = [i for i in range(N) if i % 4 in (1, 2)]  # layers 0, 3, 4, 7, 8, 11, ... deposited
    rep = _check(_program(skip=skip))
    gaps = _gaps(rep)
    assert [g["severity"] for g in gaps] == ["fail"]
    assert "about 2 layers of 1.50 mm" in gaps[0]["message"]
    assert "(4 more such gaps)" in gaps[0]["message"]
    (unc,) = [p for p in rep["problems"] if p["check"] == "uncovered"]
    assert rep["uncovered_share"] == pytest.approx(0.5, abs=0.02)  # 10 of 20 layers welded
    assert "% of the part in the layers the program skips (skipped_layers)" in unc["message"]
