"""simulate-robot simulates the program as the post-process writes it (issue 23 item 3): blend
distance, ignition dwells and controller family from the program; C_DIS acts over its range;
arc-on time never exceeds the cycle time."""

import numpy as np
import pytest

from waamflow.core.errors import RecipeError
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_recipe
from waamflow.trajectory.blend import CDIS_REF
from waamflow.trajectory.profile import load_profile
from waamflow.trajectory.run import program_settings
from waamflow.trajectory.simulate import SimOptions, simulate

from .test_simulate import moves, section

KUKA = load_profile("kuka_kr100ha_krc2")


def zigzag(n=8, leg=60.0, pitch=20.0):
    """A zig-zag of n legs: 60 mm legs advancing 20 mm, turning 2·atan(60/20)... sharp corners."""
    pts = [[0.0, 0.0, 5.0]]
    for i in range(n):
        pts.append([leg if i % 2 == 0 else 0.0, (i + 1) * pitch, 5.0])
    return np.array(pts)


@pytest.mark.parametrize("speed", [10.0, 40.0])
def test_larger_cdis_cuts_corners_further_and_runs_faster(speed):
    # before: d = min(CDIS, 0.42 mm + v·0.0347 s) saturated at 1.81 mm (40 mm/s) / 0.77 mm
    # (10 mm/s): C_DIS 5 and 20 gave the same path and time
    mv = moves(((section(zigzag(), speed=speed),), 0.0))
    res = {c: simulate(mv, KUKA, SimOptions(cdis=c)).metrics for c in (1.0, 5.0, 20.0)}
    t = [res[c]["total_time_s"] for c in (1.0, 5.0, 20.0)]
    e = [res[c]["max_corner_error_mm"] for c in (1.0, 5.0, 20.0)]
    assert t[0] > t[1] > t[2], t
    assert e[0] < e[1] < e[2], e
    assert t[0] - t[2] > 0.05  # seconds, on 8 corners: not a rounding difference
    assert e[2] > 2 * e[1]  # 4× the C_DIS, well below half a leg: a deeper cut


def test_cdis_at_the_study_value_is_the_fitted_law():
    # the fitted profile holds at the study's C_DIS: the scale is 1 there
    assert CDIS_REF == 5.0


STUDY_PATTERNS = [
    "raster",
    "semicircular",
    "triangular",
    "rectangular",
    "spiral",
    "swiping",
    "oscillate",
    "parallel",
    "contour",
]


@pytest.mark.parametrize("speed", [10, 40])
@pytest.mark.parametrize("pattern", STUDY_PATTERNS)
def test_arc_on_time_never_exceeds_total_time(pattern, speed):
    # before: triangular 40 mm/s reported arc-on 6.8407 s in a 6.8349 s cycle (the arc-OFF lag
    # after the last motion was counted as arc-on time but not as cycle time)
    recipe = apply_overrides(load_recipe("graphs/rectangle-study.json"), [("pattern", pattern), ("speed", speed)])
    out = execute(build_graph(recipe), resolver=FileResolver("graphs"), artifacts=False, preflight=False)
    m = out.outputs["simulate"]["simulation"].metrics
    assert m["arc_on_time_s"] <= m["total_time_s"]
    assert 0.0 <= m["arc_off_lag_after_end_s"] <= KUKA.arc_off_delay_s + 1e-9


def test_arc_off_lag_still_deposits():
    mv = moves(((section(zigzag(2)),), 0.0))
    m = simulate(mv, KUKA).metrics
    assert m["arc_off_lag_after_end_s"] == pytest.approx(KUKA.arc_off_delay_s, abs=1e-9)
    # the volume is arc-on time plus the lag after the end, at 94.25 mm³/s
    assert m["deposited_volume_mm3"] == pytest.approx(
        94.25 * (m["arc_on_time_s"] + m["arc_off_lag_after_end_s"]), rel=1e-9
    )


KRL = """DEF post( )
$APO.CDIS=1
LIN P1
$OUT[1]=TRUE ; arc on
WAIT SEC 0.5 ; ignition dwell
LIN P2 C_DIS
WAIT SEC 20 ; interlayer dwell
$OUT[1]=TRUE ; arc on
WAIT SEC 0.75 ; ignition dwell
END
"""
ARCTECH = ";- WDAT1: 8.1 m/min, ignition dwell 0.5 s\n$APO.CDIS=2.5\n;- ignition dwell 0.4 s (Strike.StartTime)\n"
RAPID = """MODULE m
CONST zonedata zw := [FALSE,1,1.5,1.5,0.15,1.5,0.15];
PERS seamdata sm1 := [0,0,[...],0.5,0,0,0,0]; ! ignition dwell 0.5 s
! ignition dwell 0.5 s (seamdata ign_move_delay)
ArcLStart p1, vw1, sm1, wd1, fine, tWeldGun\\WObj:=wobj0;
ArcL p2, vw1, sm1, wd1, zw, tWeldGun\\WObj:=wobj0;
"""
GCODE_MS = "; units: mm (G21), absolute (G90), dwell G4 P in milliseconds\nG4 P500 ; ignition dwell\nG4 P20000\n"


