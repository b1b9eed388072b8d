"""Interpass control and treatment paths reach the outputs: the program states each layer's dwell
with the rule that set it (G-code G4 in the profile's unit, KRL WAIT SEC, RAPID WaitTime), the
summary states the dwell per layer and the time it adds (also from a cached re-run), and rolling
strokes become the machine's tool commands with force, width and speed, per layer."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from waamflow.engine.cache import MemoryCache, SqliteCache, TieredCache
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_recipe
from waamflow.process.interpass import HeatModel, plan_dwells
from waamflow.process.treatment import TreatmentSpec, plan_treatment
from waamflow.program import GcodeSettings, parse_gcode, post_process

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"
RECIPE = GRAPHS / "bead-trials.json"


def _recipe(layers=3, **extra):
    return apply_overrides(load_recipe(RECIPE), [("layers", layers), *extra.items()])


@pytest.fixture(scope="module")
def seq():
    """The worked example's sequenced toolpath, 3 layers."""
    return execute(build_graph(_recipe()), resolver=FileResolver(GRAPHS), targets=["sequence"]).outputs["sequence"][
        "toolpath"
    ]


def _text(a):
    return a.decode() if isinstance(a, bytes) else a


def test_summary_states_the_dwells_and_a_cached_rerun_too(tmp_path):
    graph = build_graph(_recipe())
    cache = TieredCache(MemoryCache(), SqliteCache(tmp_path / "cache.sqlite"))
    first = execute(graph, resolver=FileResolver(GRAPHS), cache=cache)
    s1 = first.summary("bead-trials")
    rep = s1["nodes"]["interpass"]["report"]
    assert [r["layer"] for r in rep["layers"]] == [0, 1, 2]
    assert rep["total_added_dwell_s"] == pytest.approx(sum(r["added_dwell_s"] for r in rep["layers"]), abs=1e-3)
    assert rep["total_dwell_s"] == pytest.approx(sum(r["dwell_s"] for r in rep["layers"]), abs=1e-3)
    assert rep["layers"][0]["dwell_s"] > 0 and rep["layers"][0]["limited_by"] == "temperature"
    assert rep["layers"][-1]["dwell_s"] == 0 and rep["layers"][-1]["limited_by"] == "none"
    # the same numbers as the node's own artifact
    full = json.loads(first.artifacts["interpass.interpass.json"])
    assert [r["dwell_s"] for r in full["layers"]] == [r["dwell_s"] for r in rep["layers"]]
    # the treatment node reports too: strokes per layer
    roll = s1["nodes"]["rolling"]["report"]
    assert roll["strokes"] == sum(r["strokes"] for r in roll["layers"]) > 0
    # a second run in another process (fresh memory, same disk cache) is cached and says the same
    again = execute(
        build_graph(_recipe()),
        resolver=FileResolver(GRAPHS),
        cache=TieredCache(MemoryCache(), SqliteCache(tmp_path / "cache.sqlite")),
    )
    s2 = again.summary("bead-trials")
    assert s2["nodes"]["interpass"]["cached"] and s2["nodes"]["interpass"]["report"] == rep
    assert s2["nodes"]["rolling"]["report"] == roll
    json.dumps(s2, allow_nan=False)  # summary.json stays plain JSON


def test_gcode_states_each_layers_dwell_and_rule():
    res = execute(build_graph(_recipe()), resolver=FileResolver(GRAPHS))
    rep = res.stats["interpass"].report
    gcode = _text(res.artifacts["post.gcode"])
    prog = parse_gcode(gcode)
    # the program's interlayer dwells (arc off, not ignition) are the planned ones, layer by layer
    inter = [sec for line, sec, arc in prog.dwells if not arc and "interlayer" in gcode.split("\n")[line - 1]]
    planned = [r["dwell_s"] for r in rep["layers"] if r["dwell_s"] > 0]
    assert inter == pytest.approx(planned, abs=1e-3) and len(planned) == 2
    assert sum(inter) == pytest.approx(rep["total_added_dwell_s"], abs=2e-3)
    notes = re.findall(
        r"interlayer dwell [\d.]+ s \(interpass control: limit 150 degC, lumped heat model: part (\d+) degC "
        r"after layer (\d), (\d+) degC at the next layer's start\)",
        gcode,
    )
    assert [int(n[1]) for n in notes] == [0, 1]
    assert [int(n[0]) for n in notes] == [round(r["peak_c"]) for r in rep["layers"][:2]]
    assert all(int(n[2]) <= 150 for n in notes)


