"""Controller-sized, controller-named, traceable program files (issue #23 items 4, 5; item 2's
header claims): RAPID split into modules under a byte limit and loaded by the main module, file
names that are the controller identifiers they hold, the source revision in every header."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from waamflow import __version__
from waamflow.buildinfo import source_revision
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.preflight.read import read_program
from waamflow.program import GcodeSettings, PlanSettings, RapidSettings, plan_program, post_process, write_gcode
from waamflow.program.profiles import profile

from conftest import build_toolpath
from helpers import wall_recipe

IDENT = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
REPO = Path(__file__).resolve().parents[2]
MOTION = re.compile(r"^\s*(MoveL|MoveC|ArcLStart|ArcL|ArcLEnd|ArcC|ArcCEnd|WaitTime)\b.*$", re.M)


def _rapid(limit: int, name: str = "post"):
    return post_process(
        build_toolpath(30), "rapid", PlanSettings(), RapidSettings(program_name=name, max_module_bytes=limit)
    )


def test_rapid_modules_stay_under_the_limit_and_run_in_order():
    whole = _rapid(0)
    assert list(whole.files) == ["mod"]
    size = len(whole.files["mod"].encode())
    limit = 40_000
    assert size > 4 * limit  # the unsplit module is too big
    prog = _rapid(limit)
    names = prog.file_names("post")
    parts = [k for k in prog.files if k != "mod"]
    assert len(parts) == prog.stats["modules"] >= size // limit
    for key, text in prog.files.items():
        assert len(text.encode()) <= limit - 4096  # room left for the trace lines
        stem = names[key].rsplit(".", 1)[0]
        assert IDENT.match(stem) and re.search(rf"^MODULE {stem}\b", text, re.M)
    main = prog.files["mod"]
    calls = re.findall(r'%"(\w+)"%;', main)
    loads = re.findall(r'StartLoad \\Dynamic, \w+ \\File:="(\w+\.mod)", \w+;', main)
    assert calls == [names[k].removesuffix(".mod") for k in parts]
    assert loads == [names[k] for k in parts]
    assert main.count("WaitLoad") == main.count("UnLoad") == len(parts)
    # the part modules, in call order, hold exactly the motions of the unsplit module
    joined = "".join(prog.files[k] for k in parts)
    assert [m.group(0).strip() for m in MOTION.finditer(joined)] == [
        m.group(0).strip() for m in MOTION.finditer(whole.files["mod"])
    ]
    assert not MOTION.search(main)
    # data is LOCAL to each part module (two modules are loaded at once)
    assert all(
        ln.lstrip().startswith("LOCAL ")
        for k in parts
        for ln in prog.files[k].split("\n")
        if re.match(r"\s*(CONST|PERS|VAR) ", ln)
    )
    # the preflight reads the split program back as the whole one
    full = {names[k]: v for k, v in prog.files.items()}
    a, b = (
        read_program("rapid", dict(reversed(list(full.items())))),
        read_program("rapid", {"post.mod": whole.files["mod"]}),
    )
    assert len(a.runs) == len(b.runs) > 30
    assert [r.layer for r in a.runs] == [r.layer for r in b.runs]
    assert all(np.array_equal(x.points, y.points) for x, y in zip(a.runs, b.runs))
    assert a.travel_mm == pytest.approx(b.travel_mm, abs=1e-6) and not a.notes


def test_irc5_profile_limits_modules():
    assert profile("abb_irc5")["post"]["max_module_bytes"] == 512_000


def _run(tmp_path, post_id: str, **post):
    (tmp_path / "wall.json").write_text('{"curves": [[[0, 0], [80, 0], [80, 40]]]}')
    return execute(build_graph(parse_recipe(wall_recipe("names", post_id, **post))), resolver=FileResolver(tmp_path))


@pytest.mark.parametrize(
    "post",
    [
        dict(format="krl"),
        dict(format="krl", split_per_layer=True),
        dict(format="rapid"),
        dict(format="rapid", max_module_bytes=16_384),
    ],
)
def test_hyphenated_node_id_writes_files_named_like_their_program(tmp_path, post):
    res = _run(tmp_path, "duct-post", **post)
    files = sorted(n for n in res.artifacts if n.endswith((".src", ".dat", ".mod")))
    assert files and not any(n.startswith("duct-post") for n in res.artifacts)
    for n in files:
        stem = n.rsplit(".", 1)[0]
        text = res.artifacts[n].decode()
        assert IDENT.match(stem)
        opener = {"src": r"DEF (\w+)\(", "dat": r"DEFDAT (\w+)", "mod": r"MODULE (\w+)"}[n.rsplit(".", 1)[1]]
        assert re.search(opener, text).group(1) == stem  # DEF / DEFDAT / MODULE name == file stem
    main = "duct_post.src" if post["format"] == "krl" else "duct_post.mod"
    assert main in files
    assert not [w for w in res.warnings if "rename" in w["message"] or "file name" in w["message"]]
    assert res.preflight is not None and res.preflight["programs"][0]["files"] == files


def test_valid_node_id_keeps_its_artifact_names(tmp_path):
    assert {"post.src", "post.dat"} <= set(_run(tmp_path, "post", format="krl").artifacts)
    assert "post.mod" in _run(tmp_path, "post", format="rapid").artifacts
    res = _run(tmp_path, "post", format="krl", split_per_layer=True)
    subs = sorted(n for n in res.artifacts if n.startswith("post_L"))
    assert subs and all(
        re.search(r"DEF (\w+)\(", res.artifacts[n].decode()).group(1) == n.rsplit(".", 1)[0]
        for n in subs
        if n.endswith(".src")
    )


def test_headers_carry_version_and_source_revision(tmp_path):
    # the revision is computed once per process: read it again here, so a commit made while the test
    # session runs (HEAD moved) does not fail the comparison
    source_revision.cache_clear()
    rev = subprocess.run(
        ["git", "describe", "--always", "--dirty"], cwd=REPO, capture_output=True, text=True, check=True
    ).stdout.strip()
    assert source_revision() == rev
    for fmt, key in (("gcode", "post.gcode"), ("krl", "post.src"), ("rapid", "post.mod"), ("csv", "post.csv")):
        text = _run(tmp_path, "post", format=fmt).artifacts[key].decode()
        m = re.search(r"waamflow trace: date \S+, waamflow (\S+), revision (\S+), recipe names", text)
        assert m and m.groups() == (__version__, rev)


def test_marlin_positioner_header_makes_no_tcp_claim():
    from waamflow.core.moves import flatten

    moves = flatten(build_toolpath(2))
    plan = plan_program(moves, PlanSettings(arc_plane_normal=(0.0, 0.0, 1.0)))
    ext = np.zeros((len(moves.points), 2))
    marlin = write_gcode(plan, GcodeSettings(external_axes=ext, rotary_axes=("B", "C"), tcp_control=False))
    linuxcnc = write_gcode(plan, GcodeSettings(external_axes=ext))
    assert "tool centre point control on" not in marlin and "no tool centre point control" in marlin
    assert "tool centre point control" in linuxcnc
    assert profile("marlin")["post"]["tcp_control"] is False
