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
            nxt = next((s for s in steps[k + 1 :] if isinstance(s, (Motion, ArcOn, ArcOff, Dwell))), None)
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
    seg_t = 10 / 5 + 15 / 6 + 15 / 7
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


def test_one_chunker_for_the_robot_programs():
    """`chunk_steps`: a program per layer; a full program ends only with the arc off (INFORM/TP:
    after the motion that fills it, or the first one after the arc goes off), counting motions
    or distinct points; `cut_back` (KRL) ends it back at the latest arc OFF leaving it half full."""
    from waamflow.program.plan import LayerStart, chunk_steps

    moves = flatten(build_toolpath(3))
    plan = plan_program(moves, PlanSettings())
    steps = plan.steps
    per_layer = chunk_steps(steps)
    assert [(c.layer, c.part) for c in per_layer] == [(0, 0), (1, 0), (2, 0)]
    assert [k for c in per_layer for k in c.steps] == list(range(len(steps)))  # every step once, in order
    assert all(isinstance(steps[c.steps[0]], LayerStart) for c in per_layer)

    def arc_at_end(c) -> bool:
        on = False
        for k in c.steps:
            on = isinstance(steps[k], ArcOn) or (on and not isinstance(steps[k], ArcOff))
        return on

    cut = chunk_steps(steps, max_points=10)
    assert [k for c in cut for k in c.steps] == list(range(len(steps)))
    assert {c.layer for c in cut} == {0, 1, 2} and max(c.part for c in cut) >= 2
    for c in cut:
        n = sum(isinstance(steps[k], Motion) for k in c.steps)
        assert n >= 1 and not arc_at_end(c)  # no program switch while welding
        # past the limit a program goes on only while the arc is on (every motion but its last)
        on, seen = False, 0
        for k in c.steps:
            on = isinstance(steps[k], ArcOn) or (on and not isinstance(steps[k], ArcOff))
            if isinstance(steps[k], Motion):
                seen += 1
                assert seen < 10 or on or seen == n, (c.layer, c.part, seen, n)
    parts = [c.part for c in cut if c.layer == 1]
    assert parts == list(range(len(parts)))
    # a layer is never cut with fewer positions than the limit
    assert all(
        sum(isinstance(steps[k], Motion) for k in c.steps) >= 10
        for i, c in enumerate(cut[:-1])
        if cut[i + 1].layer == c.layer
    )
    # distinct points: a point a program goes to twice counts once (the zone dwell restates one)
    assert len(chunk_steps(steps, max_points=10, distinct=True)) <= len(cut)
    back = chunk_steps(steps, per_layer=False, max_points=12, cut_back=True)
    assert [k for c in back for k in c.steps] == list(range(len(steps)))
    assert all(sum(isinstance(steps[k], Motion) for k in c.steps) <= 12 for c in back)
    assert len(back) > 3 and {c.layer for c in back} <= {0, 1, 2}


def test_arc_geometry_of_a_circular_motion_and_the_refusal_of_a_line():
    """Writers read a circular motion's centre and normal through Motion.arc_geometry: the fitted
    half ring's centre (20, 30) and +z normal; a line has none and the error names the motion."""
    plan = plan_program(flatten(build_toolpath(1)), PlanSettings(arc_tolerance=0.05))
    circ = [m for m in plan.motions if m.circular]
    assert circ
    for m in circ:
        (cx, cy, _cz), normal = m.arc_geometry()
        if abs(cx - 20.0) < 1e-6:
            assert cy == pytest.approx(30.0, abs=1e-6) and abs(normal[2]) == pytest.approx(1.0)
    assert any(abs(m.arc_geometry()[0][0] - 20.0) < 1e-6 for m in circ)
    line = next(m for m in plan.motions if not m.circular)
    with pytest.raises(ValueError, match=rf"motion to point {line.end} \(layer {line.layer}\) is not a circular"):
        line.arc_geometry()


def test_post_process_names_the_settings_class_of_the_format():
    """A writer given another format's settings is refused by name (it failed deep inside the
    writer with an AttributeError); print points take the blend distance in mm."""
    from waamflow.program import GcodeSettings, KrlSettings, post_process

    moves = flatten(build_toolpath(1))
    with pytest.raises(
        TypeError, match=r"post_process\('krl'\): writer_settings must be KrlSettings, not GcodeSettings"
    ):
        post_process(moves, "krl", writer_settings=GcodeSettings())
    with pytest.raises(TypeError, match=r"printpoints.*blend distance in mm, not KrlSettings"):
        post_process(build_toolpath(1), "printpoints", writer_settings=KrlSettings())
    assert post_process(moves, "krl", writer_settings=KrlSettings(program_name="wall")).name == "wall"


@pytest.mark.parametrize("tol", [0.0, 0.05])
def test_straight_motions_filled_in_directly_are_the_dataclass_instances(tol, monkeypatch):
    """plan._straight_motions builds Motion objects without the frozen dataclass's __init__: the
    same plan (fields in order, equality, hashes, pickles) as Motion(...) for each, with and without
    arcs fitted between them."""
    import pickle

    from waamflow.program import plan as plan_mod

    moves = flatten(build_toolpath(2))
    fast = plan_program(moves, PlanSettings(arc_tolerance=tol))

    def by_init(base, i, j):
        return [Motion(start=k, end=k + 1, **base) for k in range(i, j)]

    monkeypatch.setattr(plan_mod, "_straight_motions", by_init)
    ref = plan_program(moves, PlanSettings(arc_tolerance=tol))
    # pickles: travel speeds are NaN, equal only as the same object (not across two plans)
    assert [pickle.dumps(s) for s in fast.steps] == [pickle.dumps(s) for s in ref.steps]
    assert len(fast.motions) > 50 and fast.stats == ref.stats
    welds = [(a, b) for a, b in zip(fast.motions, ref.motions) if a.mode != "travel"]
    assert len(welds) > 30 and all(a == b and hash(a) == hash(b) for a, b in welds)
    assert (sum(m.circular for m in fast.motions) > 0) == (tol > 0)
    with pytest.raises(AttributeError):
        fast.motions[1].start = 7  # still frozen
