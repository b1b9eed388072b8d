"""Print points read back as compas_slicer means them: point i's `extruder_toggle` is the motion
leaving it (compas_slicer sets a path's points true and its last one false, and draws a bead from
point i to i+1 where point i's toggle is true), and `wait_time` is a wait at the point with the
arc as its toggle says (compas_slicer's `set_wait_time` puts it where the toggle turns true: the
extruder starting). The reader took the toggle as the motion arriving at the point and read no
wait at all: a compas_slicer file read one segment off, and a 50 s wait with the arc on passed."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.preflight.test_preflight import BEAD, SPEED, WFS, box_part, gcode, good_layers
from waamflow.preflight.check import check_program
from waamflow.preflight.read import read_gcode, read_printpoints
from waamflow.preflight.settings import PreflightSettings


def compas_file(layers, wait: float = 0.5, long_wait: tuple[int, float] | None = None, wfs: float = WFS) -> str:
    """`layers` [(z, [run of (x, y)])] as compas_slicer's organizer writes them: one entry per point,
    a path's toggles true but its last, `wait` where the toggle turns true (`long_wait` (layer,
    seconds) there instead on that layer), the wire feed as a key of each point."""
    entries = []
    for li, (z, runs) in enumerate(layers):
        for run in runs:
            for k, (x, y) in enumerate(run):
                w = (long_wait[1] if long_wait and long_wait[0] == li else wait) if k == 0 else 0.0
                entries.append(
                    {
                        "point": [x, y, z],
                        "extruder_toggle": k < len(run) - 1,
                        "velocity": SPEED if k > 0 else 100.0,
                        "wait_time": w,
                        "wire_feed_speed": wfs,
                        "layer": li,
                        "section": "s0",
                    }
                )
    return json.dumps({str(i): e for i, e in enumerate(entries)})


def test_a_compas_slicer_file_reads_as_the_same_program_in_g_code():
    layers = good_layers()
    pp = read_printpoints(compas_file(layers))
    g = read_gcode(gcode(layers))
    assert len(pp.runs) == len(g.runs) == 4
    for a, b in zip(pp.runs, g.runs):
        assert a.layer == b.layer and len(a.points) == len(b.points) == 8
        assert np.allclose(a.points, b.points)
        assert np.allclose(a.speed, SPEED) and np.allclose(a.wfs, WFS)
    assert pp.travel_mm == pytest.approx(g.travel_mm, abs=1e-9)
    # the 0.5 s waits at the runs' first points: arc on, in their runs, as G-code's M3 + G4 P0.5
    assert [d[1] for d in pp.dwells] == [d[1] for d in g.dwells] == [0.5] * 4
    for d, e, run in zip(pp.dwells, g.dwells, pp.runs):
        assert np.allclose(d[0], e[0]) and np.allclose(d[0], run.points[0]) and d[3] is run
    rep = check_program(box_part(), pp, "post", PreflightSettings(), BEAD, weld_expected=True)
    ref = check_program(box_part(), g, "post", PreflightSettings(), BEAD)
    assert rep["verdict"] == ref["verdict"] == "ok", rep["problems"]
    assert rep["dwell_mm3"] == pytest.approx(ref["dwell_mm3"], rel=1e-9) and rep["dwell_mm3"] > 0
    assert rep["wire_part_volume_ratio"] == pytest.approx(ref["wire_part_volume_ratio"], rel=1e-9)


def test_a_long_wait_with_the_extruder_on_fails_as_a_g_code_dwell_does():
    """50 s for 0.5 at layer 2's ignition: the metal of 400 mm of bead on one spot."""
    rep = check_program(
        box_part(),
        read_printpoints(compas_file(good_layers(), long_wait=(2, 50.0))),
        "post",
        PreflightSettings(),
        BEAD,
    )
    (p,) = [p for p in rep["problems"] if p["check"] == "dwell_metal"]
    assert p["severity"] == "fail" and p["layer"] == 2
    assert p["value"] == pytest.approx(50 * SPEED / BEAD, rel=1e-3)
    assert p["point"] == [-19.0, -7.5, 4.5]


def test_a_wait_with_the_extruder_off_lays_nothing():
    """A wait at a path's last point (toggle false: the extruder is off leaving it) is a cooling
    wait, however long."""
    text = json.loads(compas_file(good_layers()))
    last = max(int(k) for k in text)
    text[str(last)]["wait_time"] = 600.0
    prog = read_printpoints(json.dumps(text))
    assert [d[1] for d in prog.dwells] == [0.5] * 4