def test_program_settings_read_as_written():
    k = program_settings("krl", {"src": KRL})
    assert (k["controller"], k["blend"], k["blend_distance_mm"], k["ignition_dwells_s"]) == (
        "kuka_krc",
        "cdis",
        1.0,
        (0.5, 0.75),
    )
    a = program_settings("krl", {"src": ARCTECH})
    assert (a["blend_distance_mm"], a["ignition_dwells_s"]) == (2.5, (0.4,))  # not the WDAT declaration
    r = program_settings("rapid", {"mod": RAPID})
    assert (r["controller"], r["blend"], r["blend_distance_mm"], r["ignition_dwells_s"]) == (
        "abb_irc5",
        "zone",
        1.0,
        (0.5,),
    )
    assert r["robot_profile"] == "abb_irb4600_irc5"
    assert program_settings("rapid", {"mod": RAPID.replace(", zw,", ", fine,")})["blend_distance_mm"] == 0.0
    g = program_settings("gcode", {"gcode": GCODE_MS})
    assert (g["blend_distance_mm"], g["ignition_dwells_s"]) == (None, (0.5,))
    with pytest.raises(ValueError, match="controller family"):
        program_settings("csv", {"csv": ""})
    with pytest.raises(ValueError, match="several values"):
        program_settings("krl", {"src": KRL, "L001.src": "$APO.CDIS=3\n"})


def _duct_run(connect: bool, extra_sim: dict | None = None):
    import json

    data = json.loads(open("graphs/curved-duct.json").read())
    for n in data["nodes"]:
        if n["id"] == "sim":
            n["params"] = {**n["params"], "kinematics": False, **(extra_sim or {})}
    edges = [e for e in data["edges"] if e["to"] != "sim.program"]
    if connect:
        edges.append({"from": "post.program", "to": "sim.program"})
    data["edges"] = edges
    return execute(build_graph(parse_recipe(data)), resolver=FileResolver("graphs"), artifacts=False, preflight=False)


def test_krl_program_simulated_with_its_dwells_and_cdis():
    # curved-duct's KRL: $APO.CDIS=1 and 58 × WAIT SEC 0.5 (29 s). Before: simulated with C_DIS 5
    # and no ignition dwell (556.49 s against the header's 557.57 s)
    off = _duct_run(False, {"cdis": 1.0}).outputs["sim"]["simulation"]
    on = _duct_run(True).outputs["sim"]["simulation"]
    assert on.options.controller == "kuka_krc"
    assert on.options.cdis == 1.0 and on.options.blend == "cdis"
    assert len(on.options.ignition_dwells_s) == 58 and sum(on.options.ignition_dwells_s) == pytest.approx(29.0)
    # the same blend without the program's dwells: exactly the 58 × 0.5 s shorter
    assert on.metrics["total_time_s"] - off.metrics["total_time_s"] == pytest.approx(29.0, abs=1e-6)
    same = _duct_run(False, {"cdis": 1.0, "ignition_dwell_s": 0.5}).outputs["sim"]["simulation"]
    assert on.metrics["total_time_s"] == pytest.approx(same.metrics["total_time_s"], abs=1e-9)
    # before: simulated with C_DIS 5 and no dwell, 556.49 s beside the header's 557.57 s
    assert on.metrics["total_time_s"] == pytest.approx(584.05, abs=0.02)


def test_two_declarations_of_the_blend_are_refused():
    with pytest.raises(RecipeError, match="one declaration.*cdis"):
        _duct_run(True, {"cdis": 5.0})


@pytest.mark.parametrize(
    "fmt, controller, blend, profile",
    [
        ("rapid", "abb_irc5", "zone", "abb_irb4600_irc5"),
        ("krl", "kuka_krc", "cdis", "kuka_kr100ha_krc2"),
    ],
)
def test_controller_family_follows_the_dialect(fmt, controller, blend, profile):
    from .test_nodes import run

    nodes = [
        {
            "id": "post",
            "type": "post-process",
            "params": {"format": fmt, "blend_distance": 2.0, "ignition_dwell": 0.25},
        },
        {"id": "sim", "type": "simulate-robot", "params": {"kinematics": False}},
    ]
    edges = [
        ("strategy.toolpath", "post.toolpath"),
        ("strategy.toolpath", "sim.toolpath"),
        ("post.program", "sim.program"),
    ]
    # a spiral: one arc-ON run with corners, so the program's motions use the blend (raster
    # passes are single ArcL…fine moves: RAPID writes no zw use and the reader says 0 mm)
    res = run(nodes, edges, pattern="spiral").outputs["sim"]["simulation"]
    assert (res.options.controller, res.options.blend, res.options.cdis) == (controller, blend, 2.0)
    assert res.profile["name"] == profile
    assert set(res.options.ignition_dwells_s) == {0.25}
    # the recipe's own robot stays its choice (dynamics), the program still gives the blending
    nodes[1]["params"]["robot_profile"] = "kuka_kr100ha_krc2"
    res = run(nodes, edges, pattern="spiral").outputs["sim"]["simulation"]
    assert res.profile["name"] == "kuka_kr100ha_krc2" and res.options.blend == blend
