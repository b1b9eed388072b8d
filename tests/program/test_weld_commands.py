"""Issue #23 items 1-2: the weld in the program, in every dialect, and Marlin travel feeds.

Every zone value (wire feed m/min, current A, voltage V, job) reaches the program as a command
that a reader finds through the program's `waamflow-weld:` header line; a value a dialect cannot
command is a weld issue naming zone and section; Marlin's travel carries F and the header's time
is the time Marlin takes.
"""

import math
import re

import numpy as np
import pytest
from program_checkers import check_gcode

from waamflow.core.moves import flatten
from waamflow.engine.node import load_nodes
from waamflow.program import GcodeSettings, KrlSettings, plan_program, post_process
from waamflow.program.common import parse_weld_tag, read_weld_commands, template_regex
from waamflow.program.plan import ArcOff, ArcOn, ProcessChange

from conftest import ZONE_PARAMS, build_toolpath
from krl_check import parse_program
from rapid_check import parse_module, values


class Ctx:
    node_id = "post"

    def __init__(self):
        self.warnings = []

    def warn(self, message, *, layer=None, section=None):
        self.warnings.append((message, layer, section))


def _node(toolpath, **params):
    cls = load_nodes()["post-process"]
    ctx = Ctx()
    out = cls().run(ctx, cls.Params(**params), {"toolpath": toolpath})
    return out["program"], ctx.warnings


def expected_commands(moves, name: str) -> list[float]:
    """The values of `name` a program must command, from the plan: every zone change before an
    ignition (arc off: all values) and, inside a run, the ones that changed."""
    out, arc, last = [], False, {}
    for st in plan_program(moves).steps:
        if isinstance(st, ArcOn):
            arc = True
        elif isinstance(st, ArcOff):
            arc = False
        elif isinstance(st, ProcessChange) and name in st.params:
            v = float(st.params[name])
            if not arc or last.get(name) != v:
                out.append(v)
            last.update({k: float(x) for k, x in st.params.items()})
    return out


@pytest.fixture(scope="module")
def moves():
    return flatten(build_toolpath(3))


# ---- G-code --------------------------------------------------------------------------------
def test_gcode_default_commands_wfs_current_voltage_job_on_linuxcnc_analog_outputs(moves):
    text = post_process(moves, "gcode").files["gcode"]
    tag = parse_weld_tag(text)
    assert tag["wire_feed_speed"]["commands"] == ["M67 E0 Q{value:.2f}", "M68 E0 Q{value:.2f}"]
    assert tag["current"]["unit"] == "A" and tag["job"]["commands"] == ["M120 P{value:.0f}"]
    got = read_weld_commands(text)
    for name in ("wire_feed_speed", "current", "voltage", "job"):
        assert got[name] == expected_commands(moves, name), name
    # 15 runs: 15 ignitions write M68 (immediate) before the arc-on code; zone changes inside a run M67
    lines = text.splitlines()
    m68 = [i for i, ln in enumerate(lines) if ln.startswith("M68 E0 ")]
    assert len(m68) == 15
    assert all(next(x for x in lines[i + 1 :] if not x.startswith(("M68 ", "M120 "))).startswith("M3 ") for i in m68)
    # 27 zone changes (3 zones x 9 sections): 15 at an ignition, 12 inside a run
    assert len(re.findall(r"^M67 E0 Q", text, re.M)) == len(expected_commands(moves, "wire_feed_speed")) - 15 == 12
    assert len(re.findall(r"^M120 P12$", text, re.M)) == 9  # the start zone's job, 9 sections
    # pygcode accepts every line and the lengths stay those of the header
    got = check_gcode({"gcode": text}, {})
    assert got["points"] == plan_program(moves).stats["motions"]


def test_gcode_compensation_steps_are_commands():
    """A run cut into 1 mm feed steps (what compensate-deposit makes): every step a command."""
    from dataclasses import replace

    tp = build_toolpath(1)
    lp = tp.items[0]
    sp = lp.sections[0]
    n = len(sp.points) - 1
    zone = tuple(f"s{i}" for i in range(n))
    params = {f"s{i}": {"wire_feed_speed": round(8.0 + 0.25 * i, 4), "current": 200.0} for i in range(n)}
    sp2 = replace(sp, zone=zone, zone_params=params, zone_colors={z: "#000000" for z in zone})
    m = flatten(type(tp)((type(lp)(lp.layer, (sp2,), 0.0),)))
    text = post_process(m, "gcode").files["gcode"]
    wfs = read_weld_commands(text)["wire_feed_speed"]
    assert wfs == [8.0 + 0.25 * i for i in range(n)] and len(wfs) == n == 8
    assert len(re.findall(r"^M67 E0 ", text, re.M)) == n - 1  # 7 changes while welding
    assert read_weld_commands(text)["current"] == [200.0]  # unchanged: written once


