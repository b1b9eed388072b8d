"""Machine profiles: shipped JSON presets chosen by the post-process node's `profile` param;
listed by `waamflow profiles` and GET /api/profiles."""

import json
import re
import pytest

from waamflow.core.errors import RecipeError
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.nodes.post import PostProcess
from waamflow.program.profiles import load_profiles

from tests.program.test_trace import _recipe, _write_wall


def _run(tmp_path, post_params):
    _write_wall(tmp_path, 80.0)
    recipe = _recipe("gcode")
    recipe["nodes"][-1]["params"] = post_params
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))


def test_every_profile_sets_only_known_params():
    profiles = load_profiles()
    assert set(profiles) == {
        "generic",
        "linuxcnc",
        "marlin",
        "fanuc",
        "kuka_krc4",
        "kuka_krc4_io",
        "abb_irc5",
        "yaskawa_yrc1000",
        "fanuc_r30ib_arctool",
    }
    for name, p in profiles.items():
        assert p["title"] and p["description"]
        PostProcess.Params.model_validate({**p["post"], "profile": name})  # values valid too
        assert set(p["post"]) <= set(PostProcess.Params.model_fields)


def test_marlin_dwell_in_ms_and_recipe_values_win(tmp_path):
    res = _run(tmp_path, {"profile": "marlin", "ignition_dwell": 0.5})
    g = res.artifacts["post.gcode"].decode()
    assert "G4 P500" in g and "M106 S255" in g and "M107" in g
    res = _run(tmp_path, {"profile": "linuxcnc", "ignition_dwell": 0.5})
    g = res.artifacts["post.gcode"].decode()
    assert re.search(r"^G4 P0\.5\b", g, re.M) and "M64 P0" in g
    res = _run(tmp_path, {"profile": "marlin", "dwell_units": "s", "arc_on": "M42 P4 S255"})  # the recipe wins
    g = res.artifacts["post.gcode"].decode()
    assert "M42 P4 S255" in g and "M107" in g and re.search(r"^G4 P0\.5\b", g, re.M)


def test_robot_profiles_choose_the_format(tmp_path):
    assert {"post.src", "post.dat"} <= set(_run(tmp_path, {"profile": "kuka_krc4"}).artifacts)
    assert "post.mod" in _run(tmp_path, {"profile": "abb_irc5"}).artifacts


def test_unknown_profile_names_the_known_ones(tmp_path):
    with pytest.raises(RecipeError, match="unknown machine profile 'heidenhain'.*marlin"):
        _run(tmp_path, {"profile": "heidenhain"})


def test_cli_and_api_list_profiles(capsys):
    from waamflow.cli import main

    assert main(["profiles"]) == 0
    names = [p["name"] for p in json.loads(capsys.readouterr().out)["profiles"]]
    assert names == sorted(load_profiles())
    from fastapi.testclient import TestClient

    from waamflow.api.routes.nodes import router
    from fastapi import FastAPI

    app = FastAPI()
    app.include_router(router)
    body = TestClient(app).get("/api/profiles").json()
    assert [p["name"] for p in body] == names and body[0]["post"]