def test_dwell_units_and_robot_formats(seq):
    tp, rep = plan_dwells(seq, HeatModel(interpass_c=150.0, min_layer_time_s=400.0))
    rows = rep["layers"]
    assert [r["limited_by"] for r in rows] == ["min_layer_time", "min_layer_time", "none"]
    for r in rows[:2]:  # the minimum layer time rule: arc + travel + dwell = 400 s
        assert r["arc_time_s"] + r["travel_time_s"] + r["dwell_s"] == pytest.approx(400.0, abs=0.01)
    ms = post_process(tp, "gcode", writer_settings=GcodeSettings(dwell_units="ms")).files["gcode"]
    lines = re.findall(
        r"^G4 P(\d+) ; interlayer dwell ([\d.]+) s \(interpass control: minimum layer time 400 s\)$", ms, re.M
    )
    assert [int(p) for p, _ in lines] == [round(r["dwell_s"] * 1000) for r in rows[:2]]
    krl = post_process(tp, "krl").files["src"]
    waits = re.findall(
        r"^WAIT SEC ([\d.]+) ; interlayer dwell \(interpass control: minimum layer time 400 s\)$", krl, re.M
    )
    assert [float(w) for w in waits] == pytest.approx([r["dwell_s"] for r in rows[:2]], abs=1e-3)
    mod = post_process(tp, "rapid").files["mod"]
    waits = re.findall(
        r"WaitTime\\InPos, ([\d.]+); ! interlayer dwell \(interpass control: minimum layer time 400 s\)", mod
    )
    assert [float(w) for w in waits] == pytest.approx([r["dwell_s"] for r in rows[:2]], abs=1e-3)
    # robot programs stay ASCII (controllers' code pages)
    assert krl.isascii() and mod.isascii()


def _segments_per_layer(text, layer_re, on, off):
    """Per layer: [(on line, off line)] of tool engagements, checking they alternate."""
    out, layer, open_at = {}, None, None
    for k, line in enumerate(text.split("\n")):
        m = re.match(layer_re, line)
        if m:
            layer = int(m.group(1))
        if re.search(on, line):
            assert open_at is None, f"line {k + 1}: tool engaged twice"
            open_at = k
        elif re.search(off, line):
            assert open_at is not None, f"line {k + 1}: tool lifted without engagement"
            out.setdefault(layer, []).append((open_at, k))
            open_at = None
    assert open_at is None
    return out


def test_rolling_program_commands_per_layer(seq):
    spec = TreatmentSpec(tool_width_mm=8.0, force_n=18000.0, speed=12.0, clearance_mm=10.0)
    tp, rep = plan_treatment(seq, spec, interleave=False)
    per_layer = {r["layer"]: r["strokes"] for r in rep["layers"]}
    assert sum(per_layer.values()) == rep["strokes"] > 10
    gcode = post_process(tp, "gcode").files["gcode"]
    strokes = _segments_per_layer(
        gcode,
        r"^; layer (\d+)",
        r"^M110 P18000 Q8 ; rolling on: force 18000 N, "
        r"tool width 8 mm, 12 mm/s$",
        r"^M111 ; rolling off$",
    )
    assert {k: len(v) for k, v in strokes.items()} == per_layer
    lines = gcode.split("\n")
    z_top = {lp.index: lp.layer.z for lp in seq}
    for layer, pairs in strokes.items():
        for a, b in pairs:
            # between on and off: only feed moves on the bead top at the rolling speed
            moves = [ln for ln in lines[a + 1 : b] if ln.startswith("G")]
            assert moves and all(ln.startswith("G1 ") for ln in moves)
            assert all(float(re.search(r"Z([-\d.]+)", ln).group(1)) == pytest.approx(z_top[layer]) for ln in moves)
            # the approach lowers onto the start from the clearance; the retract lifts 10 mm
            assert re.search(r"Z([-\d.]+)", lines[a - 1]) and float(
                re.search(r"Z([-\d.]+)", lines[a - 1]).group(1)
            ) == pytest.approx(z_top[layer])
            lift = next(ln for ln in lines[b + 1 :] if ln.startswith("G"))
            assert lift.startswith("G0") and float(re.search(r"Z([-\d.]+)", lift).group(1)) == pytest.approx(
                z_top[layer] + 10
            )
    assert "F720" in gcode  # 12 mm/s
    first = next(ln for ln in lines if ln.startswith("G0"))  # the program starts above the part
    assert float(re.search(r"Z([-\d.]+)", first).group(1)) == pytest.approx(z_top[0] + 10)
    # KRL and RAPID: the cell's routines with force, width and speed, once per stroke
    krl = post_process(tp, "krl").files["src"]
    assert krl.count("TOOL_ON(18000.0, 8.00, 12.00)") == rep["strokes"] == krl.count("TOOL_OFF()")
    assert krl.count("WAIT SEC 0 ; advance-run stop") == 2 * rep["strokes"]
    mod = post_process(tp, "rapid").files["mod"]
    assert mod.count("ToolOn 18000.0, 8.00, 12.00;") == rep["strokes"] == mod.count("ToolOff;")
    # the motion into each engagement ends in a fine point (the robot stands when the tool goes down)
    assert len(re.findall(r"fine, tWeldGun\\WObj:=wobj0;\n    ToolOn", mod)) == rep["strokes"]