@pytest.mark.parametrize(
    "profile, heads",
    [
        ("generic", ("M67 E0 Q", "M68 E0 Q")),
        ("linuxcnc", ("M67 E0 Q", "M68 E0 Q")),
        ("fanuc", ("G65 P9100 E0 Q",)),
        ("marlin", ("M106 P1 S",)),
    ],
)
def test_every_gcode_profile_commands_the_wire_feed(profile, heads):
    tp = build_toolpath(2)
    m = flatten(tp)
    prog, warnings = _node(tp, profile=profile)
    text = prog.files["gcode"]
    got = read_weld_commands(text)
    want = expected_commands(m, "wire_feed_speed")
    tol = 0.5 / 12.75 if profile == "marlin" else 0.005  # Marlin: S is an integer PWM 0..255
    assert len(got["wire_feed_speed"]) == len(want) == 18  # 10 ignitions + 8 changes in runs
    assert np.allclose(got["wire_feed_speed"], want, atol=tol)
    for name in ("current", "voltage"):
        assert np.allclose(got[name], expected_commands(m, name), atol=0.5 / 0.51 if profile == "marlin" else 0.05)
    code_lines = [ln for ln in text.splitlines() if ln.startswith(heads)]
    assert len(code_lines) == 18
    if profile == "marlin":  # S = 12.75 x m/min: 11 m/min -> 140
        assert "M106 P1 S140" in text and "M106 P2 S112" in text  # 220 A x 0.51 = 112.2
        job = [w for w in warnings if "job 12 not commanded" in w[0]]
        assert job and job[0][2] == "bs1/A" and "zone start" in job[0][0]
        assert [i.zone for i in prog.weld_issues] == ["start"] * 6  # 3 sections x 2 layers
    else:
        assert prog.weld_issues == () and not warnings
        assert got["job"] == [12.0] * 6  # 3 start zones x 2 layers
    check_gcode({"gcode": text}, {"travel_speed": 100.0})


def test_a_gcode_value_without_a_command_is_a_weld_issue(moves):
    prog = post_process(
        moves,
        "gcode",
        writer_settings=GcodeSettings(
            process_codes={"wire_feed_speed": "M67 E0 Q{value:.2f}", "current": "M67 E1 Q{value:.1f}"}
        ),
    )
    msgs = {(i.zone, i.section, i.message) for i in prog.weld_issues}
    assert (
        "z1",
        "bs1/A",
        "voltage 20 V not commanded: the program has no command for it (give it a command template in process_codes)",
    ) in msgs
    assert (
        "start",
        "bs1/C",
        "voltage 21 V, job 12 not commanded: the program has no command for them "
        "(give it a command template in process_codes)",
    ) in msgs
    assert len(prog.weld_issues) == 27  # 3 zones x 3 sections x 3 layers
    assert "waamflow-weld: current[A]=" in prog.files["gcode"] and "voltage[V]=none" in prog.files["gcode"]


# ---- Marlin travel ---------------------------------------------------------------------------
def _marlin_time(text: str) -> tuple[float, int, int]:
    """What Marlin does: G0 = G1 at the modal feed (mm/min); G4 P in ms. Returns (time s, travel
    lines, travel lines with F)."""
    pos, feed, t, n_g0, n_f = None, None, 0.0, 0, 0
    for raw in text.splitlines():
        code = raw.split(";")[0].strip()
        w = dict((m[0], float(m[1:])) for m in code.split()[1:] if m[0] in "XYZFSP") if code else {}
        head = code.split()[0] if code else ""
        if head in ("G0", "G1"):
            if "F" in w:
                feed = w["F"]
            new = np.array([w.get(k, pos[i] if pos is not None else 0.0) for i, k in enumerate("XYZ")])
            if head == "G0":
                n_g0 += 1
                n_f += "F" in w
            if pos is not None:
                t += float(np.linalg.norm(new - pos)) / (feed / 60.0)
            pos = new
        elif head == "G4":
            t += w["P"] / 1000.0
    return t, n_g0, n_f


