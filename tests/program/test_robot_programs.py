"""KRL / RAPID programs end to end: named after their node, parsed by the independent checkers
(krl_check, rapid_check) for every robot machine profile and shipped recipe, moving external
axes on the curved-duct cell, weld data from the zones with warnings, stable trace hashes."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from waamflow.core.moves import flatten
from waamflow.engine.cache import MemoryCache
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.program import PlanSettings, RapidSettings, post_process
from waamflow.program.common import program_identifier, KRL_RESERVED, RAPID_RESERVED
from waamflow.program.profiles import load_profiles

from conftest import build_toolpath
from helpers import wall_recipe
from krl_check import arctech_seams, parse_program
from rapid_check import Module, RapidError, parse_module, values
from rapid_check import parse_program as parse_rapid_program

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def _wall_recipe(post_id: str = "post", **post) -> dict:
    return wall_recipe("robot-wall", post_id, **post)


def _run(tmp_path, recipe, cache=None):
    (tmp_path / "wall.json").write_text(json.dumps({"curves": [[[0, 0], [80, 0], [80, 40]]]}))
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path), cache=cache)


def _text(res, name):
    return res.artifacts[name].decode()


# ---- 1. names --------------------------------------------------------------------------------
def test_identifiers_follow_the_controller_rules():
    assert program_identifier("post", 24, KRL_RESERVED) == "post"
    assert program_identifier("duct-post 2", 24, KRL_RESERVED) == "duct_post_2"
    assert program_identifier("3rd_layer", 24, KRL_RESERVED) == "P_3rd_layer"
    assert program_identifier("end", 24, KRL_RESERVED) == "P_end"  # KRL keyword
    assert program_identifier("main", 32, RAPID_RESERVED) == "P_main"  # the module's PROC
    long = "a_really_long_post_processor_node_id_for_testing"
    assert program_identifier(long, 24) == long[:24] and program_identifier(long, 32) == long[:32]
    assert program_identifier("post_", 24) == "post"  # no trailing '_' left by a cut


@pytest.mark.parametrize(
    "node_id, fmt, name",
    [
        ("post", "krl", "post"),
        ("duct_robot", "krl", "duct_robot"),
        ("duct-robot", "krl", "duct_robot"),  # not duct-robot.src: it could not hold DEF duct-robot
        ("duct-robot", "rapid", "duct_robot"),
    ],
)
def test_program_is_named_after_its_node(tmp_path, node_id, fmt, name):
    res = _run(tmp_path, _wall_recipe(node_id, format=fmt))
    if fmt == "krl":
        src, dat = _text(res, f"{name}.src"), _text(res, f"{name}.dat")  # file name = DEF name
        assert parse_program(src, dat).name == name
        assert f"\nDEF {name}( )\n" in src and dat.startswith(f"DEFDAT {name}\n")
    else:
        assert parse_module(_text(res, f"{name}.mod"), tool="tWeldGun").name == name
    assert not [n for n in res.artifacts if n.startswith(f"{node_id}.")] or node_id == name
    assert not [w for w in res.warnings if "rename" in w["message"]]  # named right: nothing to warn about


def test_renamed_node_is_not_served_from_the_cache(tmp_path):
    cache = MemoryCache()
    a = _run(tmp_path, _wall_recipe("first", format="krl"), cache)
    b = _run(tmp_path, _wall_recipe("second", format="krl"), cache)
    assert "DEF first( )" in _text(a, "first.src") and "DEF second( )" in _text(b, "second.src")
    assert not b.stats["second"].cached and b.stats["walls"].cached
    c = _run(tmp_path, _wall_recipe("second", format="krl"), cache)
    assert c.stats["second"].cached  # same id, same content: cached


def test_split_program_names(tmp_path):
    res = _run(tmp_path, _wall_recipe("wall_robot_program_x", format="krl", split_per_layer=True))
    files = {k: v.decode() for k, v in res.artifacts.items() if k.startswith("wall_robot_progr")}
    main = parse_program(files["wall_robot_progr.src"], files["wall_robot_progr.dat"])  # files named after DEF
    assert main.name == "wall_robot_progr"  # 16 characters: room for _L003_1
    subs = sorted(k for k in files if re.fullmatch(r"wall_robot_progr_L\d{3}\.src", k))
    assert len(subs) == 3 and len(files) == 8
    for k in subs:
        sub = parse_program(files[k], files[k[:-3] + "dat"])
        assert sub.name == k[:-4] and len(sub.name) <= 24
    assert [s.args[0] for s in main.body if s.kind == "call" and s.args[0].startswith("wall")] == [
        f"wall_robot_progr_L00{i}" for i in range(3)
    ]


# ---- 2. RAPID coordinated motion and weld data -------------------------------------------------
def test_rapid_coordinated_work_object_and_extax():
    moves = flatten(build_toolpath())
    n = len(moves.points)
    ext = np.column_stack([np.linspace(0.0, 45.0, n), np.linspace(-10.0, 10.0, n)])
    s = RapidSettings(
        program_name="coord",
        external_axes=ext,
        positioner_unit="STN1",
        work_frame=(0.0, 0.0, 150.0, 1.0, 0.0, 0.0, 0.0),
    )
    prog = post_process(moves, "rapid", PlanSettings(), s)
    mod = parse_module(prog.files["mod"], tool="tWeldGun", units=("STN1",))
    storage, dtype, wobj = mod.data["wobj_STN1"]
    assert (storage, dtype) == ("PERS", "wobjdata")
    robhold, ufprog, ufmec, uframe, oframe = values(wobj)
    assert (robhold, ufprog, ufmec) == (False, False, "STN1") and oframe == [[0.0, 0.0, 150.0], [1.0, 0.0, 0.0, 0.0]]
    body = mod.routines["main"]
    assert [c.name for c in body[:2]] == ["ConfL", "ActUnit"] and body[-1].name == "DeactUnit"
    motions = [c for c in body if c.name.startswith(("Move", "Arc"))]
    assert motions and all(c.options["WObj"] == ("name", "wobj_STN1") for c in motions)
    # every robtarget's extax = the axis values of its point
    targets = {k: values(v[2]) for k, v in mod.data.items() if v[1] == "robtarget"}
    assert len(targets) == n
    for k, t in targets.items():
        i = int(k[1:]) - 1
        assert t[3][:2] == pytest.approx(ext[i], abs=1e-3) and t[3][2:] == [9e9] * 4
        assert t[0] == pytest.approx(moves.points[i], abs=1e-3)
    assert len({round(t[3][0], 3) for t in targets.values()}) == n  # eax_a moves at every point
    # without a mechanical unit: external axes but no coordination
    plain = post_process(moves, "rapid", writer_settings=RapidSettings(external_axes=ext, positioner_unit="")).files[
        "mod"
    ]
    assert "ActUnit" not in plain and "wobjdata" not in parse_module(plain, tool="tWeldGun").data.__repr__()


def test_rapid_welddata_from_zones_and_zero_data_warns():
    moves = flatten(build_toolpath(1))
    prog = post_process(moves, "rapid")
    mod = parse_module(prog.files["mod"], tool="tWeldGun")
    welds = [values(v[2]) for v in mod.data.values() if v[1] == "welddata"]
    assert sorted((w[0], w[2][2], w[2][3], w[2][5]) for w in welds) == [
        (5.0, 21.0, 11.0, 220.0),
        (6.0, 20.0, 10.0, 200.0),
        (7.0, 19.0, 8.5, 180.0),
    ]
    assert prog.weld_issues == ()
    # a zone without parameters and one with a zero voltage: reported, naming zone, section, layer
    from dataclasses import replace

    zp = {"start": {}, "z1": {"current": 200.0, "voltage": 0.0, "wire_feed_speed": 10.0}, "end": {"job": 3}}
    bad = flatten(
        type(build_toolpath(1))(
            tuple(
                type(lp)(lp.layer, tuple(replace(sp, zone_params=zp) for sp in lp.sections)) for lp in build_toolpath(1)
            )
        )
    )
    issues = post_process(bad, "rapid").weld_issues
    assert {(i.zone, i.message) for i in issues} == {
        ("start", "no weld data (current, voltage, wire_feed_speed and job all missing or 0)"),
        ("z1", "voltage 0"),
    }
    assert {i.section for i in issues} == {"bs1/A", "bs1/B", "bs1/C"} and {i.layer for i in issues} == {0}


def test_rapid_checker_catches_broken_modules():
    good = post_process(flatten(build_toolpath(1)), "rapid").files["mod"]
    parse_module(good, tool="tWeldGun")
    broken = {
        "arity": re.sub(r"(ArcL p\d+, vw\d+, sm\d+), wd\d+,", r"\1,", good, count=1),
        "undeclared": re.sub(r"CONST speeddata vw1 := [^\n]*\n", "", good),
        "shape": re.sub(r"(CONST robtarget p1 := \[\[[^\]]*\]),", r"\1,[1,0],", good, count=1),
        "endproc": good.replace("ENDPROC", ""),
        "long name": good.replace("MODULE waamflow", "MODULE " + "m" * 33),
        "type": re.sub(r"(ArcL p\d+, )vw\d+", r"\1sm1", good, count=1),
    }
    for what, text in broken.items():
        with pytest.raises(RapidError):
            parse_module(text, tool="tWeldGun")


# ---- 4. every robot profile, every shipped recipe ------------------------------------------------
ROBOT_PROFILES = sorted(n for n, p in load_profiles().items() if p["post"].get("format") in ("krl", "rapid"))


def _check_program(res, node: str, fmt: str, tool: str = "tWeldGun"):
    """Parse every program file of `node` (named as `Program.file_names` says); returns the parsed
    main program, for RAPID the modules merged (data and routines of the main and part modules)."""
    prog = res.outputs[node]["program"]
    names = prog.file_names(node)
    if fmt == "rapid":
        mods = parse_rapid_program({names[k]: _text(res, names[k]) for k in prog.files}, tool=tool, units=("STN1",))
        merged = Module(mods[0].name)
        for m in mods:
            merged.data.update(m.data)
            merged.routines.update(m.routines)
        return merged
    arts = {k: _text(res, names[k]) for k in prog.files}
    for k in arts:
        if k.endswith("src"):
            parse_program(arts[k], arts[k[:-3] + "dat"])
    return parse_program(arts["src"], arts["dat"])


@pytest.mark.parametrize("profile", ROBOT_PROFILES)
def test_every_robot_profile_parses(tmp_path, profile):
    assert {"kuka_krc4", "kuka_krc4_io", "abb_irc5"} <= set(ROBOT_PROFILES)
    res = _run(tmp_path, _wall_recipe(profile=profile, cell="kr150_tilt_rotate", positioner_policy="fixed"))
    fmt = load_profiles()[profile]["post"]["format"]
    prog = _check_program(res, "post", fmt)
    assert prog.name == "post"
    if fmt == "krl":
        e6 = prog.e6pos()
        targets = {t for m in prog.motions() for t in m.args[:-1] if not t.startswith("$")}
        assert set(e6) == targets and len(e6) > 10
        assert {(p["E1"], p["E2"]) for p in e6.values()} == {(0.0, 0.0)}  # `fixed` positioner at 0°
        seams = arctech_seams(prog)
        if load_profiles()[profile]["post"].get("arc_control") == "arctech":
            assert len(seams) == 3  # one seam per layer of the wall
        else:
            assert not seams and sum(s.kind == "assign" and s.args[0] == "$OUT" for s in prog.body) == 3
    else:
        assert len(prog.calls("ArcLStart")) == len(prog.calls("ArcLEnd")) == 3
        assert prog.calls("ActUnit")[0].args == [("name", "STN1")]


def _shipped_robot_programs():
    """(recipe, format) for every shipped recipe with a post-process node that writes KRL/RAPID
    as shipped or through a `$format` input."""
    out = []
    for path in sorted(GRAPHS.glob("*.json")):
        recipe = json.loads(path.read_text())
        for node in recipe.get("nodes", []):
            if node.get("type") != "post-process":
                continue
            fmt = node.get("params", {}).get("format", "gcode")
            if fmt in ("krl", "rapid"):
                out.append((path.stem, fmt))
            elif fmt == "$format":
                out += [(path.stem, "krl"), (path.stem, "rapid")]
    return sorted(set(out))


SHIPPED = _shipped_robot_programs()
SLOW = {"bracket"}  # 15-25 s a run: parsed in `make bench`-sized runs only, see README


@pytest.mark.parametrize("recipe_name, fmt", [s for s in SHIPPED if s[0] not in SLOW and s[0] != "curved-duct"])
def test_shipped_recipes_parse(recipe_name, fmt):
    recipe = json.loads((GRAPHS / f"{recipe_name}.json").read_text())
    recipe.setdefault("inputs", {})["format"] = fmt
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(GRAPHS))
    posts = [n["id"] for n in recipe["nodes"] if n["type"] == "post-process"]
    for node in posts:
        prog = _check_program(res, node, fmt)
        assert prog.name == node
        n_motion = (
            len(prog.motions())
            if fmt == "krl"
            else len(prog.calls("MoveL", "MoveC", "ArcL", "ArcC", "ArcLStart", "ArcLEnd", "ArcCEnd"))
        )
        assert n_motion > 50


@pytest.fixture(scope="module")
def duct():
    """curved-duct as shipped (KRL, output arc control, kr150 cell) and as RAPID with the ABB
    profile on the irb4600 cell (without the simulation node, which the curved tests cover)."""
    shipped = json.loads((GRAPHS / "curved-duct.json").read_text())
    rapid = json.loads((GRAPHS / "curved-duct.json").read_text())
    post = next(n for n in rapid["nodes"] if n["id"] == "post")
    post["params"] = {**post["params"], "format": "rapid", "profile": "abb_irc5", "cell": "irb4600_tilt_rotate"}
    rapid["nodes"] = [n for n in rapid["nodes"] if n["id"] != "sim"]
    rapid["edges"] = [e for e in rapid["edges"] if not e["to"].startswith("sim.")]
    for r in (shipped, rapid):
        r["nodes"] = [n for n in r["nodes"] if n["id"] != "sim"]
        r["edges"] = [e for e in r["edges"] if not e["to"].startswith("sim.")]
    return [execute(build_graph(parse_recipe(r)), resolver=FileResolver(GRAPHS)) for r in (shipped, rapid)]


def test_duct_krl_parses_with_moving_external_axes(duct):
    assert ("curved-duct", "krl") in SHIPPED
    prog = _check_program(duct[0], "post", "krl")
    e6 = prog.e6pos()
    assert len(e6) == 6787  # the duct's 5 mm wall: its centre-line laps (3 mm wall: 6438)
    e1 = np.array([p["E1"] for p in e6.values()])
    assert len(np.unique(np.round(e1, 2))) == 58 and np.ptp(e1) > 85  # E1 (tilt) moves layer by layer
    # the tilt follows the deposition order: non-decreasing along the motion sequence
    seq = [e6[m.args[0]]["E1"] for m in prog.motions() if m.args[0] in e6]
    assert np.all(np.diff(seq) >= -1e-9)
    assert any(s.kind == "if" for s in prog.body) and any(s.kind == "halt" for s in prog.body)  # $EX_AX_NUM check


def test_duct_rapid_parses_with_coordinated_extax(duct):
    mod = _check_program(duct[1], "post", "rapid")
    targets = [values(v[2]) for v in mod.data.values() if v[1] == "robtarget"]
    eax_a = np.array([t[3][0] for t in targets])
    assert len(targets) > 6000 and len(np.unique(np.round(eax_a, 2))) == 58 and np.ptp(eax_a) > 85
    assert values(mod.data["wobj_STN1"][2])[:3] == [False, False, "STN1"]
    assert len(mod.calls("ArcLStart")) == len(mod.calls("ArcLEnd")) == 58
    assert len(mod.calls("ActUnit")) == len(mod.calls("DeactUnit")) == 1
    # issue 23: the bead model holds at 8.1 m/min and now puts that wire feed in every zone, so the
    # welddata carry it (before: all zero, reported as "no weld data")
    assert not [w for w in duct[1].warnings if "welddata" in w["message"]]
    welds = [values(v[2]) for v in mod.data.values() if v[1] == "welddata"]
    assert welds and {w[2][3] for w in welds} == {8.1}


# ---- 5. traceable headers: re-running gives the same hashes ---------------------------------------
@pytest.mark.parametrize("fmt, files", [("krl", ("post.src", "post.dat")), ("rapid", ("post.mod",))])
def test_rerun_gives_identical_trace_and_program(tmp_path, monkeypatch, fmt, files):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")
    runs = [_run(tmp_path, _wall_recipe(format=fmt)) for _ in range(2)]  # no cache: computed twice
    for name in files:
        a, b = (_text(r, name) for r in runs)
        trace = re.findall(r"waamflow trace: (.*)", a)
        assert len(trace) == 3 and trace == re.findall(r"waamflow trace: (.*)", b)
        assert "recipe robot-wall" in trace[0] and "waamflow 0." in trace[0] and "2026-01-01T00:00:00Z" in trace[0]
        assert re.fullmatch(r"recipe sha256 [0-9a-f]{64}", trace[1]) and re.fullmatch(
            r"input wall\.json sha256 [0-9a-f]{64}", trace[2]
        )
        assert a == b  # byte-identical programs
