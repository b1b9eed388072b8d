"""The welding position each layer is deposited in, as the program sets the positioner
(`weld_position`). curved-duct (a 90° bend in 6° wedge layers) on kr150_tilt_rotate, posted in every
dialect that writes a positioner: as written each layer lies flat (the positioner's `auto` policy);
each edit below moves no point, only the positioner's angles as a slip would (the tilt's sign, tilt
and turn swapped, radians where degrees belong, the positioner left at zero, a wrong pulses per
degree), and before this check every one passed (the preflight read the points only). The 6°
wedges of this coarse fan take more metal than the bead gives (volume_ratio fails as written): the
assertions are on the weld_position problems themselves."""

from __future__ import annotations

import functools
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from waamflow.engine.cache import MemoryCache
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set
from waamflow.preflight import run_preflight
from waamflow.preflight.read import read_program
from waamflow.preflight.read.core import NUM

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"
DIALECTS = ["krl", "rapid", "gcode", "tp", "inform"]
CACHE = MemoryCache()  # the part, fan and wall path once; each dialect posts and checks


@functools.lru_cache(maxsize=None)
def _plan(fmt: str, *sets: str):
    extra = ["post.station_pulses_per_deg=[1000, 1000]"] if fmt == "inform" else []
    rec = apply_overrides(
        load_recipe(GRAPHS / "curved-duct.json"), parse_set(["dtheta_deg=6", f"post.format={fmt}", *extra, *sets])
    )
    rec.nodes = [n for n in rec.nodes if n.type != "simulate-robot"]  # TP and INFORM: not simulated
    rec.edges = [e for e in rec.edges if not e.to.startswith("sim.")]
    g = build_graph(rec)
    return g, execute(g, resolver=FileResolver(GRAPHS), cache=CACHE, workers=1)


@pytest.fixture(scope="module", params=DIALECTS)
def planned(request):
    return (request.param, *_plan(request.param))


def _program_files(res) -> dict[str, str]:
    prog = res.outputs["post"]["program"]
    return {n: res.artifacts[n].decode() for n in prog.file_names("post").values()}


def _problems(rep) -> list[dict]:
    return [p for p in rep["problems"] if p["check"] == "weld_position"]


def test_as_written_every_layer_lies_flat(planned):
    fmt, g, res = planned
    rep = run_preflight(g, res.outputs, res.artifacts)
    (prog,) = rep["programs"]
    assert prog["weld_position_max_deg"] == pytest.approx(0.0, abs=0.05), fmt
    assert rep["weld_position_max_deg"] == prog["weld_position_max_deg"]  # the run's figure (the GUI's "off flat")
    assert prog["weld_position_unjudged_runs"] == 0 and not _problems(rep)


def test_every_dialect_reads_the_angles_the_plan_wrote(planned):
    """Per run, the positioner's angles each reader gives: one set (the positioner turns between
    layers), the tilt rising by the wedge angle layer by layer (6° here) at the turn KRL states."""
    fmt, g, res = planned
    runs = read_program(fmt, _program_files(res)).runs
    got = np.array([r.ext[0][1][:2] for r in runs])
    assert all(len(r.ext) == 1 for r in runs) and len(runs) == 15
    krl = read_program("krl", _program_files(_plan("krl")[1])).runs
    want = np.array([r.ext[0][1][:2] for r in krl])
    assert got == pytest.approx(want, abs=0.002), fmt
    assert np.diff(got[:, 0]) == pytest.approx(np.full(14, 6.0), abs=0.01)


def _edit_e1(text: str, fn) -> str:
    """Every `E1 v` of the KRL .dat through fn(v, E2)."""

    def sub(m: re.Match) -> str:
        e1, e2 = float(m.group(1)), float(m.group(2))
        a, b = fn(e1, e2)
        return f"E1 {a:.3f},E2 {b:.3f}"

    return re.sub(r"E1 (" + NUM + r"),E2 (" + NUM + ")", sub, text)


