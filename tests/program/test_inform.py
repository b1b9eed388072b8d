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
from waamflow.program.inform import InformSettings

from inform_check import check_jbi, check_program

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
    assert on and on.group(2) == "0.50"  # the ignition dwell is ARCON's T
    assert re.search(r"^ARCSET AC=\d+$", first, re.M)  # a zone change while welding
    # wire feed has no inline INFORM form: said, per zone, and the preflight warns it cannot balance the metal
    warns = [w["message"] for w in cross.warnings if w["node"] == "post"]
    assert any("wire_feed_speed" in w and "not commanded" in w for w in warns)
    probs = cross.preflight["programs"][0]["problems"]
    assert any(p["check"] == "volume_ratio" and "without a wire feed" in p["message"] for p in probs)
    assert cross.preflight["verdict"] == "warn"


def test_positions_and_orientation(cross):
    program = cross.outputs["post"]["program"]
    job = program.files["L002.JBI"]
    c = np.array(
        [
            [float(v) for v in m.groups()]
            for m in re.finditer(r"^C\d{5}=([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+),([-\d.]+)$", job, re.M)
        ]
    )
    # layer 2 welds at z = 4.5 mm; a vertical torch (tool axis down) is Rx 180, Ry 0
    assert np.isclose(c[:, 2], 4.5).sum() > 10 and (c[:, 2] >= 4.5 - 1e-9).all()
    down = np.isclose(c[:, 2], 4.5)
    assert np.allclose(np.abs(c[down, 3]), 180.0) and np.allclose(c[down, 4], 0.0)


def test_refusals():
    recipe = apply_overrides(load_recipe(GRAPHS / "curved-duct.json"), [])
    rec = recipe.model_copy(deep=True)
    post = next(n for n in rec.nodes if n.type == "post-process")
    post.params["format"] = "inform"
    assert post.params.get("cell") == "kr150_tilt_rotate"  # the shipped duct runs on a positioner cell
    # station axes need the controller's pulses per degree (the yaskawa_yrc1000 profile gives them)
    with pytest.raises(RecipeError, match=r"station_pulses_per_deg needs 2 positive values .*got \[\]") as err:
        execute(build_graph(rec), resolver=FileResolver(GRAPHS), preflight=False)
    assert err.value.field == "station_pulses_per_deg"
    with pytest.raises(ValueError, match="1 to 3 positioner axes"):
        InformSettings(external_axes=np.zeros((2, 4)), station_pulses_per_deg=(1.0,) * 4)
    with pytest.raises(ValueError, match=r"needs 2 positive values"):
        InformSettings(external_axes=np.zeros((2, 2)), station_pulses_per_deg=(1000.0, 0.0))


def test_curved_duct_is_a_coordinated_job_with_the_station():
    """With the yaskawa_yrc1000 profile the positioner is station 1: every layer job declares one EC
    position per C position in pulses (1000 per degree in the profile), GROUP2 ST1, every motion
    SMOVL .. +MOVJ EC..; the preflight reads the coordinated motions (deposition length = the
    program's)."""
    recipe = apply_overrides(load_recipe(GRAPHS / "curved-duct.json"), [])
    rec = recipe.model_copy(deep=True)
    next(n for n in rec.nodes if n.id == "fan").params["layer_count"] = 4
    rec.nodes = [n for n in rec.nodes if n.id != "sim"]
    rec.edges = [e for e in rec.edges if not e.to.startswith("sim.")]
    post = next(n for n in rec.nodes if n.type == "post-process")
    post.params.update(format="inform", profile="yaskawa_yrc1000")
    result = execute(build_graph(rec), resolver=FileResolver(GRAPHS), preflight=True)
    program = result.outputs["post"]["program"]
    info = check_program(program.files)
    jobs = [v for k, v in program.files.items() if k != "JBI"]
    assert len(jobs) == 4 and all("///GROUP2 ST1" in j and "\n///POSTYPE PULSE\n///PULSE\nEC00000=" in j for j in jobs)
    assert info["motions"] == len(info["station"]) == program.stats["motions"]
    assert all(
        re.fullmatch(r"SMOVL C(\d{5}) V=\d+\.\d PL=[01] \+MOVJ EC\1", ln)
        for j in jobs
        for ln in j.splitlines()
        if "MOVL" in ln
    )
    e1 = sorted({p[0] for p in info["station"]})
    assert e1 == [1540 * k for k in range(1, 5)]  # 1.54° more tilt per layer, 1000 pulses/°
    assert {p[1] for p in info["station"]} == {-90000}  # the turn: -90°
    dep = sum(r.length for r in read_inform(program.files).runs)
    assert dep == pytest.approx(program.stats["deposition_length_mm"], abs=0.01) and dep > 300