def test_interleaved_rolling_follows_each_layers_deposition(seq):
    tp, rep = plan_treatment(seq, TreatmentSpec(force_n=20000.0), interleave=True)
    gcode = post_process(tp, "gcode").files["gcode"]
    lines = gcode.split("\n")
    strokes = _segments_per_layer(gcode, r"^; layer (\d+)", r"^M110 P20000 Q8 ", r"^M111 ")
    assert {k: len(v) for k, v in strokes.items()} == {r["layer"]: r["strokes"] for r in rep["layers"]}
    starts = [lines.index(f"; layer {lp.index} z={lp.layer.z:.3f}") for lp in seq] + [len(lines)]
    for layer, pairs in strokes.items():
        block = range(starts[layer], starts[layer + 1])
        ons = [k for k in block if lines[k].startswith("M3 ")]
        offs = [k for k in block if lines[k].startswith("M5 ")]
        # every bead of the layer is laid (ignited and put out) before its first stroke, and all
        # its strokes come before the next layer
        runs = sum(
            int(np.count_nonzero(np.diff(np.concatenate([[0], sp.arc.astype(int)])) == 1)) for sp in seq[layer].sections
        )
        assert len(ons) == len(offs) == runs > 0
        assert max(offs) < pairs[0][0] and pairs[-1][1] < starts[layer + 1]
    # no tool engagement while the arc is on
    arc_on = False
    for ln in lines:
        arc_on = True if ln.startswith("M3 ") else False if ln.startswith("M5 ") else arc_on
        assert not (arc_on and ln.startswith("M110"))


def test_machine_profile_and_bad_templates():
    recipe = _recipe(layers=1)
    doc = recipe.to_json()
    for n in doc["nodes"]:
        if n["id"] == "rolling_post":
            n["params"]["profile"] = "marlin"
    res = execute(build_graph(parse_recipe(doc)), resolver=FileResolver(GRAPHS), targets=["rolling_post"])
    gcode = _text(next(iter(res.outputs["rolling_post"]["program"].files.values())))
    strokes = res.outputs["rolling"]["report"]["strokes"]
    assert gcode.count("M42 P5 S255 ; rolling on: force 20000 N") == strokes == gcode.count("M42 P5 S0 ; rolling off")
    from pydantic import ValidationError
    from waamflow.engine.node import load_nodes

    with pytest.raises(ValidationError, match="unknown field"):
        load_nodes()["post-process"].Params(tool_on="M110 P{pressure}")
    with pytest.raises(ValueError, match="tool_on"):
        GcodeSettings(tool_on="M110 P{force_n:q}")


def test_plots_state_the_numbers(seq):
    from waamflow.process.interpass import interpass_svg
    from waamflow.process.svgplot import nice_ticks

    assert nice_ticks(0, 2654) == [0, 500, 1000, 1500, 2000, 2500]
    assert nice_ticks(1.04, 2.37) == [1.25, 1.5, 1.75, 2.0, 2.25]
    _, rep = plan_dwells(seq, HeatModel(interpass_c=150.0))
    svg = interpass_svg(rep)
    dwells = [r["dwell_s"] for r in rep["layers"] if r["dwell_s"] > 0]
    assert svg.count('fill="#dde6f0"') == len(dwells) + 1  # one band per dwell + the legend key
    for d in dwells:
        assert f">{d:.0f} s</text>" in svg
    assert f"total dwell {rep['total_dwell_s']:.0f} s" in svg
