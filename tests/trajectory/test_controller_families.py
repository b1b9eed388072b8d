"""Controller families (issue #23 item 3): the G-code motion planner with junction deviation and
the KUKA KR C4 profile beside the KR C2.

The planner's closed form: a move from junction speed v_a to v_b with the feed F reached takes
(F − v_a)/a + (F − v_b)/a + (s − (F² − v_a²)/2a − (F² − v_b²)/2a)/F; a 90° junction (interior
angle θ = 90°) runs at v_j = √(a·δ·sin 45°/(1 − sin 45°)) (grbl planner.c)."""

import json
import math

import numpy as np
import pytest

from waamflow.core.errors import InputFileError
from waamflow.trajectory.blend import junction_speed
from waamflow.trajectory.profile import load_profile
from waamflow.trajectory.run import program_settings
from waamflow.trajectory.simulate import simulate

from .test_simulate import moves, section

PLANNER = load_profile("gcode_planner")
KRC2 = load_profile("kuka_kr100ha_krc2")
KRC4 = load_profile("kuka_kr100ha_krc4")


def _move_time(s, va, vb, F, a):
    """Trapezoid time of one move (F reached: checked by the caller)."""
    da, db = (F * F - va * va) / (2 * a), (F * F - vb * vb) / (2 * a)
    assert da + db < s
    return (F - va) / a + (F - vb) / a + (s - da - db) / F


def _square(side, speed):
    pts = np.array([[0, 0, 5], [side, 0, 5], [side, side, 5], [0, side, 5], [0, 0, 5]], float)
    return moves(((section(pts, speed=speed),), 0.0))


@pytest.mark.parametrize("side, F_mm_min, acc, delta", [(50.0, 1800.0, 200.0, 0.05), (80.0, 3000.0, 500.0, 0.2)])
def test_square_matches_the_closed_form(side, F_mm_min, acc, delta):
    F = F_mm_min / 60.0
    prof = PLANNER.with_values(path_acc=acc, junction_deviation_mm=delta)
    vj = math.sqrt(acc * delta * math.sin(math.pi / 4) / (1 - math.sin(math.pi / 4)))
    assert vj < F  # the corners do slow the tool
    expect = (
        _move_time(side, 0.0, vj, F, acc) + 2 * _move_time(side, vj, vj, F, acc) + _move_time(side, vj, 0.0, F, acc)
    )
    m = simulate(_square(side, F), prof).metrics
    assert m["total_time_s"] == pytest.approx(expect, rel=0.01)
    assert m["total_time_s"] == pytest.approx(expect, abs=2e-3)  # in fact to the sampling
    # the planner follows the path: no corner is cut (a 4 ms sample's chord across a corner
    # taken at v_j is all the sampled trace misses)
    assert m["actual_length_mm"] == pytest.approx(4 * side, abs=0.005)
    assert m["max_deviation_mm"] < 0.005
    # a larger junction deviation runs the corners faster
    fast = simulate(_square(side, F), prof.with_values(junction_deviation_mm=4 * delta)).metrics
    assert fast["total_time_s"] < m["total_time_s"] - 0.05


def test_junction_speed_formula():
    u = np.array([[1.0, 0, 0]] * 3)
    w = np.array([[0.0, 1, 0], [1.0, 0, 0], [-1.0, 0, 0]])  # 90°, straight on, reversal
    v = junction_speed(u, w, np.full(3, 50.0), 500.0, 0.05)
    assert v[0] == pytest.approx(math.sqrt(500 * 0.05 * math.sqrt(0.5) / (1 - math.sqrt(0.5))))  # 7.77 mm/s
    assert v[1] == 50.0 and v[2] == 0.0


