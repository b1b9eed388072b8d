"""The statement walk INFORM and TP share (program/walk.py), through a dialect that records what
it is asked for: the ignition dwell goes into the arc start once, other dwells are a comment and a
wait, every motion lands in its program's positions, circular motions are refused by name."""

import numpy as np
import pytest

from waamflow.core.moves import flatten
from waamflow.program.plan import Dwell, Motion, PlanSettings, chunk_steps, plan_program
from waamflow.program.walk import walk_programs

from conftest import build_toolpath


class Recorder:
    name = "REC"
    travel_speed = 123.0
    tool_on = "TOOL ON {force_n:.0f}"
    tool_off = "TOOL OFF"

    def __init__(self) -> None:
        self.ignitions: list[float] = []
        self.pts: list[int] = []
        self.speeds: list[float] = []

    def comment(self, text: str) -> str:
        return "# " + text

    def process_change(self, st, arc: bool) -> list[str]:
        return [f"ZONE {st.zone_id} {'while welding' if arc else 'before ignition'}"]

    def arc_on(self, ignition_s: float) -> list[str]:
        self.ignitions.append(ignition_s)
        return ["ARC ON"]

    def arc_off(self) -> list[str]:
        return ["ARC OFF"]

    def wait(self, seconds: float) -> str:
        return f"WAIT {seconds:.2f}"

    def start_program(self) -> None:
        self.pts = []

    def motion(self, st: Motion, speed: float) -> str:
        self.pts.append(st.end)
        self.speeds.append(speed)
        return f"MOVE {st.end}"

    def positions(self) -> list[int]:
        return list(self.pts)


def test_walk_folds_the_ignition_dwell_and_places_every_motion():
    plan = plan_program(flatten(build_toolpath(3, dwell=20.0)), PlanSettings(ignition_dwell=0.4))
    rec = Recorder()
    progs = walk_programs(plan, chunk_steps(plan.steps, max_points=12), rec)
    lines = [ln for _c, body, _p in progs for ln in body]
    dwells = [st for st in plan.steps if isinstance(st, Dwell)]
    ignition = [d.seconds for d in dwells if d.reason == "ignition"]
    others = [d for d in dwells if d.reason != "ignition"]
    # 3 layers x (wall, half ring, zigzag of 3 runs) ignitions: 9 in the start zone (its dwell 0.8 s),
    # 6 after a link (the setting, 0.4 s); 2 interlayer dwells
    assert sorted(ignition) == [0.4] * 6 + [0.8] * 9 and len(others) == 2
    assert rec.ignitions == pytest.approx(ignition)  # each arc start holds its dwell ...
    assert not any("ignition dwell" in ln for ln in lines)  # ... which is not written again
    assert [ln for ln in lines if ln.startswith("WAIT")] == [f"WAIT {d.seconds:.2f}" for d in others]
    assert sum(ln.startswith("# interlayer dwell 20 s") for ln in lines) == 2
    assert lines.count("ARC ON") == 15 and lines.count("ARC OFF") == 15
    motions = [st for st in plan.steps if isinstance(st, Motion)]
    assert [i for _c, _b, pts in progs for i in pts] == [m.end for m in motions]  # every motion, once, in order
    assert len(progs) == len(chunk_steps(plan.steps, max_points=12)) == 6  # per layer, cut after 12
    travel = [v for m, v in zip(motions, rec.speeds) if m.mode == "travel"]
    assert travel and all(v == 123.0 for v in travel)


def test_walk_refuses_circular_motions_by_the_dialect_name():
    plan = plan_program(flatten(build_toolpath(1)), PlanSettings(arc_tolerance=0.05))
    assert any(isinstance(st, Motion) and st.circular for st in plan.steps)
    with pytest.raises(ValueError, match="^REC: circular motions are not written"):
        walk_programs(plan, chunk_steps(plan.steps), Recorder())
    assert np.isfinite(plan.stats["deposition_length_mm"])
