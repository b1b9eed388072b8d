"""The planar coverage against an independent measure: the part's interior on a grid (trimesh's
`contains`), each point covered when an arc-ON segment of the layer whose slab holds it passes
within half a bead width in plan (a k-d tree over the segments' samples) — no shapely, no slabs'
sections. On parts whose sides stand upright the two agree within the grid's error; the oracle
found the slab that outweighed its volume (test_slab_volumes.py: PrusaSlicer's Prusa.stl, 1.1 %
reported for 12.4 %). On slanted sides they differ by the layers' stair steps, which the
preflight's mid-slab sections do not see (PrusaSlicer's V_standing.obj: 3.1 % vs 6.3 %)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from waamflow.preflight.check import Part, check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings

from tests.preflight.test_slab_volumes import _program as _stepped_program
from tests.preflight.test_slab_volumes import _stepped

WIDTH = 6.0


_INTERIOR: dict[tuple, np.ndarray] = {}


def _interior(mesh: trimesh.Trimesh, pitch: float) -> np.ndarray:
    """The grid points (pitch apart, cell centres) inside the mesh; kept per mesh and pitch."""
    key = (mesh.vertices.tobytes(), mesh.faces.tobytes(), pitch)
    if key not in _INTERIOR:
        lo, hi = mesh.bounds
        axes = [np.arange(lo[i] + pitch / 2, hi[i], pitch) for i in range(3)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        _INTERIOR[key] = grid[mesh.contains(grid)]
    return _INTERIOR[key]


def _oracle(mesh: trimesh.Trimesh, layers: list[tuple[float, list]], pitch: float, width: float) -> float:
    """Share of the part's interior grid points no layer's bead reaches (see the module doc)."""
    lo = mesh.bounds[0]
    inside = _interior(mesh, pitch)
    covered = np.zeros(len(inside), dtype=bool)
    below = lo[2]
    for z, lines in layers:
        pts = []
        for (x0, y0), (x1, y1) in lines:
            n = max(2, int(np.ceil(np.hypot(x1 - x0, y1 - y0) / (0.05 * width))) + 1)
            t = np.linspace(0.0, 1.0, n)[:, None]
            pts.append(np.array([x0, y0]) + t * np.array([x1 - x0, y1 - y0]))
        slab = (inside[:, 2] > below) & (inside[:, 2] <= z)
        d, _ = cKDTree(np.vstack(pts)).query(inside[slab, :2])
        covered[np.flatnonzero(slab)[d <= width / 2]] = True
        below = z
    return 1.0 - float(covered.mean())


def _gcode(layers: list[tuple[float, list]]) -> str:
    out = ["; waamflow-post: arc_on=M3 arc_off=M5 dwell_units=s feed_units=mm/min end=M30", "G21", "G90"]
    out.append('; waamflow-weld: wire_feed_speed[m/min]="M67 E0 Q{value:.2f}"')
    for i, (z, lines) in enumerate(layers):
        out.append(f"; layer {i} z={z:.3f}")
        for (x0, y0), (x1, y1) in lines:
            out += [f"G0 X{x0:.3f} Y{y0:.3f} Z{z:.3f}", "M67 E0 Q4.00", "M3", f"G1 X{x1:.3f} Y{y1:.3f} F480", "M5"]
    out.append("M30")
    return "\n".join(out)


def _l_shape() -> trimesh.Trimesh:
    """An L-shaped prism 60 x 40 mm, arms 20 mm wide, 10 mm tall."""
    from shapely.geometry import Polygon

    poly = Polygon([(0, 0), (60, 0), (60, 20), (20, 20), (20, 40), (0, 40)])
    return trimesh.creation.extrude_polygon(poly, 10.0)


def _rows(y0: float, y1: float, x0: float, x1: float, step: float) -> list:
    return [((x0, y), (x1, y)) for y in np.arange(y0, y1 + 1e-9, step)]


@pytest.mark.parametrize(
    "name, layers",
    [
        # every layer fills the L (rows 5 mm apart along x, the upright arm's rows too)
        ("full", [(z, _rows(2.5, 17.5, 0, 60, 5) + _rows(22.5, 37.5, 0, 20, 5)) for z in (2.0, 4.0, 6.0, 8.0, 10.0)]),
        # layers 2 and 3 leave the upright arm out
        (
            "arm left out",
            [
                (z, _rows(2.5, 17.5, 0, 60, 5) + ([] if z in (6.0, 8.0) else _rows(22.5, 37.5, 0, 20, 5)))
                for z in (2.0, 4.0, 6.0, 8.0, 10.0)
            ],
        ),
        # rows 8 mm apart: stripes with no bead between them on every layer
        (
            "rows too far apart",
            [(z, _rows(3.0, 19.0, 0, 60, 8) + _rows(27.0, 35.0, 0, 20, 8)) for z in (2.0, 4.0, 6.0, 8.0, 10.0)],
        ),
    ],
)
def test_the_planar_coverage_agrees_with_a_grid_of_the_part(name, layers):
    mesh = _l_shape()
    part = Part("solid", "part", vertices=np.asarray(mesh.vertices), faces=np.asarray(mesh.faces))
    rep = check_program(part, read_gcode(_gcode(layers)), "post", PreflightSettings(), WIDTH)
    oracle = _oracle(mesh, layers, 0.5, WIDTH)
    assert rep["uncovered_share"] == pytest.approx(oracle, abs=0.01), name


def test_a_step_inside_a_slab_agrees_with_the_grid():
    """The plate-and-boss of test_slab_volumes.py: 7.4 % of the part, half the boss, gets no bead."""
    part = _stepped()
    mesh = trimesh.Trimesh(part.vertices, part.faces)
    layers = [
        (2.0, [((-30.0, y), (30.0, y)) for y in np.arange(-27.5, 28.0, 5.0)]),
        (4.0, [((-10.0, y), (-3.0, y)) for y in (-7.5, -2.5, 2.5, 7.5)]),
    ]
    rep = check_program(part, read_gcode(_stepped_program()), "post", PreflightSettings(), WIDTH)
    oracle = _oracle(mesh, layers, 0.4, WIDTH)  # 0.4: 3 rows in the 1.2 mm plate, 7 in the 2.8 mm boss
    assert oracle == pytest.approx(400 / 5440, abs=0.01)
    assert rep["uncovered_share"] == pytest.approx(oracle, abs=0.01)