def test_marlin_travel_has_f_on_every_travel_line_and_the_header_time_is_marlins():
    tp = build_toolpath(3)
    prog, _ = _node(tp, profile="marlin")
    text = prog.files["gcode"]
    t, n_g0, n_f = _marlin_time(text)
    travels = sum(1 for st in plan_program(flatten(tp)).motions if st.mode == "travel")
    assert n_g0 == n_f == travels + 1 == 13  # every travel and the final lift
    assert set(re.findall(r"^G0 .* F(\d+)", text, re.M)) == {"6000"}  # travel_speed 100 mm/s
    header = float(re.search(r"estimated time ([\d.]+) s", text).group(1))
    # the first motion comes from wherever the machine is: Marlin's time from there on
    assert t == pytest.approx(header, abs=0.15)
    assert "G0 with F at travel_speed 100 mm/s on every travel line" in text
    # a weld move after a travel restates its own feed
    lines = text.splitlines()
    for i, ln in enumerate(lines[:-1]):
        if ln.startswith("G0 ") and "final lift" not in ln:
            nxt = next(x for x in lines[i + 1 :] if x.startswith(("G0", "G1")))
            assert nxt.startswith("G0") or " F" in nxt


# ---- KRL ---------------------------------------------------------------------------------------
def test_krl_output_mode_writes_analog_outputs_and_path_triggers(moves):
    prog = post_process(moves, "krl")
    src, dat = prog.files["src"], prog.files["dat"]
    parse_program(src, dat)  # the KRL parser accepts them
    got = read_weld_commands(src)
    for name in ("wire_feed_speed", "current", "voltage"):
        assert got[name] == expected_commands(moves, name), name
    assert len(re.findall(r"^\$ANOUT\[1\]=([\d.]+)/20$", src, re.M)) == 15  # before each ignition
    assert re.findall(r"^TRIGGER WHEN DISTANCE=0 DELAY=0 DO \$ANOUT\[1\]=([\d.]+)/20$", src, re.M)[:2] == [
        "10.000",
        "8.500",
    ]  # inside the run: path-synchronised
    assert len(re.findall(r"^TRIGGER WHEN DISTANCE=0 DELAY=0 DO \$ANOUT\[1\]", src, re.M)) == 12
    assert {i.message for i in prog.weld_issues} == {
        "job 12 not commanded: the program has no command for it (give it a KRL statement in process_codes)"
    }
    assert {i.zone for i in prog.weld_issues} == {"start"} and len(prog.weld_issues) == 9


def test_krl_split_keeps_the_tag_and_triggers_across_a_call(moves):
    files = post_process(moves, "krl", writer_settings=KrlSettings(program_name="part", max_points_per_file=20)).files
    assert all("waamflow-weld:" in t for k, t in files.items() if k.endswith("src"))
    total = []
    for k in sorted(k for k in files if k.endswith(".src")):
        total += read_weld_commands(files[k])["wire_feed_speed"]
    assert total == expected_commands(moves, "wire_feed_speed")


def test_arctech_carries_current_and_reports_an_unmapped_value(moves):
    prog = post_process(moves, "krl", writer_settings=KrlSettings(arc_control="arctech"))
    parsed = parse_program(prog.files["src"], prog.files["dat"])
    sets = [dict(dict(v)["Weld"]) for n, (t, v) in parsed.data.items() if n.startswith("WDAT")]
    assert sorted({x["Channel4"] for x in sets}) == [180.0, 200.0, 220.0]  # current on channel 4
    assert 'current[A]="stArcDat_T.Weld.Channel4"' in prog.files["src"]
    # without a current channel, current is reported, not dropped silently
    p2 = post_process(
        moves,
        "krl",
        writer_settings=KrlSettings(
            arc_control="arctech", arctech_channels={"job": 1, "wire_feed_speed": 2, "voltage": 3}
        ),
    )
    lost = [i for i in p2.weld_issues if "current" in i.message]
    assert len(lost) == 27 and {i.zone for i in lost} == {"start", "z1", "end"}
    assert "current 200 A not commanded" in next(i.message for i in lost if i.zone == "z1")
    assert "current[A]=none" in p2.files["src"]


