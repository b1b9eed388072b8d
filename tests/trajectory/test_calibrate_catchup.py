"""The arc-OFF catch-up of the user's own robot, identified from a trace (issue #23, item 6).

The study says the controller "catches up" after each arc-OFF stop by cutting the path outside
the OR harder; how much is a property of the controller, not of the study's KR 100 (the shipped
0.232 is fitted to its Table-5 arc-OFF column, see trajectory/MODEL.md). A robot that cuts harder
or softer is measured with a trace of a program with arc-OFF links, and `fit_trace` (what the
calibrate-robot node runs) must give back its catch-up and so the length it really travels
outside the OR.
"""

import pytest

from waamflow.trajectory import study
from waamflow.trajectory.calibrate import fit_trace, read_trace_csv, trace_csv
from waamflow.trajectory.profile import load_profile
from waamflow.trajectory.simulate import simulate

KUKA = load_profile("kuka_kr100ha_krc2")


@pytest.mark.parametrize("speed, catchup", [(10.0, 0.7), (40.0, 0.55), (10.0, 0.05)])
def test_a_traced_catchup_is_recovered_with_the_length_outside(speed, catchup):
    moves = study.triangular(speed, 45.0, False)
    robot = KUKA.with_values(catchup=catchup)
    truth = simulate(moves, robot).metrics
    meas = read_trace_csv(trace_csv(simulate(moves, robot)), "synthetic robot")
    # the fit starts from the shipped 0.232 and knows every other constant
    fitted, info = fit_trace(KUKA, moves, meas, ("catchup",))
    assert fitted.catchup == pytest.approx(catchup, rel=0.05)
    got = simulate(moves, fitted).metrics
    assert got["actual_length_outside_mm"] == pytest.approx(truth["actual_length_outside_mm"], rel=0.01)
    assert got["total_time_s"] == pytest.approx(truth["total_time_s"], rel=0.005)
    assert info["rms_position_error_mm"] < 0.01


def test_the_catchup_shortens_the_travel_outside_monotonically():
    """0 → 1 cuts the 45° triangles' arc-OFF links harder and harder (10 mm/s, small OR): the
    length outside falls from no shortening to ~40 % shorter than with the arc ON throughout."""
    on = simulate(study.triangular(10.0, 45.0, True), KUKA).metrics["actual_length_outside_mm"]
    outside = [
        simulate(study.triangular(10.0, 45.0, False), KUKA.with_values(catchup=c)).metrics["actual_length_outside_mm"]
        for c in (0.0, 0.25, 0.5, 0.75, 1.0)
    ]
    assert all(a > b for a, b in zip(outside, outside[1:]))
    assert outside[0] / on == pytest.approx(1.0, abs=0.01)
    assert 0.55 < outside[-1] / on < 0.65
