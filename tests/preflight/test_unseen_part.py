"""A part no layer's mid-plane cuts: trimesh's octagonal_pocket.stl read as mm is 0.016 mm tall;
its one 0.75 mm layer is cut at z 0.375, above the part, so every section is empty and the part's
whole volume counts as uncovered. The check said "100.0 % of the part gets no bead: add a mask
section or a filling pattern there", which blames the plan for what the layers cannot see. It now
says that no mid-plane cuts the part, where the part and the planes are, and what to check. The
general case: a fin thinner than a layer between two mid-planes, in no section, counted as
uncovered and blamed on the plan; the message now names that share and finer layers."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from waamflow.core.process import deposit_rate_mm3_s
from waamflow.preflight.check import Part, check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings

BEAD, SPEED = 6.0, 8.0


def _box(height: float) -> Part:
    m = trimesh.creation.box(extents=(60, 40, height))
    m.apply_translation((0, 0, height / 2))
    return Part("solid", "part", vertices=np.asarray(m.vertices), faces=np.asarray(m.faces))


def _program(layer_tops: list[float], layer: float, full: bool = False) -> str:
    """Boustrophedon beads over the 60 × 40 box, `full`: to its edges (rows 5.7 mm apart, runs to
    x ±30), else rows 6 mm apart ending 3 mm short (corners and a strip uncovered)."""
    wfs = BEAD * layer * SPEED / deposit_rate_mm3_s(1.0)
    ys = np.linspace(-17.0, 17.0, 7) if full else np.arange(-20 + BEAD / 2, 20 - BEAD / 2 + 1e-9, BEAD)
    x = 30.0 if full else 27.0
    out = ["; waamflow-post: arc_on=M3 arc_off=M5 dwell_units=s feed_units=mm/min end=M30"]
    out.append('; waamflow-weld: wire_feed_speed[m/min]="M67 E0 Q{value:.2f}" current[A]="M67 E1 Q{value:.1f}"')
    out += ["G21", "G90"]
    for k, z in enumerate(layer_tops):
        pts = []
        for j, y in enumerate(ys):
            a, b = (-x, x) if j % 2 == 0 else (x, -x)
            pts += [(a, y), (b, y)]
        out += [f"; layer {k} z={z:.3f}", f"G0 X{pts[0][0]:.3f} Y{pts[0][1]:.3f} Z{z:.3f}"]
        out += [f"M67 E0 Q{wfs:.3f}", "M67 E1 Q180.0", "M3", "G4 P0.5"]
        out += [f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f} F{SPEED * 60:.0f}" for x, y in pts[1:]]
        out += ["M5"]
    out += ["M30"]
    return "\n".join(out)


def _uncovered(report: dict) -> list[dict]:
    return [p for p in report["problems"] if p["check"] == "uncovered"]


def test_a_part_no_mid_plane_cuts_is_named_so():
    report = check_program(_box(0.016), read_gcode(_program([0.75], 0.75)), "post", PreflightSettings(), BEAD)
    (p,) = _uncovered(report)
    assert report["verdict"] == "fail" and p["severity"] == "fail" and p["value"] == 1.0
    msg = p["message"]
    assert msg.startswith("no layer's mid-plane cuts the part: it spans z 0.000–0.016 mm (0.016 mm tall)")
    assert "cut at z 0.375 mm" in msg and "'units'" in msg
    assert "add a mask section" not in msg
    assert report["layers"][0]["part_area_mm2"] == 0.0


def test_every_plane_over_a_thin_plate_is_listed():
    """A 0.5 mm plate under three 2 mm layers (mid-planes 1, 3 and 5 mm): no section, every plane named."""
    report = check_program(_box(0.5), read_gcode(_program([2.0, 4.0, 6.0], 2.0)), "post", PreflightSettings(), BEAD)
    (p,) = _uncovered(report)
    assert "spans z 0.000–0.500 mm (0.5 mm tall) and the layers are cut at z 1.000, 3.000, 5.000 mm" in p["message"]
    assert [L["part_area_mm2"] for L in report["layers"]] == [0.0, 0.0, 0.0]


def test_a_plan_that_misses_a_seen_part_keeps_the_plans_message():
    """A 3 mm box with one 1.5 mm layer of two beads: the mid-plane cuts it, most of it gets no
    bead; the message still points at the plan (a mask section or a filling pattern)."""
    text = _program([1.5], 1.5).split("\n")
    keep = [ln for ln in text if not ln.startswith("G1") or "Y-17.000" in ln or "Y-11.000" in ln]
    report = check_program(_box(3.0), read_gcode("\n".join(keep)), "post", PreflightSettings(), BEAD)
    (p,) = _uncovered(report)
    assert p["message"].endswith("add a mask section or a filling pattern there")
    assert "no layer's mid-plane" not in p["message"]


def _box_with_fin(fin_z: float, fin_t: float) -> Part:
    """A 60 × 40 × 9 mm box with an 80 × 40 mm fin `fin_t` thick against its +x side at z `fin_z`
    (touching, not overlapping: the volumes add)."""
    box = trimesh.creation.box(extents=(60, 40, 9))
    box.apply_translation((0, 0, 4.5))
    fin = trimesh.creation.box(extents=(80, 40, fin_t))
    fin.apply_translation((70, 0, fin_z + fin_t / 2))
    m = trimesh.util.concatenate([box, fin])
    return Part("solid", "part", vertices=np.asarray(m.vertices), faces=np.asarray(m.faces))


def test_a_fin_between_mid_planes_is_named_as_unseen_not_as_unplanned():
    """A 0.45 mm fin at z 4.5-4.95 lies between the 1.5 mm layers' mid-planes (3.75 and 5.25):
    no section holds it, so no plan can cover it. Its 1,440 mm³ are 6.2 % of the part: the check
    said only "6.2 % of the part gets no bead: add a mask section or a filling pattern there"
    while every section the layers cut was covered. It now says how much of the part no layer's
    mid-plane section holds, and that finer layers would see it."""
    tops = [1.5 * (k + 1) for k in range(6)]
    report = check_program(
        _box_with_fin(4.5, 0.45), read_gcode(_program(tops, 1.5, full=True)), "post", PreflightSettings(), BEAD
    )
    (p,) = _uncovered(report)
    assert p["severity"] == "fail" and p["value"] == pytest.approx(1440 / (21600 + 1440), abs=1e-3)
    assert all(L["uncovered_share"] == pytest.approx(0.0, abs=1e-3) for L in report["layers"])
    msg = p["message"]
    assert "6.2 % of the part's volume is in no layer's mid-plane section" in msg
    assert "finer layers" in msg and "add a mask section" not in msg


def test_a_fin_a_mid_plane_cuts_is_planned_like_the_rest():
    """The same fin at z 5.0-5.45 holds the 5.25 mm mid-plane: its layer sees it, the plan leaves
    it uncovered, and the message points at the plan (its worst layer)."""
    tops = [1.5 * (k + 1) for k in range(6)]
    report = check_program(
        _box_with_fin(5.0, 0.45), read_gcode(_program(tops, 1.5, full=True)), "post", PreflightSettings(), BEAD
    )
    (p,) = _uncovered(report)
    assert "worst layer 3" in p["message"] and p["message"].endswith("add a mask section or a filling pattern there")
    assert "mid-plane section" not in p["message"]


def test_a_small_share_outside_the_sections_does_not_take_over_the_message():
    """A 0.12 mm fin between mid-planes (1.7 % of the part, under the 2 % warning on its own) and
    a plan whose first row stops 20 mm short on layer 0: 2.1 % gets no bead, most of it the fin's.
    A share that small outside the sections is what a slanted side's mid-plane sections can miss
    too, so the message points at the plan's worst layer as before."""
    tops = [1.5 * (k + 1) for k in range(6)]
    lines = _program(tops, 1.5, full=True).split("\n")
    first = next(k for k, ln in enumerate(lines) if ln.startswith("G1"))
    lines[first] = lines[first].replace("X30.000", "X10.000")
    report = check_program(_box_with_fin(4.5, 0.12), read_gcode("\n".join(lines)), "post", PreflightSettings(), BEAD)
    (p,) = _uncovered(report)
    assert p["value"] == pytest.approx(0.0212, abs=5e-4)
    assert p["message"].startswith("2.1 % of the part gets no bead; worst layer 0:")
    assert "mid-plane section" not in p["message"]
