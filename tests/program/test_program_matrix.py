"""Every shipped recipe's program in every machine profile, read by an independent parser.

For each recipe in graphs/ with post-process nodes, one engine run adds a copy of every
post-process node per machine profile (`data/machines/*.json`; upstream nodes are computed once,
simulation nodes are dropped, large recipes are limited to a few layers: `LAYER_LIMIT`). Every program is checked by `program_checkers.PROGRAM_CHECKERS` of
its format (G-code: pygcode); the lengths, dwell and time pygcode measures agree with the
program statistics that `summary.json` carries (`programs`) within `LEN_TOL` / `TIME_TOL`; the
header holds the waamflow version and the recipe's and every input file's sha256, and a second run
gives the same hashes.
"""

from __future__ import annotations

import copy
import hashlib
import json
import re
from pathlib import Path

import numpy as np
import pytest
from program_checkers import PROGRAM_CHECKERS

from waamflow import __version__
from waamflow.buildinfo import source_revision
from waamflow.engine.cache import MemoryCache
from waamflow.engine.executor import FileResolver, execute, recipe_sha256
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.program.profiles import load_profiles

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"
LEN_TOL = 5e-4  # relative: coordinates are written to 0.001 mm
TIME_TOL = 1e-3  # relative: feeds are written to 0.1 mm/min
LAYER_LIMIT = {
    "bracket": ("layers", 12),
    "curved-duct": ("fan", 8),
    "curved-bracket": ("fan", 8),
    "thin-wall-panel": ("layers", 5),
}  # pygcode reads ~1 ms/line
PROFILES = load_profiles()
# formats that do not write a positioner: a recipe with a cell is refused in them (none: INFORM writes station 1)
NO_CELL: set[str] = set()
ANGLE_TOL = 1e-3  # deg: positioner angles in a program vs the simulation's


def _post_recipes() -> list[str]:
    out = []
    for p in sorted(GRAPHS.glob("*.json")):
        doc = json.loads(p.read_text())
        if any(n["type"] == "post-process" for n in doc.get("nodes", [])):
            out.append(p.stem)
    return out


RECIPES = _post_recipes()


def _matrix_recipe(name: str) -> tuple[dict, dict[str, tuple[str, str, dict]]]:
    """The recipe with one post-process copy per profile: node id → (original id, profile, params)."""
    doc = json.loads((GRAPHS / f"{name}.json").read_text())
    if name in LAYER_LIMIT:
        nid, count = LAYER_LIMIT[name]
        next(n for n in doc["nodes"] if n["id"] == nid)["params"]["layer_count"] = count
    _prune_to_programs(doc)
    posts = {}
    for node in [n for n in doc["nodes"] if n["type"] == "post-process"]:
        feeds = [e for e in doc["edges"] if e["to"] == f"{node['id']}.toolpath"]
        for prof, spec in PROFILES.items():
            if spec["post"]["format"] in NO_CELL and node["params"].get("cell"):
                continue
            nid = f"{node['id']}__{prof}"
            params = {**copy.deepcopy(node["params"]), "profile": prof, "format": spec["post"]["format"]}
            doc["nodes"].append({"id": nid, "type": "post-process", "params": params})
            doc["edges"] += [{"from": e["from"], "to": f"{nid}.toolpath"} for e in feeds]
            posts[nid] = (node["id"], prof, params)
    return doc, posts


def _prune_to_programs(doc: dict) -> None:
    """Keep only the post-process nodes and what they depend on (no simulation: faster)."""
    keep = {n["id"] for n in doc["nodes"] if n["type"] == "post-process"}
    grew = True
    while grew:
        src = {e["from"].split(".")[0] for e in doc["edges"] if e["to"].split(".")[0] in keep}
        grew = not src <= keep
        keep |= src
    doc["nodes"] = [n for n in doc["nodes"] if n["id"] in keep]
    doc["edges"] = [e for e in doc["edges"] if e["to"].split(".")[0] in keep]


@pytest.fixture(scope="module")
def runs():
    cache = MemoryCache()
    out = {}
    for name in RECIPES:
        doc, posts = _matrix_recipe(name)
        recipe = parse_recipe(doc)
        result = execute(build_graph(recipe), resolver=FileResolver(GRAPHS), cache=cache)
        out[name] = (recipe, posts, result)
    return out, cache


def test_every_recipe_and_profile_is_in_the_matrix(runs):
    results, _ = runs
    assert {"mpp-cross", "curved-duct", "bracket", "thin-wall-panel", "bead-trials"} <= set(RECIPES)
    assert {"generic", "linuxcnc", "marlin", "kuka_krc4", "abb_irc5"} <= set(PROFILES)
    n = sum(len(posts) for _, posts, _ in results.values())
    assert n == sum(
        sum(
            1 for prof, spec in PROFILES.items() if not (spec["post"]["format"] in NO_CELL and nd["params"].get("cell"))
        )
        for r in RECIPES
        for nd in json.loads((GRAPHS / f"{r}.json").read_text())["nodes"]
        if nd["type"] == "post-process"
    )