def test_lookahead_buffer_limits_speed_on_short_moves():
    """A straight line cut into 200 moves of 0.5 mm at 50 mm/s: with 16 blocks in view the
    planner never plans more than 8 mm ahead, and from 50 mm/s it stops within 2.5 mm at
    500 mm/s²: F is reached as with the whole program known (2.100 s). With 4 blocks (2 mm) every
    junction is at most √(2·500·2) = 44.7 mm/s (within a block the tool peaks at
    √(44.7² + 500·0.5) = 47.4 mm/s): 2.262 s."""
    x = np.linspace(0, 100, 201)
    pts = np.column_stack([x, np.zeros_like(x), np.full_like(x, 5.0)])
    # alternate the feed slightly so the planner cannot merge the moves into one
    speed = np.where(np.arange(200) % 2 == 0, 50.0, 49.99)
    mv = moves(((section(pts, speed=speed),), 0.0))
    t16 = simulate(mv, PLANNER.with_values(lookahead_blocks=16)).metrics["total_time_s"]
    t4 = simulate(mv, PLANNER.with_values(lookahead_blocks=4)).metrics["total_time_s"]
    t_all = simulate(mv, PLANNER.with_values(lookahead_blocks=0)).metrics["total_time_s"]
    assert t16 == pytest.approx(t_all, rel=1e-3)
    assert t_all == pytest.approx(100 / 50 + 50 / 500, rel=1e-3)  # cruise + two ramps' extra time
    v4 = math.sqrt(2 * 500 * 2.0)
    v_peak = math.sqrt(v4**2 + 500 * 0.5)
    assert 100 / v_peak < t4 < 100 / v4 + v4 / 500
    assert t4 > t16 + 0.1


def test_gcode_program_is_simulated_by_the_planner_family():
    st = program_settings("gcode", {"gcode": "G4 P0.5 ; ignition dwell\n"})
    assert (st["controller"], st["blend"], st["robot_profile"]) == ("gcode_planner", "junction", "gcode_planner")


def test_profile_validation_names_the_value():
    d = json.loads(
        (
            PLANNER_FILE := __import__("waamflow.trajectory.profile", fromlist=["ROBOTS_DIR"]).ROBOTS_DIR
            / "gcode_planner.json"
        ).read_text()
    )
    with pytest.raises(InputFileError, match="lookahead_blocks"):
        load_profile("x.json", text=json.dumps({**d, "lookahead_blocks": 2.5}))
    with pytest.raises(InputFileError, match="junction_deviation_mm"):
        load_profile("x.json", text=json.dumps({**d, "junction_deviation_mm": -1}))
    assert PLANNER_FILE.exists()


def _post_and_sim(fmt, machine, pattern="raster", sim_params=None, dwell=0.25):
    from .test_nodes import run

    nodes = [
        {"id": "post", "type": "post-process", "params": {"format": fmt, "profile": machine, "ignition_dwell": dwell}},
        {"id": "sim", "type": "simulate-robot", "params": {"kinematics": False, **(sim_params or {})}},
    ]
    edges = [
        ("strategy.toolpath", "post.toolpath"),
        ("strategy.toolpath", "sim.toolpath"),
        ("post.program", "sim.program"),
    ]
    r = run(nodes, edges, pattern=pattern)
    _post_and_sim.artifacts = r.artifacts
    return r.outputs["post"]["program"], r.outputs["sim"]["simulation"]


