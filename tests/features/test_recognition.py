"""Feature recognition by valence (Venturini et al. 2018): counts of each kind on hand-made sketches."""

import json
import math
from collections import Counter
from pathlib import Path

import numpy as np
from curve_shapes import c, circle
import pytest
from shapely.geometry import LineString

from waamflow.core.model import Layer, Layered
from waamflow.features import FeatureSet, RecognitionSpec, features_for_layer, recognise, recognise_layers

PANEL = Path(__file__).resolve().parents[2] / "graphs" / "parts" / "panel.json"


def kinds(curves, **kw):
    return Counter(f["kind"] for f in recognise(curves, RecognitionSpec(**kw)))


@pytest.mark.parametrize(
    "name, curves, expected",
    [
        ("X", [c((-10, 0), (10, 0)), c((0, -10), (0, 10))], {"direct_crossing": 1, "free_end": 4}),
        ("T", [c((-10, 0), (10, 0)), c((0, 0), (0, 10))], {"t_crossing": 1, "free_end": 3}),
        ("L", [c((0, 0), (10, 0)), c((10, 0), (10, 10))], {"corner": 1, "free_end": 2}),
        ("smooth", [c((0, 0), (10, 0)), c((10, 0), (20, 1))], {"continuous": 1, "free_end": 2}),
        ("free", [c((0, 0), (10, 0))], {"free_end": 2}),
        (
            "four",
            [c((0, 0), (10, 0)), c((0, 0), (0, 10)), c((0, 0), (-10, 0)), c((0, 0), (0, -10))],
            {"four_direct_crossing": 1, "free_end": 4},
        ),
        ("Y", [c((0, 0), (10, 0)), c((0, 0), (-5, 8)), c((0, 0), (-5, -8))], {"odd_t_crossing": 1, "free_end": 3}),
        (
            "oddX",
            [c((-10, 0), (10, 0)), c((0, 0), (1, 10)), c((0, 0), (-1, -10))],
            {"odd_direct_crossing": 1, "free_end": 4},
        ),
        (
            "closed-T",
            [c((0, 0), (20, 0), (20, 20), (0, 20), (0, 0)), c((10, 0), (10, 10))],
            {"t_crossing": 1, "corner": 4, "free_end": 1},
        ),
    ],
)
def test_counts_per_kind(name, curves, expected):
    assert kinds(curves) == expected


def test_study_valences_reported():
    feats = recognise([c((-10, 0), (10, 0)), c((0, -10), (0, 10))])
    x = next(f for f in feats if f["kind"] == "direct_crossing")
    assert x["study_valence"] == [1, 0] and x["branches"] == 4 and x["entities"] == [0, 1]
    assert x["point"] == [0.0, 0.0]
    assert x["corner_angles_deg"] == [90.0, 90.0, 90.0, 90.0]


def test_corner_vs_continuous_by_threshold():
    # walls turning by 20°: continuous at a 30° threshold, corner at 15°
    turn = math.radians(20)
    curves = [c((0, 0), (10, 0)), c((10, 0), (10 + 10 * math.cos(turn), 10 * math.sin(turn)))]
    assert kinds(curves, corner_angle_deg=30)["continuous"] == 1
    assert kinds(curves, corner_angle_deg=15)["corner"] == 1
    f = next(f for f in recognise(curves) if f["kind"] == "continuous")
    assert f["angle_deg"] == pytest.approx(160.0, abs=1e-6)


def test_merge_tolerance():
    # the stem ends 5e-7 mm off the wall: one point (study: 1e-6 mm); 1e-3 mm off: a free end
    near = [c((-10, 0), (10, 0)), c((0, 5e-7), (0, 10))]
    far = [c((-10, 0), (10, 0)), c((0, 1e-3), (0, 10))]
    assert kinds(near) == {"t_crossing": 1, "free_end": 3}
    assert kinds(far) == {"free_end": 4}
    assert kinds(far, merge_tol=2e-3) == {"t_crossing": 1, "free_end": 3}