def _files(result, node_id: str, named: bool = False) -> dict[str, str]:
    """The node's program files by key ("src", "L003.src", "mod", "M001.mod") or, `named`, by the
    file name they are written as (KRL / RAPID: named after the program, e.g. `post_M001.mod`)."""
    names = result.outputs[node_id]["program"].file_names(node_id)
    return {
        (names[k] if named else k): (v.decode() if isinstance(v, bytes) else v)
        for k in names
        if (v := result.artifacts.get(names[k])) is not None
    }


@pytest.mark.parametrize("name", RECIPES)
def test_programs_parse_and_agree_with_the_summary(runs, name):
    results, _ = runs
    recipe, posts, result = results[name]
    programs = result.summary(recipe.name)["programs"]
    for nid, (_orig, prof, params) in posts.items():
        fmt = params["format"]
        files = _files(result, nid)
        assert files, f"{name}/{prof}: no program files"
        stats = programs[nid]
        assert stats["format"] == fmt
        got = PROGRAM_CHECKERS[fmt](_files(result, nid, named=fmt == "rapid"), {**PROFILES[prof]["post"], **params})
        where = f"{name} in profile {prof}"
        if fmt == "gcode":
            assert got["points"] == stats["motions"], where
            for key in ("deposition_length_mm", "travel_length_mm"):
                assert got[key] == pytest.approx(stats[key], rel=LEN_TOL, abs=0.01), f"{where}: {key}"
            assert got["dwell_total_s"] == pytest.approx(stats["dwell_total_s"], abs=1e-3), where
            assert got["estimated_time_s"] == pytest.approx(stats["estimated_time_s"], rel=TIME_TOL), where
        else:
            # one instruction per plan motion, plus KRL's BCO run (PTP $AXIS_ACT); a robot writer may
            # restate a point (e.g. a zone dwell with the arc on), never more than once per ignition
            assert stats["motions"] <= got["motions"] <= stats["motions"] + stats["arc_on_count"] + 1, where
            assert got["points_declared"] >= stats["motions"] - 1, where


def _trace(text: str) -> dict:
    head = re.search(r"waamflow trace: date (\S+), waamflow (\S+), revision (\S+), recipe ([^\s)]+)", text)
    rsha = re.search(r"waamflow trace: recipe sha256 ([0-9a-f]{64})", text)
    return {
        "version": head.group(2),
        "revision": head.group(3),
        "recipe": head.group(4),
        "recipe_sha256": rsha.group(1),
        "inputs": dict(re.findall(r"waamflow trace: input (\S+) sha256 ([0-9a-f]{64})", text)),
    }


@pytest.mark.parametrize("name", RECIPES)
def test_headers_carry_version_and_hashes(runs, name):
    results, _ = runs
    recipe, posts, result = results[name]
    trace = result.summary(recipe.name)["trace"]
    assert trace["recipe_sha256"] == recipe_sha256(recipe)
    assert trace["inputs"], f"{name}: no input files hashed"
    for path, digest in trace["inputs"].items():
        assert hashlib.sha256((GRAPHS / path).read_bytes()).hexdigest() == digest, path
    for nid, (_o, prof, params) in posts.items():
        files = _files(result, nid)
        if params["format"] == "inform":  # 32-character comments: the short forms
            text = files["JBI"]
            assert f"'waamflow {__version__}" in text and f"'rev {source_revision()}"[:33] in text, f"{name}/{prof}"
            assert f"'recipe sha256 {trace['recipe_sha256'][:16]}" in text, f"{name}/{prof}"
            continue
        if params["format"] == "tp":  # numbered 32-character comments of the main program
            text = files["LS"]
            assert f"  ! waamflow {__version__} ;" in text, f"{name}/{prof}"
            assert f"! rev {source_revision()}"[:32] in text, f"{name}/{prof}"
            assert f"! recipe sha256 {trace['recipe_sha256'][:16]} ;" in text, f"{name}/{prof}"
            continue
        main = {"gcode": "gcode", "krl": "src", "rapid": "mod"}[params["format"]]
        got = _trace(files[main])
        assert got == {
            "version": __version__,
            "revision": source_revision(),
            "recipe": recipe.name,
            "recipe_sha256": trace["recipe_sha256"],
            "inputs": trace["inputs"],
        }, f"{name}/{prof}"
        assert trace["revision"] == source_revision()
        for text in files.values():  # every file of the program (parts too)
            assert _trace(text)["revision"] == source_revision(), f"{name}/{prof}"


