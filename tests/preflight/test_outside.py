"""Preflight `outside`: metal deposited where there is no part.

The filleted thin-wall panel as the old sequencer threaded its L walls (a 71.4 mm diagonal welded
across the cell between the skin and the longitudinal rib), written by hand into the shipped plan;
the MPP cross with one pass moved 20 mm off its arm, written by hand into the G-code; and the two
as planned, which must pass. Expected lengths are computed here with shapely from the part, not by
the kernel's sampling."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, MultiLineString

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set
from waamflow.preflight import PreflightSettings, _part_of, _stock_length
from waamflow.preflight.check import Part, check_program
from waamflow.preflight.read import read_gcode, read_toolpath

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"

# layer 1, wall2 (the L round the skin corner at (200, 0)) as the old pass detection re-threaded it:
# on the wall at (151.6, 0), out along the fillet lead into the cell, then straight across the cell
# to the rib junction at (200, 60), back down the skin and round the 4.6 mm corner fillet
OLD_WALL2 = [
    (151.6, 0.0),
    (155.657, 5.657),
    (200.0, 61.6),
    (200.0, 58.4),
    (200.0, 4.6),
    (199.992, 4.332),
    (199.969, 4.066),
    (199.93, 3.801),
    (199.876, 3.539),
    (199.807, 3.281),
    (199.723, 3.027),
    (199.624, 2.778),
    (199.511, 2.535),
    (199.384, 2.3),
    (199.243, 2.072),
    (199.09, 1.853),
    (198.924, 1.643),
]


def outside_problems(rep):
    return [p for p in rep["problems"] if p["check"] == "outside"]


@pytest.fixture(scope="module")
def panel():
    recipe = apply_overrides(load_recipe(GRAPHS / "thin-wall-panel.json"), parse_set(["fillet_radius=3"]))
    graph = build_graph(recipe)
    res = execute(graph, resolver=FileResolver(GRAPHS), workers=1)
    return graph, res


def check_panel_doc(graph, res, doc):
    part = _part_of(graph, res.outputs, "sequence")
    assert part.kind == "midsurface"
    return check_program(
        part,
        read_toolpath(doc),
        "sequence",
        PreflightSettings(),
        4.0,
        weld_expected=False,
        stock_mm=_stock_length(graph, "sequence", 4.0),
    )


def test_filleted_panel_as_planned_has_no_metal_outside(panel):
    graph, res = panel
    assert res.preflight["verdict"] == "ok", res.preflight["problems"]
    prog = res.preflight["programs"][0]
    assert prog["outside_method"] == "midsurface distance" and prog["outside_mm"] == 0.0
    assert prog["outside_stock_mm"] == pytest.approx(5.0 + 4.0)  # free_end_extension + one bead width
    rep = check_panel_doc(graph, res, json.loads(res.artifacts["sequence.toolpath.json"]))
    assert not outside_problems(rep) and rep["outside_mm"] == 0.0


def test_diagonal_weld_across_the_panel_fails_at_its_layer_and_wall(panel):
    graph, res = panel
    doc = copy.deepcopy(json.loads(res.artifacts["sequence.toolpath.json"]))
    layer = next(L for L in doc["layers"] if L["index"] == 1)
    sec = next(s for s in layer["sections"] if s["key"] == "wall2")
    z = sec["points"][0][2]
    n = len(OLD_WALL2) - 1
    sec.update(
        points=[[x, y, z] for x, y in OLD_WALL2], arc=[True] * n, speed=[sec["speed"][0]] * n, zone=[sec["zone"][0]] * n
    )
    rep = check_panel_doc(graph, res, doc)
    found = outside_problems(rep)
    assert rep["verdict"] == "fail" and len(found) == 1
    p = found[0]
    assert p["severity"] == "fail" and p["layer"] == 1 and p["section"] == "wall2"
    assert "layer 1, section wall2" in p["message"]
    # the run's part whose bead clears the wall (a 4 mm wall round the midsurface, the bead's half
    # width beyond it: centre line > 4 mm from the midsurface): the fillet lead's last 2 mm and the
    # 71.4 mm diagonal but its last 7.1 mm at the rib junction
    panel_json = json.loads((GRAPHS / "parts" / "panel.json").read_text())
    mid = MultiLineString([np.asarray(c, float) for c in panel_json["curves"]])
    beyond = LineString(OLD_WALL2).difference(mid.buffer(4.0, quad_segs=32)).length
    assert beyond == pytest.approx(66.28, abs=0.01)
    assert p["value"] == pytest.approx(beyond, abs=1.0)  # sampled every 1 mm
    assert rep["outside_mm"] == pytest.approx(beyond, abs=1.0)
    # the farthest point: mid-cell, ~20 mm from the skin, the rib and x = 150 less half a bead
    x, y, _z = p["point"]
    assert 160 < x < 190 and 10 < y < 50 and p["point"][2] == pytest.approx(z)
    assert rep["layers"][1]["outside_mm"] == pytest.approx(beyond, abs=1.0)
    # warn mode keeps the figure and lowers the verdict
    warn = check_program(
        _part_of(graph, res.outputs, "sequence"),
        read_toolpath(doc),
        "sequence",
        PreflightSettings(outside="warn"),
        4.0,
        weld_expected=False,
        stock_mm=9.0,
    )
    assert [q["severity"] for q in outside_problems(warn)] == ["warn"] and warn["verdict"] == "warn"


# ---- MPP cross: one pass 20 mm off its arm ---------------------------------------------------------
@pytest.fixture(scope="module")
def cross():
    graph = build_graph(load_recipe(GRAPHS / "mpp-cross.json"))
    res = execute(graph, resolver=FileResolver(GRAPHS), workers=1)
    return graph, res


def shift_run(text: str, layer: int, section: str, dy: float) -> str:
    """The G-code with every move of one section (from its `; section` comment to the next) moved dy
    in Y."""
    out, here, cur_layer = [], False, None
    for line in text.splitlines():
        m = re.match(r"; layer (\d+)", line)
        if m:
            cur_layer = int(m.group(1))
        if line.startswith("; section") or m:
            here = cur_layer == layer and line == f"; section {section}"
        if here and re.match(r"G[01] ", line) and " Y" in line:
            line = re.sub(r"Y(-?[\d.]+)", lambda g: f"Y{float(g.group(1)) + dy:.3f}", line)
        out.append(line)
    return "\n".join(out)


def check_cross(graph, res, text):
    return check_program(
        _part_of(graph, res.outputs, "post"),
        read_gcode(text),
        "post",
        PreflightSettings(),
        6.0,
        stock_mm=_stock_length(graph, "post", 6.0),
    )


def test_mpp_cross_as_shipped_has_no_metal_outside(cross):
    graph, res = cross
    assert res.preflight["verdict"] == "ok", res.preflight["problems"]
    prog = res.preflight["programs"][0]
    assert prog["outside_method"] == "planar slabs"
    assert prog["outside_mm"] == 0.0 and prog["outside_mm2"] == 0.0 and prog["outside_share"] == 0.0


def test_mpp_cross_pass_shifted_off_the_part_fails(cross):
    graph, res = cross
    text = shift_run(res.artifacts["post.gcode"].decode(), 2, "bs1/B", 20.0)
    prog = read_gcode(text)
    moved = next(r for r in prog.runs if r.layer == 2 and r.section == "bs1/B")
    assert moved.points[:, 1].min() == pytest.approx(17.0)  # y ±3 → 17 … 23
    rep = check_cross(graph, res, text)
    found = outside_problems(rep)
    assert rep["verdict"] == "fail" and found and found[0]["severity"] == "fail"
    p = found[0]
    assert p["layer"] == 2 and p["section"] == "bs1/B"
    # the moved run's centre line beyond ½ bead (3 mm) of the cross's section (arms 12 mm wide): its
    # two legs along the arm at y 17 and 23, apart where they meet the vertical arm at x = −6; both
    # hold a run end, so each counts less the stock a run end may have (no extension: one bead width)
    section = shapely.union(shapely.box(-60, -6, 60, 6), shapely.box(-6, -60, 6, 60))
    beyond = LineString(moved.points[:, :2]).difference(section.buffer(3.0, quad_segs=32)).length
    assert beyond == pytest.approx(2 * 51.0, abs=0.1)
    assert rep["outside_stock_mm"] == 6.0
    assert p["value"] == pytest.approx(beyond / 2 - 6.0, abs=1.0) and p["value"] > 2 * 6.0
    assert rep["outside_mm_total"] == pytest.approx(beyond - 2 * 6.0, abs=2.0)
    assert p["point"][1] in (pytest.approx(17.0), pytest.approx(23.0))
    assert rep["outside_max_mm"] == pytest.approx(17.0, abs=0.1)  # y 23 against the arm's edge at 6
    assert rep["layers"][2]["outside_mm2"] > 0.8 * beyond * 6.0  # ~ a bead's width along it
    # the same program unshifted: nothing outside
    assert not outside_problems(check_cross(graph, res, res.artifacts["post.gcode"].decode()))


def test_the_old_sequencer_on_the_filleted_panel_fails_outside(monkeypatch):
    """The fault as it shipped: the filleted L walls read as two-pass serpentines (tests/preflight/
    test_conserve.py keeps that pass detection) and welded across their cell; the program as written
    fails on every odd layer, wall2 and wall6, 66.4 mm each."""
    from waamflow.sequencing import seams

    from test_conserve import passes_before_the_fix, run_panel

    monkeypatch.setattr(seams, "_passes", passes_before_the_fix)
    monkeypatch.setattr(seams, "WALL_PATH", frozenset())  # walls re-threaded like fills, as they were then
    res = run_panel()
    found = [p for p in res.preflight["problems"] if p["check"] == "outside"]
    assert res.preflight["verdict"] == "fail" and len(found) == 1 and found[0]["node"] == "post"
    p = found[0]
    assert p["severity"] == "fail" and p["layer"] == 1 and p["section"] in ("wall2", "wall6")
    assert "14 arc-ON stretch(es)" in p["message"] and "layers 1, 3, 5, 7, 9, 11, 13" in p["message"]
    assert p["value"] == pytest.approx(66.28, abs=1.0) and res.preflight["outside_mm"] == p["value"]


# ---- hand-written programs on a 40 × 20 × 6 mm box: what is legitimately outside ------------------
BOX_L, BOX_W, BOX_H, BOX_LAYER, BOX_BEAD = 40.0, 20.0, 6.0, 1.5, 6.0


def box_part() -> Part:
    import trimesh

    m = trimesh.creation.box(extents=(BOX_L, BOX_W, BOX_H))
    m.apply_translation((0, 0, BOX_H / 2))
    return Part("solid", "part", vertices=np.asarray(m.vertices), faces=np.asarray(m.faces))


def box_gcode(runs_of_layer, travel=()):
    """runs_of_layer(z) → [run, ...], run = [(x, y), ...]; travel: extra G0 points before each layer."""
    out = [
        "; waamflow-post: arc_on=M3 arc_off=M5 dwell_units=s feed_units=mm/min end=M30",
        '; waamflow-weld: wire_feed_speed[m/min]="M67 E0 Q{value:.2f}"',
        "G21",
        "G90",
    ]
    for i in range(int(BOX_H / BOX_LAYER)):
        z = (i + 1) * BOX_LAYER
        out.append(f"; layer {i} z={z:.3f}")
        out += [f"G0 X{x:.3f} Y{y:.3f} Z{z + 20:.3f}" for x, y in travel]
        for j, run in enumerate(runs_of_layer(z)):
            out += [f"; section s{j}", f"G0 X{run[0][0]:.3f} Y{run[0][1]:.3f} Z{z:.3f}", "M67 E0 Q4.00", "M3"]
            out += [f"G1 X{x:.3f} Y{y:.3f} Z{z:.3f} F480" for x, y in run[1:]]
            out.append("M5")
    return "\n".join(out + ["M30"])


def box_check(text, stock_mm=None, **kw):
    return check_program(box_part(), read_gcode(text), "post", PreflightSettings(**kw), BOX_BEAD, stock_mm=stock_mm)


YS = (-7.0, -2.5, 2.5, 7.0)


def serpentine(x0=-17.0, x1=17.0, ys=YS):
    pts = []
    for k, y in enumerate(ys):
        pts += [(x0, y), (x1, y)] if k % 2 == 0 else [(x1, y), (x0, y)]
    return pts


def test_edge_overhang_and_travel_outside_do_not_count():
    # outer passes on the part's edge (y = ±10: half the bead overhangs), the torch travelling 50 mm
    # beyond the part between layers with the arc off
    rep = box_check(box_gcode(lambda z: [serpentine(ys=(-10.0, -3.5, 3.5, 10.0))], travel=[(70.0, 40.0)]))
    assert not outside_problems(rep) and rep["outside_mm"] == 0.0 and rep["outside_mm2"] == 0.0
    assert rep["outside_share"] == 0.0


def test_run_ups_are_stock_up_to_the_recipes_extension():
    # every pass starts 20 mm before the part's end (x = −40 against −20): the bead clears the part
    # over 17 mm of it (beyond ½ bead), 14 mm of it more than a bead width off
    def runs(z):
        return [[(-40.0, y), (17.0, y)] for y in YS]

    assert not outside_problems(box_check(box_gcode(runs), stock_mm=20.0 + BOX_BEAD))  # extension_before 20
    rep = box_check(box_gcode(runs), stock_mm=BOX_BEAD)  # no extension stated
    found = outside_problems(rep)
    assert [p["severity"] for p in found] == ["warn"]  # deep 14 − 6 = 8 ≤ 12 mm: not a fail
    assert found[0]["value"] == pytest.approx(17.0 - BOX_BEAD, abs=1.0) and found[0]["layer"] == 0
    assert rep["layers"][0]["outside_stock_mm"] == pytest.approx(4 * BOX_BEAD, abs=0.1)


def test_a_link_bulging_out_of_the_part_mid_run_fails_whatever_the_stock():
    # the link between two passes swings 15 mm beyond the part's end: stock never excuses a run's middle
    def runs(z):
        return [[(-17.0, -7.0), (17.0, -7.0), (35.0, -7.0), (35.0, 7.0), (17.0, 7.0), (-17.0, 7.0)]]

    rep = box_check(box_gcode(runs), stock_mm=50.0)
    found = outside_problems(rep)
    assert found and found[0]["severity"] == "fail" and found[0]["section"] == "s0"
    # x > 23 (beyond ½ bead of the end at 20): 12 + 14 + 12 mm of centre line
    assert found[0]["value"] == pytest.approx(38.0, abs=1.0)
    assert rep["outside_max_mm"] == pytest.approx(15.0, abs=0.01)
    off = box_check(box_gcode(runs), stock_mm=50.0, outside="off")
    assert not outside_problems(off) and off["outside_mm"] == found[0]["value"]  # figures kept, no verdict


def test_a_section_is_grown_by_half_a_bead_only_at_layers_with_an_excursion(cross, monkeypatch):
    """The reach (section buffered by ½ bead, for outside_mm2) costs a buffer of the section: 0.3-0.5 s
    on the bench vase's 133 layers of 4,000-vertex rings with nothing outside. Only the shifted
    layer's section is grown; the figures are the ones the test above checks."""
    from shapely.geometry.base import BaseGeometry

    grown = []
    buffer = BaseGeometry.buffer

    def counted(self, distance, *a, **k):
        if self.geom_type in ("Polygon", "MultiPolygon") and k.get("quad_segs") == 8:
            grown.append(round(float(distance), 6))
        return buffer(self, distance, *a, **k)

    monkeypatch.setattr(BaseGeometry, "buffer", counted)
    graph, res = cross
    text = res.artifacts["post.gcode"].decode()
    assert not outside_problems(check_cross(graph, res, text)) and grown == []
    rep = check_cross(graph, res, shift_run(text, 2, "bs1/B", 20.0))
    assert grown == [3.0] and rep["layers"][2]["outside_mm2"] > 0.8 * 2 * 51.0 * 6.0


