"""The deposit's bottom against the part's and against the plate (z = 0 of the program's frame):
a program that starts layers above the part's bottom lays its first bead on nothing, and one that
goes below z = 0 drives the torch into the substrate. Both passed the preflight before (a tube
sliced from z_min 4.5: first bead at z 6.0, 4.5 mm of the part never built, verdict "warn"; a part
centred on the origin: beads at z -13.5)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from tests.preflight.test_preflight import BEAD, LAYER, box_part, gcode, good_layers
from tests.wall_recipe import wall_recipe

from waamflow.preflight.check import Part, check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings


def _check(layers, part: Part | None = None, **kw):
    return check_program(part or box_part(), read_gcode(gcode(layers)), "post", PreflightSettings(**kw), BEAD)


def _problems(rep, check):
    return [p for p in rep["problems"] if p["check"] == check]


def _shifted_box(dz: float) -> Part:
    p = box_part()
    return Part("solid", "part", vertices=p.vertices + (0, 0, dz), faces=p.faces)


def test_a_program_built_from_the_parts_bottom_has_no_bottom_or_plate_problem():
    rep = _check(good_layers())
    assert not _problems(rep, "bottom_gap") and not _problems(rep, "plate")
    assert rep["bottom_gap_mm"] == pytest.approx(0.0, abs=1e-6)
    assert rep["deposit_bottom_mm"] == pytest.approx(LAYER)


def test_layers_missing_at_the_bottom_fail_with_the_first_layer_and_the_gap():
    # the 6 mm box: layers 3 and 4 only (z 4.5, 6.0) — the first bead lies 3 mm above the part's bottom
    rep = _check(good_layers()[2:])
    (p,) = _problems(rep, "bottom_gap")
    assert p["severity"] == "fail" and p["layer"] == 0 and p["section"] == "s0"
    assert p["value"] == pytest.approx(3.0, abs=1e-6) and p["limit"] == pytest.approx(0.5 * LAYER)
    assert "3.00 mm above the part's bottom" in p["message"] and "z_min" in p["message"]
    assert rep["bottom_gap_mm"] == pytest.approx(3.0, abs=1e-6) and rep["verdict"] == "fail"
    # one layer and a half of slack set in the settings: passes
    assert not _problems(_check(good_layers()[2:], bottom_gap_max_layers=2.5), "bottom_gap")


def test_a_program_below_the_plate_fails_and_says_where_the_part_reaches():
    down = [(z - 3.0, runs) for z, runs in good_layers()]  # the box 3 mm into the plate
    rep = _check(down, _shifted_box(-3.0))
    assert not _problems(rep, "bottom_gap")  # the program follows the part
    (p,) = _problems(rep, "plate")
    assert p["severity"] == "fail" and p["layer"] == 0 and p["value"] == pytest.approx(-1.5)
    assert "below the plate" in p["message"] and "z = -3.000 mm" in p["message"] and "on_plate" in p["message"]
    assert p["point"][2] == pytest.approx(-1.5)
    assert _problems(_check(down, _shifted_box(-3.0), plate="warn"), "plate")[0]["severity"] == "warn"
    assert not _problems(_check(down, _shifted_box(-3.0), plate="off"), "plate")


def test_a_travel_below_the_plate_fails_too():
    text = gcode(good_layers()).replace("G21\nG90", "G21\nG90\nG0 X0 Y0 Z-2.000")
    rep = check_program(box_part(), read_gcode(text), "post", PreflightSettings(), BEAD)
    (p,) = _problems(rep, "plate")
    assert p["value"] == pytest.approx(-2.0) and "travel" in p["message"]


def test_a_part_floating_above_the_plate_fails_with_its_height():
    up = [(z + 100.0, runs) for z, runs in good_layers()]
    rep = _check(up, _shifted_box(100.0))
    assert not _problems(rep, "bottom_gap")
    (p,) = _problems(rep, "plate")
    assert p["severity"] == "fail" and p["value"] == pytest.approx(100.0)
    assert "100.00 mm above the plate" in p["message"] and "on_plate" in p["message"]
    # 0.5 mm up (less than half a layer): the plate's own tolerance
    near = [(z + 0.5, runs) for z, runs in good_layers()]
    assert not _problems(_check(near, _shifted_box(0.5)), "plate")


def test_the_cli_refuses_a_tube_sliced_from_z_min_and_a_tube_centred_on_the_origin(tmp_path):
    tube = trimesh.creation.annulus(r_min=37, r_max=43, height=30, sections=64)
    tube.export(tmp_path / "centred.stl")  # z -15 .. 15
    tube.apply_translation((0, 0, 15))
    tube.export(tmp_path / "tube.stl")
    recipe = wall_recipe("tube.stl")
    (tmp_path / "tube.json").write_text(json.dumps(recipe))

    def run(*extra: str) -> tuple[int, str, dict]:
        out = tmp_path / f"out{len(list(tmp_path.iterdir()))}"
        cmd = [
            sys.executable,
            "-m",
            "waamflow.cli",
            "run",
            str(tmp_path / "tube.json"),
            "--no-cache",
            "--out",
            str(out),
        ]
        r = subprocess.run([*cmd, "--workers", "1", *extra], capture_output=True, text=True, timeout=120)
        return r.returncode, r.stderr, json.loads((Path(out) / "preflight.json").read_text())

    rc, err, pf = run()
    assert rc == 0 and pf["verdict"] in ("ok", "warn") and pf["bottom_gap_mm"] == pytest.approx(0.0, abs=1e-3)
    rc, err, pf = run("--set", "layers.z_min=4.5")
    assert rc == 4 and "preflight failed (bottom_gap)" in err and "layer 0" in err
    assert pf["bottom_gap_mm"] == pytest.approx(4.5, abs=1e-3)
    rc, err, pf = run("--set", "part.path=centred.stl")
    assert rc == 4 and "preflight failed (plate)" in err and "on_plate" in err
    rc, err, pf = run("--set", "part.path=centred.stl", "--set", "part.placement=on_plate")
    assert rc == 0 and not [p for p in pf["problems"] if p["check"] in ("plate", "bottom_gap")]
    assert np.isclose(pf["programs"][0]["deposit_bottom_mm"], 1.5)
