"""A horizontal face of the part in a layer's mid-plane: the section there is a tie. The slicer's
kernel takes the plane just below the face, trimesh's section (the preflight's) the plane just
above: on a plate with a boss and one 3 mm layer (the plate's top at mid-slab) the check saw only
the boss, and failed the slicer's plan of the plate as 87.5 % uncovered with 1,009 mm of weld
outside the part (PrusaSlicer's sign_base_rounded.stl alike). Each half of such a slab is now
checked against its own section (preflight/slabs.py `two_sided_sections`)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from waamflow.core.process import deposit_rate_mm3_s
from waamflow.preflight.check import Part, check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings
from waamflow.preflight.slabs import TwoSided, two_sided_sections

BEAD, SPEED, LAYER = 6.0, 8.0, 3.0
WFS = BEAD * LAYER * SPEED / deposit_rate_mm3_s(1.0)


def _plate_with_boss() -> Part:
    plate = trimesh.creation.box(extents=(100, 60, 1.5))
    plate.apply_translation((0, 0, 0.75))
    boss = trimesh.creation.box(extents=(20, 20, 1.5))
    boss.apply_translation((0, 0, 2.25))
    m = trimesh.util.concatenate([plate, boss])
    return Part("solid", "part", vertices=np.asarray(m.vertices), faces=np.asarray(m.faces))


def _program(half_x: float, half_y: float) -> str:
    ys = np.arange(-half_y + BEAD / 2, half_y - BEAD / 2 + 1e-9, BEAD)
    pts = []
    for k, y in enumerate(ys):
        a, b = (-half_x + 3, half_x - 3) if k % 2 == 0 else (half_x - 3, -half_x + 3)
        pts += [(a, y), (b, y)]
    out = ["; waamflow-post: arc_on=M3 arc_off=M5 dwell_units=s feed_units=mm/min end=M30"]
    out.append('; waamflow-weld: wire_feed_speed[m/min]="M67 E0 Q{value:.2f}" current[A]="M67 E1 Q{value:.1f}"')
    out += ["G21", "G90", f"; layer 0 z={LAYER:.3f}", f"G0 X{pts[0][0]:.3f} Y{pts[0][1]:.3f} Z{LAYER:.3f}"]
    out += [f"M67 E0 Q{WFS:.3f}", "M67 E1 Q180.0", "M3", "G4 P0.5"]
    out += [f"G1 X{x:.3f} Y{y:.3f} Z{LAYER:.3f} F{SPEED * 60:.0f}" for x, y in pts[1:]]
    out += ["M5", "M30"]
    return "\n".join(out)


def _check(text):
    return check_program(_plate_with_boss(), read_gcode(text), "post", PreflightSettings(), BEAD)


def test_the_two_sides_of_a_face_at_mid_slab():
    part = _plate_with_boss()
    got = two_sided_sections(part.vertices, part.faces, [1.5, 0.75, 2.25])
    assert list(got) == [0]  # only the plane through the plate's top
    assert isinstance(got[0], TwoSided)
    assert got[0].below.area == pytest.approx(6000.0) and got[0].above.area == pytest.approx(400.0)


def test_the_slicers_plan_of_the_plate_is_not_called_uncovered_or_outside():
    rep = _check(_program(50, 30))
    checks = {p["check"] for p in rep["problems"]}
    assert "outside" not in checks and "uncovered" not in checks
    assert rep["layers"][0]["part_area_mm2"] == pytest.approx(3200.0)  # (6000 + 400) / 2: the slab's volume / 3 mm
    assert rep["uncovered_share"] < 0.02
    # the metal of a full 3 mm layer over the plate is twice what the part holds (9,600 mm³): a real finding
    assert rep["wire_part_volume_ratio"] > 1.5


def test_a_plan_of_the_boss_alone_leaves_the_plates_half_of_the_slab_uncovered():
    rep = _check(_program(10, 10))
    (unc,) = [p for p in rep["problems"] if p["check"] == "uncovered"]
    assert unc["severity"] == "fail"
    # the lower half of the slab needs the plate: (6000 − 400) / 2 of 3200 mm² uncovered, plus the
    # boss's edges and corners the three passes leave (0.89 in all)
    assert 2800 / 3200 <= rep["uncovered_share"] <= 0.9
