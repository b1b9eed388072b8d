"""Programmed lengths on the robot study's objective rectangles (da Silva Viola et al. 2023)."""

import math

import numpy as np
import pytest
from shapely.geometry import box

from waamflow.paths import PATTERNS, StrategySpec, plan_section

from . import helpers as h

SMALL = box(0, 0, 43, 21.5)
LARGE = box(0, 0, 86, 43)


def plan(region, pattern, **kw):
    return plan_section(region, None, StrategySpec(pattern=pattern, **kw))


@pytest.mark.parametrize(
    "pattern, kw, published, rel",
    [
        ("raster", {}, 387.910, 0.01),
        ("semicircular", {}, 242.603, 0.01),
        ("triangular", {"angle_deg": 45}, 261.301, 0.01),
        ("triangular", {"angle_deg": 60}, 250.437, 0.01),
        ("rectangular", {}, 217.600, 0.02),
        ("spiral", {}, 215.710, 0.02),
        ("swiping", {}, 464.246, 0.02),
    ],
)
def test_small_or_matches_published_lengths(pattern, kw, published, rel):
    assert plan(SMALL, pattern, **kw).length == pytest.approx(published, rel=rel)


@pytest.mark.parametrize("region, L, W", [(SMALL, 43, 21.5), (LARGE, 86, 43)])
def test_lengths_follow_the_rules(region, L, W):
    assert plan(region, "raster").length == pytest.approx(h.raster(L, W), abs=1e-6)
    # half circles are chords within 0.01 mm sagitta: a hair shorter than the true arcs
    semi = plan(region, "semicircular").length
    assert semi == pytest.approx(h.semicircular(L, W), rel=1e-3)
    assert semi < h.semicircular(L, W)
    for angle in (45, 60, 90):
        assert plan(region, "triangular", angle_deg=angle).length == pytest.approx(h.triangular(L, W, angle), abs=1e-6)
    assert plan(region, "rectangular").length == pytest.approx(h.rectangular(L, W), abs=1e-4)
    assert plan(region, "spiral").length == pytest.approx(h.spiral(L, W), abs=1e-4)
    assert plan(region, "swiping").length == pytest.approx(h.swiping(L, W), abs=1e-4)


def test_large_or_expected_values():
    # the same rules on the large OR (10 passes, W_bound 1.565 mm)
    assert h.raster(86, 43) == pytest.approx(10 * 86 + 9 * math.hypot(86, 4.43))
    assert plan(LARGE, "rectangular").length == pytest.approx(10 * (86 - 3.13) + 9 * 4.43 + 3.13, abs=1e-4)


def test_semicircle_chordal_tolerance():
    coarse = plan(SMALL, "semicircular", chord_tol=0.5).length
    fine = plan(SMALL, "semicircular", chord_tol=0.001).length
    exact = h.semicircular(43, 21.5)
    assert coarse < fine < exact
    assert exact - fine < 0.01
    p = plan(SMALL, "semicircular", chord_tol=0.01)
    # sagitta of each chord of a radius-2.215 half circle ≤ 0.01 mm → chord ≤ 2·√(2·r·tol)
    link = p.segment_lengths[~p.inside]
    assert link.max() <= 2 * math.sqrt(2 * 2.215 * 0.01) + 1e-9


def test_semicircle_is_g1_smooth():
    p = plan(SMALL, "semicircular", chord_tol=0.001)
    d = np.diff(p.points, axis=0)
    d /= np.linalg.norm(d, axis=1)[:, None]
    turn = np.degrees(np.arccos(np.clip((d[1:] * d[:-1]).sum(axis=1), -1, 1)))
    # no corners: only the turns between chords of a half circle cut into k = 53 pieces (0.001 mm
    # sagitta at r = 2.215 mm), and half of that where a pass meets its half circle
    # (4 half circles: 4 × 52 inner turns of 180/53°, 8 half turns where they meet the passes)
    values, counts = np.unique(np.round(turn, 9), return_counts=True)
    assert values == pytest.approx([90 / 53, 180 / 53], abs=1e-9)
    assert counts.tolist() == [8, 4 * 52]


