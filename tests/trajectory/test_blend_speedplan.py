"""Blend geometry and the ruckig speed plan (trajectory.blend, trajectory.speedplan)."""

import math

import numpy as np
import pytest
from ruckig import ControlInterface, InputParameter, Result, Ruckig, Trajectory

from waamflow.trajectory.blend import blend_path, polyline_distance
from waamflow.trajectory.speedplan import change_distance, evaluate, plan_spans, profile_spans, reachable_speed

SQUARE = np.array([[0, 0, 0], [20, 0, 0], [20, 20, 0], [0, 20, 0]], float)


def test_arc_blend_of_a_right_angle():
    stop = np.zeros(4, bool)
    bp = blend_path(SQUARE, np.full(3, 40.0), stop, mode="cdis", distance=5.0)
    assert bp.d[1] == pytest.approx(5.0)
    assert bp.radius[1] == pytest.approx(5.0)  # r = d / tan(90°/2)
    # apex of the arc: r (1/cos(45°) − 1) from the vertex
    apex = bp.points[1 + 4]  # middle sample of the first curve
    assert np.linalg.norm(apex - SQUARE[1]) == pytest.approx(5.0 * (math.sqrt(2) - 1), abs=1e-9)
    # length: 3·20 − 2·(2·5) + 2·(π/2·5)
    assert bp.length == pytest.approx(60 - 20 + 2 * (math.pi / 2 * 5), abs=0.05)
    assert bp.d[0] == 0 and bp.d[-1] == 0


def test_parabola_blend_and_half_segment_limit():
    pts = np.array([[0, 0, 0], [4, 0, 0], [4, 30, 0]], float)
    bp = blend_path(pts, np.full(2, 40.0), np.zeros(3, bool), mode="zone", distance=10.0)
    assert bp.d[1] == pytest.approx(2.0)  # half of the 4 mm segment
    apex = bp.points[1 + 4]
    # quadratic Bézier midpoint: d·cos(θ/2)/2 from the vertex, θ = 90° interior
    assert np.linalg.norm(apex - pts[1]) == pytest.approx(2.0 * math.cos(math.pi / 4) / 2, abs=1e-9)


def test_stops_and_speed_dependent_blend_start():
    stop = np.array([False, True, False, False])
    bp = blend_path(SQUARE, np.full(3, 10.0), stop, distance=5.0, apo_time_s=0.05, apo_min_mm=0.2)
    assert bp.d[1] == 0 and bp.cap[1] == 0  # exact stop
    assert bp.d[2] == pytest.approx(0.2 + 10.0 * 0.05)


def test_corner_cap_from_normal_jerk():
    bp = blend_path(SQUARE, np.full(3, 100.0), np.zeros(4, bool), distance=5.0, normal_acc=1e9, normal_jerk=1e4)
    assert bp.cap[1] == pytest.approx((1e4 * 25.0) ** (1 / 3))


def test_turn_rate_cap_scales_with_the_programmed_speed():
    """The direction turns no faster than v/ρ: a 90° blend of radius r < ρ runs at v·r/ρ, at
    any programmed speed; one of radius ≥ ρ is not capped by it."""
    for v in (10.0, 40.0):
        bp = blend_path(SQUARE, np.full(3, v), np.zeros(4, bool), distance=0.5, turn_radius=2.0)
        assert bp.radius[1] == pytest.approx(0.5)  # 90° turn: r = d / tan(45°)
        assert bp.cap[1] == pytest.approx(v * 0.5 / 2.0)
    wide = blend_path(SQUARE, np.full(3, 10.0), np.zeros(4, bool), distance=5.0, turn_radius=2.0)
    assert wide.cap[1] == pytest.approx(10.0)
    off = blend_path(SQUARE, np.full(3, 10.0), np.zeros(4, bool), distance=0.5)
    assert off.cap[1] == pytest.approx(10.0)


def test_polyline_distance():
    q = np.array([[10, 3, 0], [21, 10, 0], [-1, 21, 0]], float)
    d, seg = polyline_distance(q, SQUARE, np.array([0, 1, 2]))
    assert d == pytest.approx([3.0, 1.0, math.sqrt(2)])
    assert list(seg) == [0, 1, 2]


@pytest.mark.parametrize("v0,v1", [(0.0, 40.0), (40.0, 5.0), (3.0, 4.0), (10.0, 0.0)])
def test_change_distance_matches_ruckig_velocity_interface(v0, v1):
    a, j = 600.0, 50000.0
    otg, inp, tr = Ruckig(1), InputParameter(1), Trajectory(1)
    inp.control_interface = ControlInterface.Velocity
    inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [v0], [0.0]
    inp.target_velocity, inp.target_acceleration = [v1], [0.0]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [100.0], [a], [j]
    assert otg.calculate(inp, tr) == Result.Working
    p_end = tr.at_time(tr.duration)[0][0]
    assert change_distance(v0, v1, a, j) == pytest.approx(p_end, rel=1e-6)
    assert reachable_speed(min(v0, v1), p_end, a, j) == pytest.approx(max(v0, v1), rel=1e-6)


def test_speed_plan_stops_and_profiles():
    stop = np.array([True, False, True, False, True])
    pts = np.array([[0, 0, 0], [30, 0, 0], [30, 30, 0], [60, 30, 0], [60, 0, 0]], float)
    speed = np.full(4, 40.0)
    bp = blend_path(pts, speed, stop, distance=5.0, normal_acc=500, normal_jerk=1e4)
    spans = plan_spans(bp, speed, stop, 600.0, 50000.0)
    assert spans.v[0] == 0 and spans.v[-1] == 0
    assert spans.stop_after.sum() == 2  # vertex 2 and the end
    prof = profile_spans(spans, 600.0, 50000.0)
    # span profiles end where they should, never go backwards, respect the span's max speed
    idx = np.arange(len(spans.s0))
    s_end, v_end = evaluate(prof, idx, prof.duration)
    assert s_end == pytest.approx(spans.s1 - spans.s0, abs=1e-6)
    assert v_end == pytest.approx(spans.v[1:], abs=1e-6)
    assert prof.v.min() >= -1e-9
    assert np.all(prof.v.max(axis=1) <= np.maximum(spans.vmax, spans.v[:-1]) + 1e-6)


def test_profile_spans_without_limits_names_the_missing_one():
    """Spans built without their own limits and no limit passed: a ValueError naming the limit
    (before: a TypeError on None * None, deep in the profile); passing
    the constants profiles them as plan_spans' own would."""
    from waamflow.trajectory.speedplan import Spans

    stop = np.array([True, False, True, False, True])
    pts = np.array([[0, 0, 0], [30, 0, 0], [30, 30, 0], [60, 30, 0], [60, 0, 0]], float)
    bp = blend_path(pts, np.full(4, 40.0), stop, distance=5.0, normal_acc=500, normal_jerk=1e4)
    planned = plan_spans(bp, np.full(4, 40.0), stop, 600.0, 50000.0)
    bare = Spans(planned.s0, planned.s1, planned.vmax, planned.v, planned.stop_after, planned.vertex_after)
    with pytest.raises(ValueError, match=r"profile_spans: no acceleration \(a / Spans.acc\)"):
        profile_spans(bare)
    with pytest.raises(ValueError, match=r"profile_spans: no jerk \(j / Spans.jerk\)"):
        profile_spans(bare, 600.0)
    a, b = profile_spans(bare, 600.0, 50000.0), profile_spans(planned)
    assert len(a.duration) == len(planned.s0) == 2  # split at the exact stop at vertex 2
    assert np.array_equal(a.duration, b.duration) and np.array_equal(a.p, b.p)
