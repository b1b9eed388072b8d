"""Corner division (sections.corners): non-convex sections cut at their reflex corners."""

import numpy as np
import pytest
import shapely
from shapely import affinity
from shapely.geometry import Point, Polygon, box

from waamflow.sections.corners import MAX_PIECES, SLIT, corner_division, reflex_corners


def bounds(pieces):
    return sorted(tuple(round(v, 6) for v in p.bounds) for p in pieces)


def test_l_is_cut_across_its_short_arm_keeping_the_long_arm_whole():
    ell = box(0, 0, 120, 16).union(box(0, 0, 16, 64))
    assert len(reflex_corners(ell)) == 1
    pieces = corner_division(ell)
    # both candidate cuts are 16 mm long; the one keeping the 120 × 16 arm whole wins
    assert bounds(pieces) == [(0, 0, 120, 16), (0, 16, 16, 64)]
    assert [p.area for p in pieces] == pytest.approx([1920.0, 768.0])


def test_t_and_u():
    tee = box(0, 0, 120, 16).union(box(52, 0, 68, 64))
    assert bounds(corner_division(tee)) == [(0, 0, 120, 16), (52, 16, 68, 64)]
    u = shapely.union_all([box(0, 0, 120, 16), box(0, 0, 16, 64), box(104, 0, 120, 64)])
    assert bounds(corner_division(u)) == [(0, 0, 120, 16), (0, 16, 16, 64), (104, 16, 120, 64)]


def test_square_frame_opens_its_hole_and_gives_four_bars():
    frame = box(0, 0, 80, 60).difference(box(16, 16, 64, 44))
    pieces = corner_division(frame)
    assert len(pieces) == 4 and all(not p.interiors for p in pieces)
    # the first cut opens the hole with a slit SLIT mm wide across the 16 mm bar
    assert sum(p.area for p in pieces) == pytest.approx(frame.area - SLIT * 16, abs=1e-3)
    widths = sorted(min(p.bounds[2] - p.bounds[0], p.bounds[3] - p.bounds[1]) for p in pieces)
    assert widths == pytest.approx([16.0] * 4, abs=1e-3)


def test_rotated_l_gives_rotated_pieces():
    ell = box(0, 0, 120, 16).union(box(0, 0, 16, 64))
    rot = affinity.rotate(ell, 33, origin=(0, 0))
    pieces = corner_division(rot)
    assert sorted(p.area for p in pieces) == pytest.approx([768.0, 1920.0])


@pytest.mark.parametrize(
    "region",
    [
        box(0, 0, 120, 16),
        Point(0, 0).buffer(30),
        Point(0, 0).buffer(40, quad_segs=32).difference(Point(0, 0).buffer(24, quad_segs=32)),
        Polygon([(0, 0), (50, 0), (40, 20), (8, 20)]),
    ],
)
def test_convex_or_smooth_sections_are_not_cut(region):
    """A convex section has no reflex corner; a polygonised round hole turns 2.8° per vertex."""
    assert reflex_corners(region) == []
    assert corner_division(region) == [region]


def test_gentle_bend_is_not_a_corner_but_a_right_angle_is():
    bend = Polygon([(0, 0), (50, 0), (90, 8), (90, 24), (50, 16), (0, 16)])  # 11.3° turn inward
    assert reflex_corners(bend) == []
    notch = Polygon([(0, 0), (50, 0), (50, 10), (60, 10), (60, 0), (90, 0), (90, 30), (0, 30)])
    assert len(reflex_corners(notch)) == 2


def test_sawtooth_stops_at_max_pieces():
    x = np.arange(0, 400, 4.0)  # 48 reflex corners
    teeth = [(xi, 10.0 + 5.0 * (k % 2)) for k, xi in enumerate(x)]
    saw = Polygon([(0, 0), (x[-1], 0), *teeth[::-1]])
    pieces = corner_division(saw)
    assert 1 < len(pieces) <= MAX_PIECES  # (28: cuts leaving a piece under 1 % of its parent are not made)
    assert sum(p.area for p in pieces) == pytest.approx(saw.area, rel=1e-9)


def test_a_plate_of_many_holes_opens_at_most_max_holes_opened():
    """A 300 × 200 plate with 40 square 6 mm holes (160 reflex corners; a countertop of 205 holes
    took 6 s a cut): a cut that only opens a hole divides nothing by itself, so at most
    MAX_HOLES_OPENED are made (before, all 40 were opened on the way to 32 pieces). Each round splits
    only the shortest candidates, not all 320."""
    from waamflow.sections import corners

    holes = [box(20 + 35 * i, 20 + 40 * j, 26 + 35 * i, 26 + 40 * j) for i in range(8) for j in range(5)]
    plate = box(0, 0, 300, 200).difference(shapely.union_all(holes))
    assert len(reflex_corners(plate)) == 160
    splits = []
    real = corners.split

    def counting(geom, blade):
        splits.append(1)
        return real(geom, blade)

    corners.split = counting
    try:
        pieces = corner_division(plate)
    finally:
        corners.split = real
    assert sum(len(p.interiors) for p in pieces) == 40 - corners.MAX_HOLES_OPENED
    assert len(pieces) <= MAX_PIECES
    assert sum(p.area for p in pieces) == pytest.approx(plate.area, abs=corners.MAX_HOLES_OPENED * corners.SLIT * 41)
    assert len(splits) <= 300  # 274 (14 pieces); before, every corner each round: 14,448 (16 s)