def test_an_unbuilt_rib_is_uncovered_not_a_top_gap(panel):
    """The panel's program without rib wall7 on every layer: the 3D check's farthest unreached point
    is the rib's far end, beside the beads, which was reported as "the deposit ends 42.27 mm short of
    the part's top (30.00 mm)" — more than the part is high. It is the uncovered check's: 8.0 % of
    the part gets no bead; the deposit reaches the top (top gap 0)."""
    graph, res = panel
    doc = copy.deepcopy(json.loads(res.artifacts["sequence.toolpath.json"]))
    for layer in doc["layers"]:
        layer["sections"] = [s for s in layer["sections"] if s["key"] != "wall7"]
    rep = check_panel_doc(graph, res, doc)
    assert rep["top_gap_mm"] == 0.0
    assert not [p for p in rep["problems"] if p["check"] == "top_gap"]
    (unc,) = [p for p in rep["problems"] if p["check"] == "uncovered"]
    assert unc["severity"] == "fail" and rep["uncovered_share"] == pytest.approx(0.080, abs=0.005)


def test_a_panel_without_its_last_three_layers_ends_six_mm_short(panel):
    """Without its last 3 layers of 2 mm the deposit ends 6 mm below the panel's 30 mm top: the top
    gap is the distance along the build to the highest point of the part out of reach, 5.5 mm (the
    samples lie half their 1 mm step below the top); it was 3.03 (the distance less the reach)."""
    graph, res = panel
    doc = copy.deepcopy(json.loads(res.artifacts["sequence.toolpath.json"]))
    assert len(doc["layers"]) == 15
    doc["layers"] = doc["layers"][:-3]
    rep = check_panel_doc(graph, res, doc)
    (gap,) = [p for p in rep["problems"] if p["check"] == "top_gap"]
    assert gap["severity"] == "fail" and rep["top_gap_mm"] == pytest.approx(5.5, abs=0.05)