KRL_SLIPS = [  # (what, edit of E1, E2): the worst layer then lies more than 45° off flat
    ("tilt sign", lambda a, b: (-a, b)),
    ("tilt and turn swapped", lambda a, b: (b, a)),
    ("radians", lambda a, b: (np.radians(a), b)),
    ("positioner at zero", lambda a, b: (0.0, 0.0)),
    ("turn off by 90", lambda a, b: (a, b + 90.0)),
]


@pytest.mark.parametrize("what,fn", KRL_SLIPS, ids=[k[0] for k in KRL_SLIPS])
def test_each_slip_of_the_krl_angles_fails(what, fn):
    g, res = _plan("krl")
    dat = res.artifacts["post.dat"].decode()
    rep = run_preflight(g, res.outputs, {**res.artifacts, "post.dat": _edit_e1(dat, fn).encode()})
    (p,) = _problems(rep)
    assert p["severity"] == "fail" and rep["verdict"] == "fail", what
    assert p["value"] > 45.0 and f"layer {p['layer']}, section" in p["message"], (what, p["value"])
    # the points are where they were: coverage, top and wire balance unchanged
    assert (
        rep["programs"][0]["uncovered_share"]
        == run_preflight(g, res.outputs, res.artifacts)["programs"][0]["uncovered_share"]
    )


def test_the_tilt_sign_doubles_each_layers_angle():
    """With the tilt's sign flipped, the layer tilted t lies 2t off flat: the worst is the last (15 ×
    6° = 90° of bend: 180°, upside down)."""
    g, res = _plan("krl")
    dat = _edit_e1(res.artifacts["post.dat"].decode(), lambda a, b: (-a, b))
    rep = run_preflight(g, res.outputs, {**res.artifacts, "post.dat": dat.encode()})
    (p,) = _problems(rep)
    assert p["value"] == pytest.approx(180.0, abs=0.5) and p["layer"] == 14


def test_angles_outside_the_axis_limits_fail():
    """kr150_tilt_rotate tilts ±135°: a tilt of 150° (layer 3 on) is where the controller stops."""
    g, res = _plan("krl")
    dat = _edit_e1(res.artifacts["post.dat"].decode(), lambda a, b: (150.0 if a > 20 else a, b))
    rep = run_preflight(g, res.outputs, {**res.artifacts, "post.dat": dat.encode()})
    (p,) = [p for p in _problems(rep) if "outside its axis limits" in p["message"]]
    assert p["severity"] == "fail" and p["layer"] == 3 and "E1 150.000°" in p["message"]
    assert rep["verdict"] == "fail"


def test_thirty_degrees_off_flat_warns():
    """One layer's tilt 30° short (between the warning at 20° and the failure at 45°)."""
    g, res = _plan("krl")
    dat = res.artifacts["post.dat"].decode()
    tilt = sorted({float(v) for v in re.findall(r"E1 (" + NUM + ")", dat)})[10]
    dat = dat.replace(f"E1 {tilt:.3f},", f"E1 {tilt - 30.0:.3f},")
    rep = run_preflight(g, res.outputs, {**res.artifacts, "post.dat": dat.encode()})
    (p,) = _problems(rep)
    assert p["severity"] == "warn" and p["value"] == pytest.approx(30.0, abs=0.05) and p["layer"] == 10


def test_gcode_angles_in_the_unit_the_header_states():
    """G-code rotary words are degrees by the header: a header that says radians over the same
    words turns the positioner 57 times as far (outside the limits or far off flat)."""
    g, res = _plan("gcode")
    text = res.artifacts["post.gcode"].decode()
    bad = text.replace("in degrees; X Y Z", "in radians; X Y Z", 1)
    assert bad != text
    rep = run_preflight(g, res.outputs, {**res.artifacts, "post.gcode": bad.encode()})
    assert [p["severity"] for p in _problems(rep)] and rep["verdict"] == "fail"


