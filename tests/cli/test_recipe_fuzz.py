"""Every shipped recipe with one parameter at a time set to a value a user (or a script) might
give: 0, -1, 1e6, '', 'bogus', [], the other boolean. A recipe is a program, so schema checks alone
(tests/api/test_contract.py) do not reach this: the run must end as the CLI contract says — done
(0), bad input naming the node and field (2), a planning error (3) or a preflight that fails the
program (4) — never a traceback, never the preflight failing itself, never a kernel's exception
passed on by its class name ('ZeroDivisionError: float division by zero' said nothing a user could
act on). Found this way, and fixed: arc_on 'bogus' (the preflight failed itself on 'OGUS'), a
fan axis through the part (ZeroDivisionError), a bead model of negative height ('ValueError:
need 0 < H_min < H_max'), a 5,000-character file name (OSError with the server's folder).

Bounded for `make test` (~30 s): a number gets one of the three values (by its position, so each is
used across the recipe), a string both, a list []; bracket and bead-trials every third number only, and
curved-bracket (~5 s a run) not at all.
WAAMFLOW_FUZZ_ALL=1 gives every parameter every value (a few minutes)."""

from __future__ import annotations

import contextlib
import copy
import io
import json
import os
import re
import shutil
from pathlib import Path

import pytest

from waamflow.cli import main

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"
ALL = os.environ.get("WAAMFLOW_FUZZ_ALL") == "1"
# curved-bracket's runs take ~5 s each: only with ALL (curved-duct covers its node types, bounded)
RECIPES = sorted(
    p.stem for p in GRAPHS.glob("*.json") if not p.stem.startswith("_") and (ALL or p.stem != "curved-bracket")
)
VALUES = {
    "number": [0, -1, 1e6],
    "str": ["", "bogus"],
    "list": [[]],
}
RAW_EXCEPTION = re.compile(r"\b(ZeroDivision|Type|Value|Index|Key|Attribute|OS|Runtime|Assertion|Name)Error\b")
SLOW = {"curved-bracket", "bead-trials", "bracket"}  # runs of 1-5 s: every third number, no strings, unless ALL


def _leaves(obj, path=()):
    """(path, value) of every parameter leaf (numbers, strings, booleans) and list (whole, and its
    first three items: a point's coordinates too)."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _leaves(v, path + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj[:3]):
            yield from _leaves(v, path + (i,))
        yield path, obj
    else:
        yield path, obj


def _variants(recipe: dict, slow: bool):
    k = 0
    for ni, node in enumerate(recipe["nodes"]):
        for path, v in _leaves(node.get("params", {})):
            if isinstance(v, bool):
                vals = [not v]
            elif isinstance(v, (int, float)):
                vals = VALUES["number"]
            elif isinstance(v, str):
                vals = [] if slow and not ALL else VALUES["str"]
            elif isinstance(v, list):
                vals = [] if slow and not ALL else VALUES["list"]
            else:
                continue
            if not ALL and isinstance(v, (int, float)) and not isinstance(v, bool):
                if slow and k % 3:  # a slow recipe: every third number
                    vals = []
                vals = vals and [vals[k % len(vals)]]
                k += 1
            for val in vals:
                yield ni, path, val


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A copy of graphs/ (the recipes' parts, trials and parameter files beside the mutants)."""
    root = tmp_path_factory.mktemp("fuzz")
    shutil.copytree(GRAPHS, root / "graphs")
    return root


@pytest.mark.slow
@pytest.mark.parametrize("name", RECIPES)
def test_one_odd_parameter_ends_a_run_as_the_contract_says(name, folder, monkeypatch):
    monkeypatch.setenv("WAAMFLOW_CACHE", str(folder / "cache"))
    recipe = json.loads((GRAPHS / f"{name}.json").read_text())
    path = folder / "graphs" / f"_fuzz_{name}.json"
    seen, bad = {0: 0, 2: 0, 3: 0, 4: 0}, []
    for ni, keys, val in _variants(recipe, name in SLOW):
        mutant = copy.deepcopy(recipe)
        where = mutant["nodes"][ni]["params"]
        for key in keys[:-1]:
            where = where[key]
        where[keys[-1]] = val
        path.write_text(json.dumps(mutant))
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                rc = main(["run", str(path), "--no-cache", "--out", str(folder / "out")])
            except SystemExit as exit_:
                rc = exit_.code
        text = err.getvalue()
        label = f"{mutant['nodes'][ni]['id']}.{'.'.join(map(str, keys))}={val!r}: rc {rc}: {text.strip()[-300:]}"
        if rc not in seen or "Traceback" in text or "itself failed" in text or RAW_EXCEPTION.search(text):
            bad.append(label)
        elif rc in seen:
            seen[rc] += 1
    assert not bad, "\n".join(bad)
    assert sum(seen.values()) >= 5 and seen[2] >= 1  # the variants ran, and some were refused as input


XML_VALUES = ["-1", "0", "1e9", "x", "nan", "inf", "1e-9", "2,5", " 3 "]
XML_PARAMS = ["current", "voltage", "wire_feed_speed", "travel_speed", "dwell", "job"]


@pytest.mark.slow
def test_one_odd_zone_parameter_in_the_xml_ends_a_run_as_the_contract_says(folder, monkeypatch):
    """mpp-cross's zone-parameter file with one value of zone z1 (layer 0, section bs1/A) at a time set
    to an odd text: refused naming the file line, layer, section and zone (2), or planned; a wire feed
    the arc burns without (0, 1e-9 m/min) is the preflight's `wire_feed` failure (4): it passed as
    'ok' before (the layer's metal 0.77, the part's 0.94 of their volumes)."""
    monkeypatch.setenv("WAAMFLOW_CACHE", str(folder / "cache"))
    xml = folder / "graphs" / "mpp-cross.params.xml"
    original = xml.read_text()
    rcs, bad = {}, []
    try:
        for name in XML_PARAMS:
            for val in XML_VALUES:
                pat = re.compile(rf'(<zone id="z1"[^>]*>.*?<{name} unit="[^"]*">)([^<]*)(</{name}>)', re.S)
                xml.write_text(pat.sub(lambda m: m.group(1) + val + m.group(3), original, count=1))
                err = io.StringIO()
                with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                    try:
                        rc = main(
                            [
                                "run",
                                str(folder / "graphs" / "mpp-cross.json"),
                                "--no-cache",
                                "--out",
                                str(folder / "xo"),
                            ]
                        )
                    except SystemExit as exit_:
                        rc = exit_.code
                text = err.getvalue()
                rcs[(name, val)] = rc
                if rc not in (0, 2, 3, 4) or "Traceback" in text or RAW_EXCEPTION.search(text):
                    bad.append(f"{name}={val!r}: rc {rc}: {text.strip()[-300:]}")
                elif rc == 2 and not re.search(r"layer 0, section 'bs1/A', field '\w+': parameter file line \d+", text):
                    bad.append(
                        f"{name}={val!r}: refused without the file line, layer and section: {text.strip()[-300:]}"
                    )
    finally:
        xml.write_text(original)
    assert not bad, "\n".join(bad)
    assert rcs[("wire_feed_speed", "0")] == rcs[("wire_feed_speed", "1e-9")] == 4
    assert rcs[("travel_speed", "0")] == 2 and rcs[("current", "nan")] == 2 and rcs[("dwell", " 3 ")] == 0
    assert sum(rc == 2 for rc in rcs.values()) >= 35