def test_a_wall_that_stops_early_is_named_where_the_rest_reaches_the_top(panel):
    """Rib wall7 without its last 3 layers, every other wall built to the 30 mm top: the part goes on
    5.5 mm above the rib's last bead. It said "the deposit ends 5.50 mm short of the part's top
    (30.00 mm); the last deposited layer is 14" — layer 14 being the top (compas_slicer's
    facade_infill read the same way with its deposit at the part's top). Now it says where, how far
    above which layer's bead, and that the deposit reaches the top elsewhere."""
    graph, res = panel
    doc = copy.deepcopy(json.loads(res.artifacts["sequence.toolpath.json"]))
    for layer in doc["layers"][-3:]:
        layer["sections"] = [s for s in layer["sections"] if s["key"] != "wall7"]
    rep = check_panel_doc(graph, res, doc)
    (gap,) = [p for p in rep["problems"] if p["check"] == "top_gap"]
    assert gap["severity"] == "fail" and rep["top_gap_mm"] == pytest.approx(5.5, abs=0.05)
    assert gap["layer"] == 11 and gap["section"] == "wall7"
    msg = gap["message"]
    assert "5.50 mm above its nearest bead (layer 11, section wall7, z 24.00 mm)" in msg
    assert "the deposit reaches the part's top (30.00 mm) elsewhere" in msg and "last deposited layer" not in msg
    wall = [
        s for s in json.loads(res.artifacts["sequence.toolpath.json"])["layers"][11]["sections"] if s["key"] == "wall7"
    ]
    xy = np.array(wall[0]["points"])[:, :2]
    assert np.hypot(*(xy - np.array(gap["point"][:2])).T).min() < 4.0  # the point named lies on the rib