def test_inform_pulses_per_degree_from_the_main_job():
    """INFORM's station positions are pulses: the main job's `'pulse/deg` turns them into degrees;
    a note of 100 where the controller counts 1000 reads every angle 10 times as large (fail), and
    with no note the angles are unknown: every run unjudged, said in the notes."""
    g, res = _plan("inform")
    name = next(n for n in _program_files(res) if n == "POST.JBI")
    main = res.artifacts[name].decode()
    assert "'pulse/deg 1000 1000" in main
    rep = run_preflight(
        g, res.outputs, {**res.artifacts, name: main.replace("'pulse/deg 1000 1000", "'pulse/deg 100 100").encode()}
    )
    assert rep["verdict"] == "fail" and _problems(rep)
    rep = run_preflight(
        g,
        res.outputs,
        {
            **res.artifacts,
            name: main.replace("'pulse/deg 1000 1000\r\n", "").replace("'pulse/deg 1000 1000\n", "").encode(),
        },
    )
    (prog,) = rep["programs"]
    assert prog["weld_position_unjudged_runs"] == 15 and "weld_position_max_deg" not in prog
    assert any("pulses per degree" in n for n in prog["notes"])


def test_targets_without_angles_are_counted_and_noted():
    """KRL points that state no E1/E2 leave the positioner where it stands: not judged, said so."""
    g, res = _plan("krl")
    dat = re.sub(r",E1 [^,]*,E2 [^,]*,E3 [^,]*,E4 [^,]*,E5 [^,]*,E6 [^}]*", "", res.artifacts["post.dat"].decode())
    assert "E1" not in dat
    rep = run_preflight(g, res.outputs, {**res.artifacts, "post.dat": dat.encode()})
    (prog,) = rep["programs"]
    assert prog["weld_position_unjudged_runs"] == 15 and "weld_position_max_deg" not in prog
    assert any(n.startswith("15 arc-ON runs state no positioner angles") for n in prog["notes"]) and not _problems(rep)


def test_a_program_without_a_cell_is_not_judged():
    """mpp-cross's KRL names no cell: the part's orientation in the world is not known."""
    g = build_graph(apply_overrides(load_recipe(GRAPHS / "mpp-cross.json"), parse_set(["format=krl"])))
    res = execute(g, resolver=FileResolver(GRAPHS), workers=1)
    (prog,) = run_preflight(g, res.outputs, res.artifacts)["programs"]
    assert "weld_position_max_deg" not in prog and "weld_position_unjudged_runs" not in prog
    assert run_preflight(g, res.outputs, res.artifacts)["weld_position_max_deg"] is None


def test_off_skips_the_check():
    from waamflow.preflight.settings import PreflightSettings

    g, res = _plan("krl")
    dat = _edit_e1(res.artifacts["post.dat"].decode(), lambda a, b: (0.0, 0.0))
    arts = {**res.artifacts, "post.dat": dat.encode()}
    g.recipe.preflight = PreflightSettings(weld_position="off")
    try:
        rep = run_preflight(g, res.outputs, arts, g.recipe.preflight)
    finally:
        g.recipe.preflight = None
    assert not _problems(rep)


@pytest.mark.skipif(
    shutil.which("rs274") is None, reason="LinuxCNC's rs274 is not installed (apt-get install linuxcnc-uspace)"
)
def test_rs274_reads_the_same_angles(tmp_path):
    """LinuxCNC's interpreter runs the G-code (A, C as the header maps them: E1 tilt, E2 turn): the
    angles of its welding feeds, layer by layer, are the ones our reader gives each run."""
    g, res = _plan("gcode")
    path = tmp_path / "post.ngc"
    path.write_text(res.artifacts["post.gcode"].decode())
    canon = subprocess.run(["rs274", "-g", str(path)], capture_output=True, text=True, timeout=120, input="")
    assert canon.returncode == 0, canon.stderr
    feeds = [[float(v) for v in m.group(1).split(",")] for m in re.finditer(r"STRAIGHT_FEED\(([^)]*)\)", canon.stdout)]
    ac = [(round(f[3], 3), round(f[5], 3)) for f in feeds]
    distinct = [p for k, p in enumerate(ac) if k == 0 or p != ac[k - 1]]
    ours = [tuple(np.round(r.ext[0][1][:2], 3)) for r in read_program("gcode", _program_files(res)).runs]
    assert len(distinct) == 15 and distinct == ours


