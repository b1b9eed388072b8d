"""The neutral plan every writer renders: order of arc switches, dwells, stops, statistics."""

from dataclasses import replace

import numpy as np
import pytest

from waamflow.core.model import LayerPaths, Layered
from waamflow.core.moves import flatten
from waamflow.program.plan import ArcOff, ArcOn, Dwell, Motion, PlanSettings, ProcessChange, plan_program

from conftest import build_toolpath


def test_steps_and_stops():
    moves = flatten(build_toolpath(2))
    plan = plan_program(moves, PlanSettings(ignition_dwell=0.4))
    steps = plan.steps
    motions = plan.motions
    assert len(motions) == len(moves.points)
    assert motions[0].start == -1 and motions[0].end == 0
    assert [m.end for m in motions] == list(range(len(moves.points)))
    for k, st in enumerate(steps):
        if isinstance(st, ArcOn):
            assert isinstance(steps[k + 1], Dwell) and steps[k + 1].reason == "ignition"
            assert isinstance(steps[k - 1], ProcessChange) or isinstance(steps[k - 1], Dwell)
    # a motion stops exactly where an arc switch or a dwell follows it, and at the end
    for k, st in enumerate(steps):
        if isinstance(st, Motion):
            nxt = next((s for s in steps[k + 1:] if isinstance(s, (Motion, ArcOn, ArcOff, Dwell))), None)
            assert st.stop == (nxt is None or not isinstance(nxt, Motion))
    on = sum(isinstance(s, ArcOn) for s in steps)
    assert on == sum(isinstance(s, ArcOff) for s in steps) == plan.stats["arc_on_count"] == 10


def test_zone_dwell_inside_run_and_time_estimate():
    tp = build_toolpath(1)
    lp = tp[0]
    wall = lp.sections[0]
    params = {k: dict(v) for k, v in wall.zone_params.items()}
    params["z1"]["dwell"] = 1.5
    tp = Layered((LayerPaths(lp.layer, (replace(wall, zone_params=params),)),))
    moves = flatten(tp)
    plan = plan_program(moves, PlanSettings(ignition_dwell=0.3, travel_speed=50.0))
    dwells = [(s.reason, s.seconds, s.point) for s in plan.steps if isinstance(s, Dwell)]
    assert dwells == [("ignition", 0.8, 0), ("zone", 1.5, 2)]  # z1 starts at segment 2, arc on
    # 40 mm wall, 8 segments of 5 mm: zones 2/3/3 segments at 5, 6, 7 mm/s
    seg_t = (10 / 5 + 15 / 6 + 15 / 7)
    assert plan.stats["estimated_time_s"] == pytest.approx(seg_t + 0.8 + 1.5, abs=1e-3)
    assert plan.stats["deposition_length_mm"] == pytest.approx(40.0)


def test_arc_fit_merges_motions_only_inside_groups():
    moves = flatten(build_toolpath(1))
    plan = plan_program(moves, PlanSettings(arc_tolerance=0.05))
    circ = [m for m in plan.motions if m.circular]
    assert len(circ) == 3
    for m in circ:
        assert len({int(moves.zone[i]) for i in range(m.start, m.end)}) == 1  # never across a zone change
        assert m.start < m.via < m.end
        r = np.linalg.norm(moves.points[[m.start, m.via, m.end]] - np.array(m.center), axis=1)
        assert np.allclose(r, 15.0)


def test_weld_without_speed_fails_naming_layer_and_section():
    from waamflow.core.errors import PlanningError

    tp = build_toolpath(2)
    lp = tp[1]
    ring = lp.sections[1]
    speed = ring.speed.copy()
    speed[4] = np.nan
    tp = Layered((tp[0], LayerPaths(lp.layer, (lp.sections[0], replace(ring, speed=speed), lp.sections[2]))))
    with pytest.raises(PlanningError) as err:
        plan_program(flatten(tp))
    assert err.value.layer == 1 and err.value.section == "bs1/B"
    assert "layer 1" in str(err.value) and "bs1/B" in str(err.value)
