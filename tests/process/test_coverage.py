"""Coverage of sections by beads: void, overlap and over-deposit areas on shapes with known answers."""

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, box

from waamflow.process.coverage import section_coverage


def passes(ys, x0=0.0, x1=40.0, linked=False):
    """Parallel passes along x at heights ys; separate (arc OFF between) or linked boustrophedon."""
    pts, arc = [], []
    for k, y in enumerate(ys):
        a, b = (x0, x1) if k % 2 == 0 else (x1, x0)
        if pts:
            arc.append(linked)
        pts += [[a, y], [b, y]]
        arc.append(True)
    return np.array(pts, float), np.array(arc, bool)


def test_parallel_passes_void_and_over_deposit_exact():
    region = box(0, 0, 40, 20)
    pts, arc = passes([2.5, 7.5, 12.5, 17.5])
    cov = section_coverage(region, pts, arc, width=4.0)
    # inside the rectangle each pass covers a 40 x 4 strip; its round ends spill outside
    assert cov.void_area == pytest.approx(800 - 4 * 40 * 4, rel=0.01)
    assert cov.over_deposit_area == pytest.approx(4 * math.pi * 2**2, rel=0.01)
    assert cov.overlap_area == pytest.approx(0.0, abs=1e-9)


def test_overlapping_passes_overlap_area():
    region = box(0, 0, 40, 20)
    ys = [2.0, 5.0, 8.0, 11.0, 14.0, 17.0]  # 3 mm apart, 4 mm wide: 1 mm overlap strips
    pts, arc = passes(ys)
    cov = section_coverage(region, pts, arc, width=4.0)
    lines = [LineString([(0, y), (40, y)]).buffer(2.0, quad_segs=64) for y in ys]
    exact = shapely.union_all([a.intersection(b) for a, b in zip(lines[:-1], lines[1:])]).area
    assert cov.overlap_area == pytest.approx(exact, rel=0.02)
    assert cov.void_area == pytest.approx(region.difference(shapely.union_all(lines)).area, rel=0.01)
    # the beads cover y 0..19: the 1 mm strip along the top is the void
    assert cov.void_area == pytest.approx(40.0, rel=0.01)


def test_linked_path_does_not_count_itself_along_a_straight_run():
    """One polyline: a straight run split into many segments is one pass, not many."""
    region = box(0, 0, 40, 4)
    x = np.linspace(0, 40, 81)
    pts = np.column_stack([x, np.full_like(x, 2.0)])
    cov = section_coverage(region, pts, np.ones(80, bool), width=4.0)
    assert cov.overlap_area == pytest.approx(0.0, abs=1e-9)
    assert cov.void_area == pytest.approx(0.0, abs=1e-6)


def test_reversal_counts_twice():
    """Out and back along the same line: the whole footprint is deposited twice."""
    region = box(0, 0, 40, 4)
    pts = np.array([[0, 2.0], [40, 2.0], [0, 2.0]])
    cov = section_coverage(region, pts, np.ones(2, bool), width=4.0)
    # the whole stadium (40 x 4 + a disc of radius 2) except the disc about the turning vertex,
    # where going out and coming back is one connected stretch
    assert cov.overlap_area == pytest.approx(40 * 4 + math.pi * 4 - math.pi * 4, rel=0.01)


def _strips_one_by_one(mask, origin, cell):
    """The overlap polygon as it was first built: a box per row's strip, all united."""
    boxes = []
    for j in np.flatnonzero(mask.any(axis=1)):
        row = np.concatenate([[False], mask[j], [False]]).astype(np.int8)
        edges = np.flatnonzero(np.diff(row))
        y0 = origin[1] + j * cell
        for s, e in zip(edges[::2], edges[1::2]):
            boxes.append(box(origin[0] + s * cell, y0, origin[0] + e * cell, y0 + cell))
    return shapely.union_all(boxes) if boxes else shapely.Polygon()


def _bands(h: int, w: int) -> np.ndarray:
    """Overlap bands as a raster fill and its turns leave them: along y, along x and diagonal."""
    yy, xx = np.mgrid[:h, :w]
    return (np.abs(xx % 40 - 20) < 4) | (np.abs(yy % 50 - 25) < 3) | (np.abs((xx + yy) % 60 - 30) < 3)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_overlap_cells_polygon_is_the_cells_exactly_with_fewer_vertices(seed):
    """Strips of the same columns in consecutive rows are one box: the same cells (area to 1e-9,
    the old per-strip union's point set up to rounding of the shared edges), a valid polygon, and
    no more vertices than the per-strip union kept (collinear ones on a band's sides)."""
    from waamflow.process.coverage import _cells_to_polygon

    rng = np.random.default_rng(seed)
    mask = rng.random((37, 53)) < 0.3 if seed < 3 else _bands(200, 400)
    mask[5] = True  # a full row: one strip edge to edge
    origin, cell = np.array([-12.3, 4.56]), 0.3
    got, want = _cells_to_polygon(mask, origin, cell), _strips_one_by_one(mask, origin, cell)
    assert got.is_valid
    assert got.area == pytest.approx(mask.sum() * cell * cell, rel=1e-9)
    assert got.symmetric_difference(want).area < 1e-9 * want.area
    assert len(shapely.get_coordinates(got)) <= len(shapely.get_coordinates(want))
    if seed == 3:  # bands: a box per band stretch, not per row (9,034 vertices before, 4,919 now:
        # the diagonal band's staircase is real; the bands along x and y lose their collinear ones)
        assert len(shapely.get_coordinates(got)) < 0.6 * len(shapely.get_coordinates(want))
    assert _cells_to_polygon(np.zeros((4, 4), bool), origin, cell).is_empty
