"""simulate-robot fed a cell program simulates that program's positioner plan (issue #23 item 3,
"the program as written"; #28): the same cell, policy and limits as the post-process that wrote
it — taken from the program where simulate-robot leaves them unset, refused where both set
different values (two declarations of one thing)."""

import json
from pathlib import Path

import pytest

from waamflow.core.errors import RecipeError
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def _duct(post: dict, sim: dict):
    recipe = json.loads((GRAPHS / "curved-duct.json").read_text())
    recipe["inputs"]["dtheta_deg"] = 15.0  # few layers: the test is about the settings
    for n in recipe["nodes"]:
        if n["id"] == "post":
            n["params"] = {"format": "krl", "ignition_dwell": 0.5, **post}
        if n["id"] == "sim":
            n["params"] = sim
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(GRAPHS))


def test_the_simulation_takes_the_programs_policy_and_limits():
    r = _duct(
        {"cell": "kr150_tilt_rotate", "positioner_policy": "gravity", "max_tilt_deg": 20.0},
        {"cell": "kr150_tilt_rotate"},
    )
    pos = r.outputs["post"]["program"].stats["positioner"]
    assert pos == {
        "cell": "kr150_tilt_rotate",
        "positioner_policy": "gravity",
        "max_tilt_deg": 20.0,
        "max_lean_deg": 15.0,
        "flat_tol_deg": 5.0,
    }
    sim = r.outputs["sim"]["simulation"]
    assert sim.kinematics.get("positioner_plan") is None  # gravity, as written (auto would plan)


@pytest.mark.parametrize(
    "sim, names",
    [
        ({"cell": "kr150_tilt_rotate", "positioner_policy": "fixed"}, "positioner_policy='fixed'"),
        ({"cell": "kr150_tilt_rotate", "max_lean_deg": 10.0}, "max_lean_deg=10.0"),
        ({"cell": "irb4600_tilt_rotate"}, "'irb4600_tilt_rotate' is not the cell"),
    ],
)
def test_two_declarations_of_the_cell_plan_are_refused(sim, names):
    with pytest.raises(RecipeError) as e:
        _duct({"cell": "kr150_tilt_rotate", "positioner_policy": "gravity"}, sim)
    assert e.value.node == "sim" and names in e.value.message
