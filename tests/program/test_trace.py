"""Traceable programs: every program header and summary.json carry date, version, recipe name,
the recipe's sha256 and each input file's sha256; hashes are stable across runs and follow the
input file; the date never enters a cache key."""

import hashlib
import json
import re

import pytest

from waamflow.engine.cache import MemoryCache
from waamflow.engine.executor import FileResolver, execute, recipe_sha256
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe

from helpers import wall_recipe


def _recipe(fmt: str) -> dict:
    return wall_recipe("trace-wall", format=fmt)


def _write_wall(tmp_path, length: float) -> bytes:
    data = json.dumps({"curves": [[[0, 0], [length, 0], [length, 40]]]}).encode()
    (tmp_path / "wall.json").write_bytes(data)
    return data


def _trace_from(text: str) -> dict:
    head = re.search(r"waamflow trace: date (\S+), waamflow (\S+), revision \S+, recipe (\S+)", text)
    rsha = re.search(r"waamflow trace: recipe sha256 ([0-9a-f]{64})", text)
    inputs = dict(re.findall(r"waamflow trace: input (\S+) sha256 ([0-9a-f]{64})", text))
    return {
        "date": head.group(1),
        "version": head.group(2),
        "recipe": head.group(3),
        "recipe_sha256": rsha.group(1),
        "inputs": inputs,
    }


def test_hashes_stable_across_runs_and_follow_the_input(tmp_path):
    data = _write_wall(tmp_path, 80.0)
    recipe = parse_recipe(_recipe("gcode"))
    cache = MemoryCache()
    r1 = execute(build_graph(recipe), resolver=FileResolver(tmp_path), cache=cache)
    r2 = execute(build_graph(recipe), resolver=FileResolver(tmp_path), cache=cache)
    assert r2.stats["post"].cached  # the date did not break the cache
    t1, t2 = (_trace_from(r.artifacts["post.gcode"].decode()) for r in (r1, r2))
    assert t1["recipe"] == "trace-wall"
    assert t1["recipe_sha256"] == t2["recipe_sha256"] == recipe_sha256(recipe)
    assert t1["inputs"] == t2["inputs"] == {"wall.json": hashlib.sha256(data).hexdigest()}
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", t1["date"])
    s = r1.summary("trace-wall")["trace"]
    assert s["recipe_sha256"] == t1["recipe_sha256"] and s["inputs"] == t1["inputs"] and s["date"] == t1["date"]
    assert s["waamflow"] == t1["version"]
    # key order of the recipe does not matter; a changed param does
    shuffled = _recipe("gcode")
    shuffled["nodes"] = [dict(reversed(list(n.items()))) for n in shuffled["nodes"]]
    assert recipe_sha256(parse_recipe(shuffled)) == t1["recipe_sha256"]
    changed = _recipe("gcode")
    changed["nodes"][1]["params"]["layer_height"] = 1.5
    assert recipe_sha256(parse_recipe(changed)) != t1["recipe_sha256"]
    # a changed input file changes its hash
    data2 = _write_wall(tmp_path, 90.0)
    r3 = execute(build_graph(recipe), resolver=FileResolver(tmp_path), cache=cache)
    t3 = _trace_from(r3.artifacts["post.gcode"].decode())
    assert t3["inputs"] == {"wall.json": hashlib.sha256(data2).hexdigest()} != t1["inputs"]
    assert t3["recipe_sha256"] == t1["recipe_sha256"]


def test_source_date_epoch_fixes_the_date(tmp_path, monkeypatch):
    _write_wall(tmp_path, 80.0)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")
    res = execute(build_graph(parse_recipe(_recipe("gcode"))), resolver=FileResolver(tmp_path))
    assert _trace_from(res.artifacts["post.gcode"].decode())["date"] == "2026-01-01T00:00:00Z"
    assert res.summary("x")["trace"]["date"] == "2026-01-01T00:00:00Z"


@pytest.mark.parametrize(
    "fmt, suffix, mark", [("krl", "src", ";"), ("krl", "dat", ";"), ("rapid", "mod", "!"), ("csv", "csv", "#")]
)
def test_every_format_carries_the_trace(tmp_path, fmt, suffix, mark):
    _write_wall(tmp_path, 80.0)
    res = execute(build_graph(parse_recipe(_recipe(fmt))), resolver=FileResolver(tmp_path))
    text = res.artifacts[f"post.{suffix}"].decode()
    t = _trace_from(text)
    assert t["recipe"] == "trace-wall" and "wall.json" in t["inputs"]
    lines = [ln.strip() for ln in text.split("\n") if "waamflow trace:" in ln]
    assert len(lines) == 3 and all(ln.startswith(mark) for ln in lines)
    first = text.split("\n")
    if fmt == "krl":
        i = next(i for i, ln in enumerate(first) if "waamflow trace" in ln)
        assert first[i - 1].startswith("DEF")  # inside the program, after DEF/DEFDAT
    if fmt == "rapid":
        i = next(i for i, ln in enumerate(first) if "waamflow trace" in ln)
        assert first[i - 1].startswith("MODULE")