def test_tubular_isolated_vs_not():
    wall = c((0, 0), (40, 0))
    far = circle(40, 40, 8)  # 32 mm from the wall: outside the 15 mm half-encumbrance band
    near = circle(40, 20, 8)  # 12 mm from the wall: inside it
    f_far = [f for f in recognise([wall, far]) if f["kind"] == "tubular"]
    f_near = [f for f in recognise([wall, near]) if f["kind"] == "tubular"]
    assert len(f_far) == 1 and f_far[0]["isolated"] is True
    assert len(f_near) == 1 and f_near[0]["isolated"] is False
    # a smaller torch makes the near tube isolated
    f_small = [f for f in recognise([wall, near], RecognitionSpec(encumbrance=20.0)) if f["kind"] == "tubular"]
    assert f_small[0]["isolated"] is True
    assert f_far[0]["length_mm"] == pytest.approx(2 * 64 * 8 * math.sin(math.pi / 64), abs=1e-6)
    assert f_far[0]["point"] == pytest.approx([40, 40], abs=1e-6)


def test_tubular_chained_from_open_curves_and_touching_loop_is_not_tubular():
    half1 = circle(0, 0, 10, 64)[:33]
    half2 = np.vstack([circle(0, 0, 10, 64)[32:]])
    feats = recognise([half1, half2])
    assert Counter(f["kind"] for f in feats) == {"continuous": 2, "tubular": 1}
    # a closed loop crossed by a wall is walls and crossings, not a tubular
    feats = recognise([circle(0, 0, 10), c((-20, 0), (20, 0))])
    assert Counter(f["kind"] for f in feats) == {"direct_crossing": 2, "free_end": 2}


def test_panel_sketch_counts():
    doc = json.loads(PANEL.read_text())
    feats = recognise([np.array(cv) for cv in doc["curves"]])
    counts = Counter(f["kind"] for f in feats)
    assert counts == {
        "t_crossing": 9,
        "corner": 4,
        "direct_crossing": 2,
        "four_direct_crossing": 1,
        "free_end": 1,
        "tubular": 1,
    }
    assert [f["isolated"] for f in feats if f["kind"] == "tubular"] == [True]


def test_layers_first_layer_reused_and_fresh_recognition():
    curves = (LineString([(-10, 0), (10, 0)]), LineString([(0, -10), (0, 10)]))
    layers = Layered(tuple(Layer(i, 2.0 * (i + 1), 2.0, curves=curves) for i in range(3)))
    fs = recognise_layers(layers)
    assert isinstance(fs, FeatureSet) and set(fs.layers) == {0}
    assert fs.to_json()["features"][0]["kind"] in {"direct_crossing", "free_end"}
    again = features_for_layer(fs, layers[2])
    assert Counter(f["kind"] for f in again) == {"direct_crossing": 1, "free_end": 4}
    assert {f["layer"] for f in again} == {2}
    other = Layer(3, 8.0, 2.0, curves=(LineString([(0, 0), (10, 0)]),))
    assert Counter(f["kind"] for f in features_for_layer(fs, other)) == {"free_end": 2}


def test_curve_crossing_itself():
    loop = c((-10, 0), (10, 0), (10, 10), (0, 10), (0, -10))  # crosses its first segment at (0, 0)
    feats = recognise([loop])
    assert Counter(f["kind"] for f in feats) == {"direct_crossing": 1, "corner": 3, "free_end": 2}
    x = next(f for f in feats if f["kind"] == "direct_crossing")
    assert x["point"] == [0.0, 0.0] and x["entities"] == [0] and x["branches"] == 4


def test_walls_joined_end_to_end_at_a_shallow_angle_list_a_continuous_junction():
    """Two straight walls joined into one polyline (as the sketch reader joins DXF LINEs) meeting at
    12° still give their junction, `continuous`, with the angle between the walls."""
    turn = math.radians(12)
    pts = np.array([[0, 0], [100, 0], [100 + 80 * math.cos(turn), 80 * math.sin(turn)]])
    feats = recognise([pts])
    (j,) = [f for f in feats if f["kind"] in ("corner", "continuous")]
    assert j["kind"] == "continuous" and j["point"] == [100.0, 0.0]
    assert j["angle_deg"] == pytest.approx(168.0, abs=1e-6)
    # the same geometry at 45° is a corner; as two separate curves it is the same junction
    assert kinds([pts], corner_angle_deg=10)["corner"] == 1
    two = recognise([pts[:2], pts[1:]])
    (j2,) = [f for f in two if f["kind"] in ("corner", "continuous")]
    assert (j2["kind"], j2["angle_deg"]) == ("continuous", pytest.approx(168.0, abs=1e-6))
    # a rectangle with one shallow kink on a long side: 4 corners + 1 continuous
    rect = np.array([[0, 0], [60, 0], [120, 5], [120, 40], [0, 40], [0, 0]], float)
    k = kinds([rect])
    assert (k["corner"], k["continuous"]) == (4, 1)