@pytest.mark.parametrize(
    "machine, travel", [("linuxcnc", 200.0), ("generic", 200.0), ("fanuc", 200.0), ("marlin", 100.0)]
)
def test_gcode_program_runs_the_planner_with_its_feeds_and_dwells(machine, travel):
    """Raster at 40 mm/s (F2400) on the small OR, linked by arc-OFF returns: every pass and every
    return is a stop-to-stop move (the arc switches empty the planner), s/F + F/a each, plus the
    program's 5 ignition dwells G4 0.25 s — 6.981 + 1.25 s. G0 travel: the program's F (Marlin
    F6000) or the planner's rapid rate (G0 without F)."""
    from waamflow.program import parse_gcode

    prog, res = _post_and_sim("gcode", machine)
    assert (res.options.controller, res.profile["name"]) == ("gcode_planner", "gcode_planner")
    assert res.options.ignition_dwells_s == (0.25,) * 5
    assert res.options.travel_speed == travel
    settings = json.loads(_post_and_sim.artifacts["sim.simulation.json"])["settings"]
    assert settings == {
        **settings,
        "controller": "gcode_planner",
        "blend": "junction",
        "cdis_mm": None,
        "junction_deviation_mm": 0.05,
        "lookahead_blocks": 16,
        "travel_speed_mm_s": travel,
        "ignition_dwells": 5,
    }
    feeds = np.concatenate([r.feed_mm_min for r in parse_gcode(prog.files["gcode"]).runs])
    F = float(np.unique(feeds)[0]) / 60.0
    assert np.unique(feeds).tolist() == [2400.0]
    a = PLANNER.path_acc
    ret = math.hypot(43.0, 4.43)
    expect = 5 * (43.0 / F + F / a) + 4 * (ret / F + F / a) + 5 * 0.25
    assert res.metrics["total_time_s"] == pytest.approx(expect, rel=0.01)
    assert res.metrics["total_time_s"] == pytest.approx(expect, abs=0.01)
    assert float(np.max(res.trace["speed"])) == pytest.approx(F, rel=1e-3)
    # the dwells are the program's: written 0.75 s, simulated 3 × longer in total
    _, slow = _post_and_sim("gcode", machine, dwell=0.75)
    assert slow.metrics["total_time_s"] - res.metrics["total_time_s"] == pytest.approx(5 * 0.5, abs=1e-6)


def test_gcode_program_on_a_robot_the_recipe_names_keeps_the_robot():
    """A recipe that sets the robot or its blending on simulate-robot runs the G-code on that
    robot (a robot's CNC option): KR C2 blending, as before the planner family (bead-trials)."""
    _, res = _post_and_sim("gcode", "generic", pattern="spiral", sim_params={"cdis": 5.0})
    assert res.profile["name"] == "kuka_kr100ha_krc2" and res.options.blend == "cdis" and res.options.cdis == 5.0
    _, planner = _post_and_sim("gcode", "generic", pattern="spiral")
    assert planner.options.blend == "junction" and planner.profile["junction_deviation_mm"] == 0.05
    # the planner follows the spiral's corners exactly, the robot cuts them
    assert planner.metrics["max_deviation_mm"] < 0.01 < res.metrics["max_deviation_mm"]


def test_krc4_arctech_program_runs_the_krc4_family():
    """ArcTech Basic 3.x (ArcMainNG) runs on KSS 8.x, a KR C4. Documented for LIN … C_DIS: the KR
    C4's legacy planner keeps the KR C2's $APO semantics and the 12 ms IPO cycle, so the same
    program is timed alike; the KR C4 file states its dynamics as assumed (no KR C4 trace)."""
    prog, res4 = _post_and_sim("krl", "kuka_krc4", pattern="spiral")
    assert "ArcMainNG" in prog.files["src"]
    assert (res4.options.controller, res4.profile["name"]) == ("kuka_krc4", "kuka_kr100ha_krc4")
    assert KRC4.interpolation_cycle_s == KRC2.interpolation_cycle_s == 0.012
    assert (
        "ASSUMED"
        in load_profile.__globals__["json"].loads(
            (load_profile.__globals__["ROBOTS_DIR"] / "kuka_kr100ha_krc4.json").read_text()
        )["comment"]
    )
    _, res2 = _post_and_sim("krl", "kuka_krc4", pattern="spiral", sim_params={"robot_profile": "kuka_kr100ha_krc2"})
    assert res2.profile["name"] == "kuka_kr100ha_krc2" and res2.options.cdis == res4.options.cdis == 1.0
    assert res4.metrics["total_time_s"] == pytest.approx(res2.metrics["total_time_s"], rel=1e-9)
    # a KRL program by output (no ArcTech) stays with the KR C2 profile
    _, out = _post_and_sim("krl", "kuka_krc4_io", pattern="spiral")
    assert (out.options.controller, out.profile["name"]) == ("kuka_krc", "kuka_kr100ha_krc2")