def test_triangular_apex_angle():
    for angle in (45, 60, 90, 120):
        p = plan(SMALL, "triangular", angle_deg=angle)
        out = np.flatnonzero(~p.inside)
        a, b = p.points[out[0]], p.points[out[0] + 1]
        c = p.points[out[0] + 2]
        u, v = a - b, c - b
        got = math.degrees(math.acos(u @ v / np.linalg.norm(u) / np.linalg.norm(v)))
        assert got == pytest.approx(angle, abs=1e-9)


def test_raster_arc_off_on_returns_and_switches():
    p = plan(SMALL, "raster")
    assert p.arc_switches == 10  # on and off at both ends of each of 5 passes
    assert p.arc_on_length == pytest.approx(5 * 43)
    assert p.inside.all()


@pytest.mark.parametrize(
    "pattern, kw, outside",
    [
        ("semicircular", {}, None),
        ("triangular", {"angle_deg": 45}, 4 * 2 * 2.215 / math.sin(math.radians(22.5))),
        ("triangular", {"angle_deg": 60}, 4 * 2 * 4.43),  # equilateral: sides = W_WB
    ],
)
def test_arc_outside_off_switches_at_every_crossing(pattern, kw, outside):
    on = plan(SMALL, pattern, arc_outside="on", **kw)
    off = plan(SMALL, pattern, arc_outside="off", **kw)
    assert on.arc_switches == 2 and on.arc.all()
    assert off.arc_switches == 10
    assert off.arc_on_length == pytest.approx(5 * 43)
    assert off.length == pytest.approx(on.length)
    if outside is not None:
        assert off.outside_length == pytest.approx(outside)


@pytest.mark.parametrize("pattern", ["rectangular", "spiral", "swiping"])
def test_in_or_patterns_stay_inside(pattern):
    p = plan(SMALL, pattern)
    assert p.inside.all() and p.arc.all()
    assert p.arc_switches == 2
    inner = box(1.89 - 1e-5, 1.89 - 1e-5, 43 - 1.89 + 1e-5, 21.5 - 1.89 + 1e-5)  # inset is nudged by 1e-6
    # everything but the lead-in/out keeps the study's boundary margin on all sides
    if pattern != "swiping":
        body = p.points[1:-1]
        assert all(inner.covers(__import__("shapely").points(q)) for q in body)


def test_swiping_reversal_and_overlap():
    p = plan(SMALL, "swiping")
    d = np.diff(p.points, axis=0)
    adv = np.abs(d[:, 1])
    assert np.allclose(adv, 4.43 / 3)  # each leg advances a third of the spacing
    u = d / np.linalg.norm(d, axis=1)[:, None]
    interior = np.degrees(np.arccos(np.clip(-(u[1:] * u[:-1]).sum(axis=1), -1, 1)))
    assert interior == pytest.approx(np.full(len(interior), 2 * math.degrees(math.atan(4.43 / 3 / 38.57))))
    assert p.points[:, 0].min() == pytest.approx(4.43 / 2)
    assert p.points[:, 0].max() == pytest.approx(43 - 4.43 / 2)


def test_extensions_run_up_outside_the_section():
    p = plan(SMALL, "raster", extension_before=4.5, extension_after=3.6, arc_outside="off")
    # run-ups of 8.1 mm per pass, plus the parts of the 51.1 mm-long returns beyond the OR ends
    ret = math.hypot(51.1, 4.43)
    assert p.outside_length == pytest.approx(5 * 8.1 + 4 * ret * 8.1 / 51.1)
    assert p.length == pytest.approx(5 * 51.1 + 4 * ret)
    assert p.arc_on_length == pytest.approx(5 * 43)
    assert p.arc_switches == 10
    assert p.points[:, 0].min() == pytest.approx(-4.5)
    assert p.points[:, 0].max() == pytest.approx(46.6)
    s = plan(SMALL, "semicircular", extension_before=4.5, extension_after=3.6)
    # each link joins a run-out (3.6) and the next pass's run-up (4.5) on the same end: a 0.9 mm
    # straight stub keeps the half circle tangent to both
    assert s.length == pytest.approx(plan(SMALL, "semicircular").length + 5 * 8.1 + 4 * 0.9)
    assert s.points[:, 0].max() == pytest.approx(43 + 4.5 + 2.215, abs=0.01)  # within the chord tolerance


def test_every_pattern_registered_and_runs_on_the_or():
    for name in PATTERNS:
        p = plan(SMALL, name)
        assert p.length > 43
        assert len(p.arc) == len(p.points) - 1 == len(p.inside)