def test_a_panel_of_one_layer_ends_far_short_of_its_top(panel):
    """Only the panel's first layer (2 mm of its 30 mm): no layer before or after gives the build
    direction, so it is +z; the top gap is the distance up to the highest point of the part out of
    reach, 27.5 mm (the samples lie 0.5 mm below the top), not 0."""
    graph, res = panel
    doc = copy.deepcopy(json.loads(res.artifacts["sequence.toolpath.json"]))
    doc["layers"] = doc["layers"][:1]
    rep = check_panel_doc(graph, res, doc)
    (gap,) = [p for p in rep["problems"] if p["check"] == "top_gap"]
    assert gap["severity"] == "fail" and rep["top_gap_mm"] == pytest.approx(27.5, abs=0.05)


def test_midsurface_distance_through_the_tree_is_the_distance_to_every_curve():
    """A point's distance to a midsurface of thousands of curves is its distance to the nearest
    one, found through an STRtree: exactly what GEOS gives for the distance to all of them as one
    MultiLineString (which walked every curve's segments per point: recover01.dxf's ~3,000 walls a
    layer), on curves of 2-9 points and long ones (circles of 2,000-5,000 vertices, a 3,001-point
    walk: indexed in pieces of PIECE_SEGMENTS segments, as hatch_issues.dxf's circles now are),
    points on, near and far from them."""
    from waamflow.preflight.outside import PIECE_SEGMENTS, distance_to_midsurface, midsurface_lines

    rng = np.random.default_rng(7)
    curves = []
    for _ in range(2000):
        start = rng.uniform(0, 1000, 2)
        curves.append(start + np.cumsum(rng.normal(0, 8, (int(rng.integers(2, 10)), 2)), axis=0))
    for n, r in ((2000, 300.0), (5000, 120.0)):
        t = np.linspace(0.0, 2 * np.pi, n)
        curves.append(np.column_stack([500 + r * np.cos(t), 500 + r * np.sin(t)]))
    curves.append(np.cumsum(rng.normal(0, 3, (3001, 2)), axis=0) + 400)
    on = np.vstack([c[int(rng.integers(len(c)))] for c in curves[:300] + curves[-3:] * 20])
    pts = np.vstack([on, on + rng.normal(0, 2, on.shape), rng.uniform(-200, 1200, (400, 2))])
    want = shapely.distance(MultiLineString(curves), shapely.points(pts))
    index = midsurface_lines(curves)
    got = index.distance(pts)
    assert np.array_equal(got, want)
    assert (got == 0).sum() >= 360 and got.max() > 50  # on the curves, and far from them
    pieces = index.tree.geometries
    assert shapely.get_num_coordinates(pieces).max() == PIECE_SEGMENTS + 1
    segments = sum(len(c) - 1 for c in curves)
    assert int((shapely.get_num_coordinates(pieces) - 1).sum()) == segments  # every segment, once
    width = 4.0
    assert np.array_equal(distance_to_midsurface(curves, pts, width), np.maximum(0.0, want - width / 2))