# ---- RAPID -------------------------------------------------------------------------------------
def test_rapid_header_names_the_welddata_fields_and_values_match(moves):
    text = post_process(moves, "rapid").files["mod"]
    tag = parse_weld_tag(text)
    assert tag["wire_feed_speed"]["commands"] == ["welddata.main_arc.wirefeed"]
    assert tag["current"]["commands"] == ["welddata.main_arc.current"]
    mod = parse_module(text, tool="tWeldGun")
    arcs = {tuple(values(v[2])[2]) for v in mod.data.values() if v[1] == "welddata"}
    assert {(a[3], a[5], a[2], a[0]) for a in arcs} == {
        (11.0, 220.0, 21.0, 12),
        (10.0, 200.0, 20.0, 0),
        (8.5, 180.0, 19.0, 0),
    }


# ---- curved recipes: the bead model's wire feed ------------------------------------------------
def test_bead_model_writes_its_wire_feed_into_every_welded_zone():
    from dataclasses import replace

    cls = load_nodes()["bead-model"]
    tp = build_toolpath(1)
    lp = tp.items[0]
    bare = type(lp)(lp.layer, tuple(replace(sp, zone_params={}) for sp in lp.sections), 0.0)
    out = cls().run_layer(Ctx(), cls.Params(), 0, {"toolpath": bare})["toolpath"]
    assert {z: p["wire_feed_speed"] for sp in out.sections for z, p in sp.zone_params.items()} == {
        "start": 8.1,
        "z1": 8.1,
        "end": 8.1,
    }
    m = flatten(type(tp)((out,)))
    src = post_process(m, "krl").files["src"]
    assert set(read_weld_commands(src)["wire_feed_speed"]) == {8.1}
    assert "$ANOUT[1]=8.100/20" in src
    mod = parse_module(post_process(m, "rapid").files["mod"], tool="tWeldGun")
    assert {values(v[2])[2][3] for v in mod.data.values() if v[1] == "welddata"} == {8.1}
    # a zone's own wire feed stays
    own = cls().run_layer(Ctx(), cls.Params(model_wfs=9.0), 0, {"toolpath": lp})["toolpath"]
    assert own.sections[0].zone_params["z1"]["wire_feed_speed"] == ZONE_PARAMS["z1"]["wire_feed_speed"] == 10.0


def test_template_regex_reads_numbers_back():
    pat = template_regex("$ANOUT[1]={value:.3f}/20")
    assert float(pat.search("TRIGGER WHEN DISTANCE=0 DELAY=0 DO $ANOUT[1]=8.100/20").group(1)) == 8.1
    assert template_regex("M67 E0 Q{value:.2f}").search("M67 E1 Q10.00") is None
    assert math.isclose(float(template_regex("M106 P1 S{value:.0f}").search("M106 P1 S140").group(1)), 140.0)


# ---- weld_values: a recipe without a parameter file states the weld it was planned for -----------
def test_weld_values_fill_zones_without_their_own():
    from dataclasses import replace

    from pydantic import ValidationError

    tp = build_toolpath(1)
    lp = tp.items[0]
    bare = type(tp)((replace(lp, sections=tuple(replace(sp, zone_params={}) for sp in lp.sections)),))
    prog, warnings = _node(bare, weld_values={"wire_feed_speed": 4.3, "current": 150})
    got = read_weld_commands(prog.files["gcode"])
    assert got["wire_feed_speed"] == [4.3] * 5 and got["current"] == [150.0] * 5  # one per ignition (5 runs)
    assert prog.weld_issues == () and warnings == []
    own, _ = _node(tp, weld_values={"wire_feed_speed": 4.3})  # a zone's own value stays
    assert read_weld_commands(own.files["gcode"])["wire_feed_speed"][:3] == [11.0, 10.0, 8.5]
    with pytest.raises(ValidationError, match="travel_speed not a weld value"):
        load_nodes()["post-process"].Params(weld_values={"travel_speed": 5.0})
    with pytest.raises(ValidationError, match="wire_feed_speed 0"):
        load_nodes()["post-process"].Params(weld_values={"wire_feed_speed": 0.0})


def test_shipped_thin_wall_panel_commands_its_wire_feed(tmp_path, monkeypatch):
    from pathlib import Path

    from waamflow.cli import main

    monkeypatch.setenv("WAAMFLOW_CACHE", str(tmp_path / "cache"))
    recipe = Path(__file__).resolve().parents[2] / "graphs" / "thin-wall-panel.json"
    assert main(["run", str(recipe), "--out", str(tmp_path / "out")]) == 0
    text = (tmp_path / "out" / "post.gcode").read_text()
    ignitions = len(re.findall(r"^M3 ", text, re.M))
    assert read_weld_commands(text)["wire_feed_speed"] == [2.0] * ignitions and ignitions == 301