def test_rerun_gives_the_same_hashes(runs):
    results, cache = runs
    recipe, posts, first = results["mpp-cross"]
    again = execute(
        build_graph(parse_recipe(_matrix_recipe("mpp-cross")[0])), resolver=FileResolver(GRAPHS), cache=cache
    )
    a, b = first.summary(recipe.name)["trace"], again.summary(recipe.name)["trace"]
    assert (a["recipe_sha256"], a["inputs"]) == (b["recipe_sha256"], b["inputs"])
    nid = next(k for k, v in posts.items() if v[1] == "generic")
    strip = lambda t: "\n".join(ln for ln in t.splitlines() if "waamflow trace: date" not in ln)  # noqa: E731
    assert strip(_files(first, nid)["gcode"]) == strip(_files(again, nid)["gcode"])


def test_curved_duct_gcode_carries_the_simulated_positioner_angles_as_rotary_axes(runs):
    """#12 item 4: G-code from a positioner cell names the positioner axes by the profile's
    letters (generic/linuxcnc A/C, marlin B/C) in degrees; the values move layer by layer and are
    the simulation's angles."""
    from program_checkers import check_gcode

    from waamflow.core.moves import flatten
    from waamflow.trajectory.cell import load_cell, positioner_angles

    _, cache = runs
    doc = json.loads((GRAPHS / "curved-duct.json").read_text())
    next(n for n in doc["nodes"] if n["id"] == "fan")["params"]["layer_count"] = 12
    post = next(n for n in doc["nodes"] if n["id"] == "post")
    for prof in ("linuxcnc", "marlin"):
        doc["nodes"].append(
            {
                "id": f"g_{prof}",
                "type": "post-process",
                "params": {**post["params"], "format": "gcode", "profile": prof},
            }
        )
        doc["edges"].append({"from": "bead.toolpath", "to": f"g_{prof}.toolpath"})
    result = execute(build_graph(parse_recipe(doc)), resolver=FileResolver(GRAPHS), cache=cache)
    sim = json.loads(result.artifacts["sim.simulation.json"])
    moves = flatten(result.outputs["bead"]["toolpath"])
    angles = positioner_angles(load_cell("kr150_tilt_rotate"), moves, "gravity")
    assert result.warnings == []
    for prof, (tilt, turn) in {"linuxcnc": ("A", "C"), "marlin": ("B", "C")}.items():
        text = _files(result, f"g_{prof}")["gcode"]
        assert f"; rotary axes: {tilt} = positioner E1 (tilt), {turn} = positioner E2 (turn) in degrees" in text
        rot = check_gcode({"gcode": text}, {**PROFILES[prof]["post"], **post["params"]})["rotary"]
        e1, e2 = np.array(rot[tilt]), np.array(rot[turn])
        assert len(e1) == len(moves.points) + 1  # one per motion + the final lift
        assert (e1[-1], e2[-1]) == (e1[-2], e2[-2])  # the lift keeps the angles
        e1, e2 = e1[:-1], e2[:-1]
        assert np.allclose(e1, angles[:, 0], atol=1e-3) and np.allclose(e2, angles[:, 1], atol=1e-3)
        assert len(np.unique(np.round(e1, 3))) == 12  # moves once per layer
        assert e1.min() == pytest.approx(sim["positioner_e1_min_deg"], abs=1e-3) == pytest.approx(1.54)
        assert e1.max() == pytest.approx(sim["positioner_e1_max_deg"], abs=1e-3) == pytest.approx(12 * 1.54)
        assert e2.min() == pytest.approx(sim["positioner_e2_min_deg"]) and e2.max() == pytest.approx(
            sim["positioner_e2_max_deg"]
        )


def test_curved_duct_robot_programs_carry_the_simulated_positioner_angles(runs):
    """Every robot format whose checker reads the positioner (Fanuc TP group 2 J1/J2, Yaskawa
    INFORM station EC pulses over the profile's pulses per degree) has, per motion, the angles the
    simulation turns the positioner to (`positioner_angles` of the cell and policy)."""
    from waamflow.core.moves import flatten
    from waamflow.trajectory.cell import load_cell, positioner_angles

    results, _ = runs
    recipe, posts, result = results["curved-duct"]
    moves = flatten(result.outputs["bead"]["toolpath"])
    checked = set()
    for nid, (_orig, prof, params) in posts.items():
        fmt = params["format"]
        if fmt not in ("tp", "inform"):
            continue
        angles = positioner_angles(load_cell(params["cell"]), moves, params.get("positioner_policy", "fixed"))
        got = PROGRAM_CHECKERS[fmt](_files(result, nid), {**PROFILES[prof]["post"], **params})
        if fmt == "tp":
            axes = np.array(got["joints"])
        else:
            axes = np.array(got["station"], float) / np.array(PROFILES[prof]["post"]["station_pulses_per_deg"])
        assert axes.shape == angles.shape == (len(moves.points), 2), prof
        assert np.abs(axes - angles).max() <= ANGLE_TOL, prof
        assert len(np.unique(np.round(axes[:, 0], 3))) == LAYER_LIMIT["curved-duct"][1], prof
        checked.add(fmt)
    assert checked == {"tp", "inform"}
