"""Uniform deposit by design: compensation at least halves the deposit-per-mm cv on the robot
study's rectangular and triangular patterns at 40 mm/s (small objective rectangle)."""

import json
from pathlib import Path

import pytest

from waamflow.core.moves import flatten
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe
from waamflow.trajectory.compensate import deposit_cv, subdivide_toolpath
from waamflow.trajectory.profile import load_profile
from waamflow.trajectory.run import simulate_program
from waamflow.trajectory.simulate import SimOptions

RECIPE = Path(__file__).resolve().parents[2] / "graphs" / "rectangle-study.json"


def run(**inputs):
    recipe = apply_overrides(load_recipe(RECIPE), list(inputs.items()))
    return execute(build_graph(recipe), resolver=FileResolver(RECIPE.parent))


@pytest.mark.parametrize("pattern", ["rectangular", "triangular"])
def test_compensation_halves_the_cv(pattern):
    off = json.loads(run(pattern=pattern, speed=40, compensate="off").artifacts["simulate.simulation.json"])
    res = run(pattern=pattern, speed=40, compensate="on")
    on = json.loads(res.artifacts["simulate.simulation.json"])
    assert on["deposit_per_mm_cv_before"] == pytest.approx(off["deposit_per_mm_cv"], rel=1e-6)
    assert off["deposit_per_mm_cv"] > 0.2  # stops and corners at 40 mm/s: uneven
    assert on["deposit_per_mm_cv"] <= 0.5 * off["deposit_per_mm_cv"]
    # the motion is the same program's: same time within two interpolation cycles
    assert on["total_time_s"] == pytest.approx(off["total_time_s"], abs=0.025)
    # the metal laid per mm of the path the robot really travels comes back to the programmed
    # 94.25 / 40 mm³/mm (constant feed: ~10 % more, from every slow-down)
    q = 94.25 / 40.0
    assert on["deposited_volume_mm3"] / (q * on["arc_on_length_mm"]) == pytest.approx(1.0, abs=0.02)
    assert off["deposited_volume_mm3"] / (q * off["arc_on_length_mm"]) > 1.05
    assert on["deposit_ratio_cv"] == pytest.approx(on["deposit_per_mm_cv"], rel=1e-6)  # one target: same measure
    svg = res.artifacts["simulate.deposit.svg"]
    svg = svg.decode() if isinstance(svg, bytes) else svg
    assert svg.count("<polyline") == 3 and "compensated" in svg


def test_subdivision_keeps_the_corners_the_robot_takes():
    recipe = apply_overrides(load_recipe(RECIPE), [("pattern", "triangular"), ("speed", 40)])
    tp = execute(build_graph(recipe), resolver=FileResolver(RECIPE.parent), targets=["strategy"]).outputs["strategy"][
        "toolpath"
    ]
    prof = load_profile("kuka_kr100ha_krc2")
    fine = subdivide_toolpath(tp, 1.0, 5.0, "cdis", prof)
    a = simulate_program(flatten(tp), prof, SimOptions())
    b = simulate_program(flatten(fine), prof, SimOptions())
    assert len(flatten(fine).points) > 3 * len(flatten(tp).points)
    assert b.metrics["actual_length_mm"] == pytest.approx(a.metrics["actual_length_mm"], abs=0.01)
    assert b.metrics["max_corner_error_mm"] == pytest.approx(a.metrics["max_corner_error_mm"], abs=0.01)
    assert deposit_cv(b.trace) == pytest.approx(deposit_cv(a.trace), rel=0.05)