def test_a_one_axis_tilter_leaves_the_duct_on_its_side_as_simulate_robot_says():
    """curved-duct on kr150_tilt (one tilt axis about x; the duct's wedges turn about y) with the
    recipe's own gravity policy: no tilt turns a layer leaning in x, and simulate-robot warns that the
    layers stay up to 90° off flat here (6° wedges); the program as written, read back, gives the
    same angle, and the preflight now refuses it where before it passed (a recipe without the
    simulate-robot node had not even warned)."""
    rec = apply_overrides(
        load_recipe(GRAPHS / "curved-duct.json"),
        parse_set(["dtheta_deg=6", "post.cell=kr150_tilt", "sim.cell=kr150_tilt"]),
    )
    g = build_graph(rec)
    res = execute(g, resolver=FileResolver(GRAPHS), cache=CACHE, workers=1)
    (warned,) = [w["message"] for w in res.warnings if "off flat" in w["message"] and w.get("node") == "sim"]
    sim_deg = float(re.search(r"up to (" + NUM + ")° off flat", warned).group(1))
    rep = run_preflight(g, res.outputs, res.artifacts)
    (p,) = _problems(rep)
    assert p["severity"] == "fail" and p["value"] == pytest.approx(sim_deg, abs=0.05) and p["layer"] == 14
    assert "cell kr150_tilt)" in p["message"]


def test_a_helix_is_judged_where_each_state_stands():
    """A layer that is not flat (one run of a helix, 3 turns of pitch 2 mm, r 20 mm) has no one build
    direction; each positioner state is judged at its own point, growing from the turn below it
    (+z on the first, within a layer of the plate): states at the start of each turn with the
    positioner at (0, 0) lie within the helix's slope of flat (atan(2 / (2π · 20)) = 0.9°); a tilt
    of 60° set on the third turn fails at 60°; a run of the same layer floating 50 mm up (no bead
    below within reach) is not judged, counted and said in the notes. Such runs had all been left
    unjudged (counted only)."""
    from waamflow.preflight.position import weld_position_problems
    from waamflow.preflight.read.core import Run
    from waamflow.preflight.report import Report
    from waamflow.preflight.settings import PreflightSettings
    from waamflow.preflight.torch import build_directions
    from waamflow.trajectory.cell import load_cell

    th = np.linspace(0.0, 6 * np.pi, 361)
    pts = np.column_stack([20 * np.cos(th), 20 * np.sin(th), 2.0 * th / (2 * np.pi)])
    n = len(pts) - 1
    cell = load_cell("kr150_tilt_rotate").model_dump_json()

    def check(tilt_third: float):
        states = [(0, np.zeros(2)), (121, np.zeros(2)), (241, np.array([tilt_third, 0.0]))]
        helix = Run(pts, np.full(n, 8.0), np.full(n, 3.0), np.ones(n, bool), 0, "tube", 0, states)
        lone = pts[:40] + [200.0, 0.0, 50.0]
        air = Run(lone, np.full(39, 8.0), np.full(39, 3.0), np.ones(39, bool), 0, "air", 0, [(0, np.zeros(2))])
        out: dict = {}
        rep = Report("post", "krl")
        layers = [(0, [helix, air])]
        weld_position_problems(layers, build_directions(layers, False, 2.0), 2.0, cell, out, rep, PreflightSettings())
        return out, rep

    out, rep = check(0.0)
    assert out["weld_position_max_deg"] == pytest.approx(0.9, abs=0.1) and rep.problems == []
    assert out["weld_position_unjudged_runs"] == 1
    (note,) = out["notes"]
    assert note.startswith("1 positioner state of arc-ON runs on layers that are not flat") and "not judged" in note
    out, rep = check(60.0)
    (p,) = rep.problems
    assert p["check"] == "weld_position" and p["severity"] == "fail" and p["value"] == pytest.approx(60.0, abs=1.0)
    assert p["point"][2] > 4.0  # the third turn's state