def test_discretised_arcs_are_one_wall_not_a_chain_of_junctions():
    t = np.linspace(0, math.pi, 40)  # half circle r 50, 4.6° per chord
    arc = np.column_stack([50 * np.cos(t), 50 * np.sin(t)])
    k = kinds([arc])
    assert k["continuous"] == 0 and k["corner"] == 0
    # tangent straight legs on both ends of the arc: still no junction
    line_arc = np.vstack([[[50, -30]], arc, [[-50, -30]]])
    k = kinds([line_arc])
    assert k["continuous"] == 0 and k["corner"] == 0
    ring = circle(0, 0, 30, 64)
    assert kinds([ring])["continuous"] == 0


def _joint_vertices_by_scan(curves, joints, tol, skip):
    """The reference: every joint against every skip point and every curve's vertices (what
    recognition did before its k-d trees; minutes on a floor plan's thousands of joints)."""
    from waamflow.features.junctions import _unit, is_closed

    out = []
    for q in np.asarray(joints, float):
        if any(np.hypot(*(q - s)) <= tol for s in skip):
            continue
        for ci, cv in enumerate(curves):
            closed = is_closed(cv, tol)
            pts = cv[:-1] if closed else cv
            d = np.hypot(*(pts - q).T)
            k = int(np.argmin(d))
            if d[k] > tol or (not closed and k in (0, len(pts) - 1)):
                continue
            n = len(pts)
            u, v = _unit(pts[(k - 1) % n] - pts[k]), _unit(pts[(k + 1) % n] - pts[k])
            if np.any(u) and np.any(v):
                out.append((pts[k], math.degrees(math.acos(float(np.clip(u @ v, -1.0, 1.0)))), ci))
            break
    return out


@pytest.mark.parametrize("seed", range(6))
def test_joint_vertices_match_the_scan_of_every_curve(seed):
    """Joints matched to curve vertices through k-d trees: the same joints, vertices, angles and
    curves as the scan of every curve per joint, on random polylines (open and closed, sharing
    vertices) whose joints lie on vertices, at ends, within and just beyond tol, and nowhere."""
    from waamflow.features.recognition import _joint_vertices, _tree

    rng = np.random.default_rng(seed)
    tol = 1e-3
    curves = []
    for _ in range(40):
        pts = rng.integers(0, 30, size=(int(rng.integers(2, 9)), 2)).astype(float)  # shared grid vertices
        pts = pts[np.r_[True, np.any(np.diff(pts, axis=0) != 0, axis=1)]]
        if len(pts) >= 3 and rng.random() < 0.3:
            pts = np.vstack([pts, pts[:1]])
        if len(pts) >= 2:
            curves.append(pts)
    verts = np.vstack(curves)
    on = verts[rng.integers(0, len(verts), 150)]
    near = on + rng.normal(size=on.shape) * tol * 0.5
    beyond = on + np.array([tol * 1.5, 0.0])
    joints = np.vstack([on, near, beyond, rng.random((50, 2)) * 30])
    skip = verts[rng.integers(0, len(verts), 20)]
    got = _joint_vertices(curves, joints, tol, _tree(skip))
    want = _joint_vertices_by_scan(curves, joints, tol, skip)
    assert len(want) > 100  # the case exercises the matching, not only the misses
    assert [(tuple(p), ci) for p, _, ci in got] == [(tuple(p), ci) for p, _, ci in want]
    assert [a for _, a, _ in got] == pytest.approx([a for _, a, _ in want], abs=1e-12)
