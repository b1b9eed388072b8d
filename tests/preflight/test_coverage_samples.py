"""The 3D coverage check samples a large part on a coarser grid, and says so.

A thin-wall part read from a DXF in the wrong units (ezdxf's wipeout_door.dxf: 93 × 78 m of walls,
30 mm tall) was sampled every 1 mm: 28.5 million samples, minutes in the preflight, where a mesh
part's samples were held to MAX_SAMPLES. A midsurface's grid now has at most MAX_GRID_SAMPLES, and
preflight.json states the spacing used (`coverage_sample_mm`) beside the one asked
(`coverage_sample_asked_mm`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from waamflow.preflight.check import Part, check_program
from waamflow.preflight.samples import MAX_GRID_SAMPLES
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings

WIDTH, LAYER, SPEED = 4.0, 2.0, 5.0


def walls(n: int, length: float, spacing: float = 50.0) -> tuple:
    return tuple(np.array([(0.0, k * spacing), (length, k * spacing)]) for k in range(n))


def program(curves, height: float, skip: frozenset = frozenset()) -> str:
    """One bead a layer along each wall but the `skip`ped ones, layers every LAYER mm to `height`."""
    out = [
        "; waamflow-post: arc_on=M3 arc_off=M5 dwell_units=s feed_units=mm/min end=M30",
        '; waamflow-weld: wire_feed_speed[m/min]="M67 E0 Q{value:.2f}"',
        "G21",
        "G90",
    ]
    for i, z in enumerate(np.arange(LAYER, height + 1e-9, LAYER)):
        out.append(f"; layer {i} z={z:.3f}")
        for j, c in enumerate(curves):
            if j in skip:
                continue
            a, b = (c[0], c[-1]) if (i + j) % 2 == 0 else (c[-1], c[0])  # ends alternate: no stacked starts
            out += [f"; section w{j}", f"G0 X{a[0]:.3f} Y{a[1]:.3f} Z{z:.3f}", "M67 E0 Q2.00", "M3"]
            out += [f"G1 X{b[0]:.3f} Y{b[1]:.3f} Z{z:.3f} F{SPEED * 60:.0f}", "M5"]
    out.append("M30")
    return "\n".join(out)


def check(n: int, length: float, height: float, skip: frozenset, **settings) -> dict:
    curves = walls(n, length)
    part = Part("midsurface", "sketch", curves=curves, z0=0.0, height=height)
    s = PreflightSettings(weld_data="off", **settings)
    return check_program(part, read_gcode(program(curves, height, skip)), "post", s, WIDTH)


def samples(rep: dict) -> int:
    return sum(L.get("samples", 0) for L in rep["layers"])


def test_a_large_midsurface_is_sampled_at_most_max_samples_and_the_spacing_is_stated():
    """12 walls of 5 m × 40 mm (2.4 m²): every 1 mm (a quarter of the 4 mm bead) that is 2.4 million
    samples; held to MAX_GRID_SAMPLES, the spacing is √(2.4 m² / 1,000,000) = 1.55 mm. One wall
    never built is still 1/12 of the part uncovered."""
    rep = check(12, 5000.0, 40.0, frozenset([5]))
    area = 12 * 5000.0 * 40.0
    assert rep["coverage_method"] == "3D samples"
    assert rep["coverage_sample_mm"] == pytest.approx(math.sqrt(area / MAX_GRID_SAMPLES), abs=1e-3)
    assert rep["coverage_sample_asked_mm"] == pytest.approx(WIDTH / 4)  # what the GUI compares it with
    assert 0.95 * MAX_GRID_SAMPLES <= samples(rep) <= 1.01 * MAX_GRID_SAMPLES
    assert rep["uncovered_share"] == pytest.approx(1 / 12, abs=0.005)
    assert rep["part_volume_mm3"] == pytest.approx(area * WIDTH, rel=1e-9)
    (unc,) = [p for p in rep["problems"] if p["check"] == "uncovered"]
    assert unc["severity"] == "fail"


def test_a_small_midsurface_keeps_its_spacing_and_an_explicit_one_is_coarsened_too():
    """Under the cap, the spacing is the quarter bead (1 mm) or the one the settings give; a given
    spacing that would need more samples than MAX_GRID_SAMPLES is coarsened as the default is."""
    small = check(3, 200.0, 20.0, frozenset())
    assert small["coverage_sample_mm"] == small["coverage_sample_asked_mm"] == pytest.approx(1.0)
    assert samples(small) == 3 * 201 * 20  # 201 points along each 200 mm wall, 20 heights
    assert small["uncovered_share"] == 0.0
    given = check(3, 200.0, 20.0, frozenset(), sample_mm=2.0)
    assert (
        given["coverage_sample_mm"] == given["coverage_sample_asked_mm"] == pytest.approx(2.0)
        and samples(given) == 3 * 101 * 10
    )
    fine = check(6, 2000.0, 40.0, frozenset(), sample_mm=0.5)
    assert fine["coverage_sample_mm"] == pytest.approx(math.sqrt(6 * 2000.0 * 40.0 / MAX_GRID_SAMPLES), abs=1e-3)
    assert fine["coverage_sample_asked_mm"] == pytest.approx(0.5)
    assert samples(fine) <= 1.01 * MAX_GRID_SAMPLES and fine["uncovered_share"] == 0.0
