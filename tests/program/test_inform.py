"""Yaskawa INFORM jobs (#28 item 4): a structural checker of the .JBI files, the weld in ARCON /
ARCSET, lengths read back equal to the program's statistics, refusals."""

import re
from pathlib import Path

import numpy as np
import pytest

from waamflow.core.errors import RecipeError
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe
from waamflow.preflight.read import read_inform

from inform_check import check_jbi

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


@pytest.fixture(scope="module")
def cross():
    recipe = apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), [("format", "inform")])
    return execute(build_graph(recipe), resolver=FileResolver(GRAPHS), preflight=True)


def test_mpp_cross_as_inform_jobs(cross):
    program = cross.outputs["post"]["program"]
    assert program.format == "inform" and program.name == "POST"
    names = program.file_names("post")
    assert names["JBI"] == "POST.JBI" and names["L003.JBI"] == "POST_L003.JBI"
    info = {k: check_jbi(v) for k, v in program.files.items()}
    main = program.files["JBI"]
    assert re.findall(r"^CALL JOB:(\S+)$", main, re.M) == [f"POST_L{k:03d}" for k in range(8)]
    assert sum(i["arcs"] for i in info.values()) == program.stats["arc_on_count"] == 24
    # read back by the preflight's reader: the arc-ON length is the program's deposition length
    read = read_inform(program.files)
    dep = sum(r.length for r in read.runs)
    assert dep == pytest.approx(program.stats["deposition_length_mm"], abs=0.01)
    assert len(read.runs) == 24 and all(r.weld.all() for r in read.runs)


def test_weld_values_are_commands(cross):
    program = cross.outputs["post"]["program"]
    text = "\n".join(program.files[k] for k in sorted(program.files) if k != "JBI")
    # the zones' currents (mpp-cross.params.xml: I = 55 A + 15 A per m/min of wire feed)
    currents = {int(x) for x in re.findall(r"\bAC=(\d+)", text)}
    assert currents and all(55 <= c <= 205 for c in currents)
    first = program.files["L000.JBI"]
    on = re.search(r"^ARCON AC=(\d+) T=(\d+\.\d\d)$", first, re.M)
    assert on and on.group(2) == "0.50"                       # the ignition dwell is ARCON's T
    assert re.search(r"^ARCSET AC=\d+$", first, re.M)          # a zone change while welding
    # wire feed has no inline INFORM form: said, per zone, and the preflight warns it cannot balance the metal
    warns = [w["message"] for w in cross.warnings if w["node"] == "post"]
    assert any("wire_feed_speed" in w and "not commanded" in w for w in warns)
    probs = cross.preflight["programs"][0]["problems"]
    assert any(p["check"] == "volume_ratio" and "without a wire feed" in p["message"] for p in probs)
    assert cross.preflight["verdict"] == "warn"


def test_positions_and_orientation(cross):
    program = cross.outputs["post"]["program"]
    job = program.files["L002.JBI"]
    c = np.array([[float(v) for v in m.groups()] for m in re.finditer(
        r"^C\d{5}=([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+)$", job, re.M)])
    # layer 2 welds at z = 4.5 mm; a vertical torch (tool axis down) is Rx 180, Ry 0
    assert np.isclose(c[:, 2], 4.5).sum() > 10 and (c[:, 2] >= 4.5 - 1e-9).all()
    down = np.isclose(c[:, 2], 4.5)
    assert np.allclose(np.abs(c[down, 3]), 180.0) and np.allclose(c[down, 4], 0.0)


def test_refusals():
    recipe = apply_overrides(load_recipe(GRAPHS / "curved-duct.json"), [])
    rec = recipe.model_copy(deep=True)
    post = next(n for n in rec.nodes if n.type == "post-process")
    post.params["format"] = "inform"
    assert post.params.get("cell") == "kr150_tilt_rotate"     # the shipped duct runs on a positioner cell
    with pytest.raises(RecipeError, match="station axes"):
        execute(build_graph(rec), resolver=FileResolver(GRAPHS), preflight=False)
