"""The G-code reader honours the modes a controller does: units (G20 inches / G21 mm), distance
(G91 incremental / G90 absolute), the G92 coordinate offset, and the program's end (M2/M30: nothing
after it runs). A machine profile's `start_code`, `layer_code` or `end_code` may hold any of them,
and the reader ignored all four: a program in inches (every move 25.4× as far), an incremental
one, one whose layer 2 is offset 5 mm by a G92, and one that ends after layer 1 all read back as the
planned part and passed "ok". LinuxCNC's rs274 reads each the same way (`test_rs274_agrees`)."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from tests.preflight.test_preflight import BEAD, box_part, gcode, good_layers
from waamflow.preflight.check import check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings


def _check(text: str) -> dict:
    return check_program(box_part(), read_gcode(text), "post", PreflightSettings(), BEAD)


def _fails(rep: dict) -> set[str]:
    return {p["check"] for p in rep["problems"] if p["severity"] == "fail"}


GOOD = gcode(good_layers())
MUTANTS = {
    "inches": GOOD.replace("G21", "G20"),
    "incremental": GOOD.replace("G90", "G91"),
    "offset layer 2": GOOD.replace("; layer 2", "G92 X-5 Y0\n; layer 2"),
    "ends after layer 1": GOOD.replace("; layer 2", "M30\n; layer 2"),
}


def test_the_right_program_still_passes_and_reads_the_same():
    assert _check(GOOD)["verdict"] == "ok"
    fast = read_gcode(GOOD)
    assert len(fast.runs) == 4 and fast.runs[0].points[0].tolist() == [-19.0, -7.5, 1.5]


@pytest.mark.parametrize("name", sorted(MUTANTS))
def test_each_mode_is_honoured_and_the_program_fails(name):
    rep = _check(MUTANTS[name])
    assert rep["verdict"] == "fail", (name, rep["problems"])


def test_the_modes_move_the_points_as_a_controller_does():
    inch = read_gcode(MUTANTS["inches"])
    assert inch.runs[0].points[0].tolist() == pytest.approx([-19.0 * 25.4, -7.5 * 25.4, 1.5 * 25.4])
    assert inch.runs[0].speed[0] == pytest.approx(8.0 * 25.4)  # F480 in/min
    off = read_gcode(MUTANTS["offset layer 2"])
    # G92 X-5 Y0 where the torch stands (layer 1's last point): from there on x reads 5 mm short of
    # it and y 0 at it, so layer 2's first point (x -19, y -7.5 as written) lands that much further on
    stop = off.runs[1].points[-1]
    assert off.runs[2].points[0][:2] == pytest.approx([-19.0 + stop[0] + 5.0, -7.5 + stop[1]])
    assert len(read_gcode(MUTANTS["ends after layer 1"]).runs) == 2
    inc = read_gcode(MUTANTS["incremental"])
    assert inc.runs[0].points[1][0] == pytest.approx(-19.0 + 19.0)  # X19 from x -19: to 0


RS274 = shutil.which("rs274")
FEED = re.compile(r"STRAIGHT_FEED\(([-\d.]+), ([-\d.]+), ([-\d.]+)")
G92 = re.compile(r"SET_G92_OFFSET\(([-\d.]+), ([-\d.]+), ([-\d.]+)")


@pytest.mark.skipif(RS274 is None, reason="LinuxCNC's rs274 is not installed (.ci/run installs it)")
@pytest.mark.parametrize("name", ["inches", "incremental", "offset layer 2", "ends after layer 1"])
def test_rs274_agrees(name, tmp_path):
    """The feed moves' end points as LinuxCNC's interpreter computes them equal the points the
    reader gives (its canonical calls are in the program's units, the G92 offset apart)."""
    text = re.sub(r"^M67 .*$|^M3$|^M5$", "", MUTANTS[name], flags=re.M)  # analog outputs and spindle: not motion
    (tmp_path / "p.ngc").write_text(text + "\n")
    out = subprocess.run(
        [RS274, "-g", str(tmp_path / "p.ngc")], stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60
    )
    # canonical calls are in the program's units and frame: mm, and the G92 offset added, as a machine moves
    scale, offset, pts = 1.0, np.zeros(3), []
    for line in out.stdout.splitlines():
        if "USE_LENGTH_UNITS" in line:
            scale = 25.4 if "INCHES" in line else 1.0
        elif m := G92.search(line):
            offset = np.array([float(v) for v in m.groups()])
        elif m := FEED.search(line):
            pts.append((np.array([float(v) for v in m.groups()]) + offset) * scale)
    theirs = np.array(pts)
    ours = np.concatenate([r.points[1:] for r in read_gcode(MUTANTS[name]).runs])
    assert len(theirs) == len(ours) and np.allclose(theirs, ours, atol=2e-3), (name, out.stdout[-500:])