def test_points_the_k_d_tree_finds_near_the_midsurface_are_at_its_exact_distance_0():
    """distance_to_midsurface asks the exact (STRtree) distance only of the points its k-d tree of
    the curves' points (at most half a bead apart) does not find within half a bead: the result is
    the exact distance's, bit for bit, on points on, near (around half a bead) and far from the
    curves; a lone point is no curve (none of the points near it is certified near)."""
    from waamflow.preflight.outside import MidsurfaceIndex, _densified, distance_to_midsurface

    rng = np.random.default_rng(11)
    curves = [
        rng.uniform(0, 500, 2) + np.cumsum(rng.normal(0, 20, (int(rng.integers(2, 40)), 2)), axis=0) for _ in range(60)
    ]
    t = np.linspace(0.0, 2 * np.pi, 700)
    curves.append(np.column_stack([250 + 90 * np.cos(t), 250 + 90 * np.sin(t)]))
    width = 4.0
    index = MidsurfaceIndex(curves + [np.array([[900.0, 900.0]])])
    pts = []
    for c in curves:
        k = rng.integers(len(c) - 1, size=40)
        f = rng.uniform(0, 1, (40, 1))
        on = c[k] + f * (c[k + 1] - c[k])
        pts += [on, on + rng.normal(0, 1.5, on.shape), on + rng.normal(0, 3.0, on.shape)]
    pts += [rng.uniform(-100, 600, (2000, 2)), np.array([[900.0, 900.0], [900.5, 900.0]])]
    pts = np.vstack(pts)
    want = np.maximum(0.0, index.distance(pts) - width / 2.0)
    got = distance_to_midsurface(index, pts, width)
    assert np.array_equal(got, want)
    near = index.within(pts, width / 2.0)
    assert 0.5 * len(pts) < near.sum() < len(pts) and (got[near] == 0).all()
    assert not near[-2:].any() and (got[-2:] > 100).all()  # the lone point certifies nothing
    for c in curves[:5] + curves[-1:]:
        d = _densified(c, 2.0)
        steps = np.linalg.norm(np.diff(d, axis=0), axis=1)
        assert steps.max() <= 2.0 + 1e-9 and np.array_equal(d[[0, -1]], c[[0, -1]])
        assert steps.sum() == pytest.approx(np.linalg.norm(np.diff(c, axis=0), axis=1).sum(), rel=1e-12)
