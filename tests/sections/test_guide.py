"""Guides: exactly two boundary crossings, clipped between start and stop; default long axis."""

import pytest
import shapely
from shapely.geometry import LineString, Polygon, box

from waamflow.core.errors import PlanningError, RecipeError
from waamflow.core.model import Section
from waamflow.sections import apply_guide, guide_crossings
from waamflow.sections.guide import guide_line


def sec(geom, key="bs1/A"):
    return Section(key, geom)


def test_straight_guide_clipped_to_the_bar():
    s = apply_guide(sec(box(0, 0, 100, 10)), LineString([(-10, 5), (110, 5)]), layer=2)
    assert s.start == (0.0, 5.0) and s.stop == (100.0, 5.0)
    assert s.guide.length == pytest.approx(100.0)


def test_guide_direction_sets_start_and_stop():
    s = apply_guide(sec(box(0, 0, 100, 10)), LineString([(110, 5), (-10, 5)]))
    assert s.start == (100.0, 5.0) and s.stop == (0.0, 5.0)


def test_bent_guide_keeps_its_bend_between_crossings():
    # L-shaped section; guide goes along the bottom arm, turns, goes up the vertical arm.
    region = shapely.union(box(0, 0, 60, 10), box(50, 0, 60, 60))
    g = LineString([(-5, 5), (55, 5), (55, 70)])
    s = apply_guide(sec(region), g)
    assert guide_crossings(region, g) == pytest.approx([5.0, 5 + 50 + 5 + 60 - 5])
    assert s.start == (0.0, 5.0) and s.stop == (55.0, 60.0)
    assert s.guide.length == pytest.approx(55 + 55)


@pytest.mark.parametrize(
    "guide, count",
    [
        ([(10, 5), (90, 5)], 0),  # inside, never crosses
        ([(-10, 5), (50, 5)], 1),  # crosses once, ends inside
        ([(-10, 5), (110, 5), (110, 8), (-10, 8)], 4),  # in and out twice
    ],
)
def test_crossing_count_other_than_two_fails_with_layer_and_section(guide, count):
    with pytest.raises(PlanningError) as e:
        apply_guide(sec(box(0, 0, 100, 10), "bs2/C"), LineString(guide), layer=11)
    assert (e.value.layer, e.value.section) == (11, "bs2/C")
    assert f"{count} times" in e.value.message


def test_guide_through_a_hole_crosses_four_times():
    ring = Polygon([(0, 0), (100, 0), (100, 20), (0, 20)], [[(40, 5), (60, 5), (60, 15), (40, 15)]])
    assert len(guide_crossings(ring, LineString([(-1, 10), (101, 10)]))) == 4
    assert len(guide_crossings(ring, LineString([(-1, 2), (101, 2)]))) == 2


def test_crossing_through_a_boundary_vertex_counts_once():
    diamond = Polygon([(0, 0), (10, 10), (20, 0), (10, -10)])
    assert guide_crossings(diamond, LineString([(-5, 0), (25, 0)])) == pytest.approx([5.0, 25.0])


def test_default_guide_is_the_long_axis():
    s = apply_guide(sec(box(0, 0, 100, 10)), None)
    assert s.start == pytest.approx((0.0, 5.0)) and s.stop == pytest.approx((100.0, 5.0))
    rotated = shapely.affinity.rotate(box(0, 0, 80, 8), 90, origin=(0, 0))
    s = apply_guide(sec(rotated), None)
    assert s.guide.length == pytest.approx(80.0)


def test_default_guide_on_non_convex_region_keeps_longest_inside_piece():
    # An 'E' shape 40 × 100: the long axis (x = 20) crosses three 10 mm prongs; the longest inside
    # piece (first of equals) is kept, so the result crosses the boundary exactly twice.
    e = shapely.union_all([box(0, 0, 10, 100), box(0, 0, 40, 10), box(0, 45, 40, 57), box(0, 90, 40, 100)])
    s = apply_guide(sec(e), None)
    assert s.guide.length == pytest.approx(12.0)
    assert s.start == pytest.approx((20.0, 45.0)) and s.stop == pytest.approx((20.0, 57.0))
    assert len(guide_crossings(e, s.guide)) == 2


def test_bad_guide_points_are_recipe_errors():
    with pytest.raises(RecipeError):
        guide_line([[0, 0]], "bs1/A")
    with pytest.raises(RecipeError):
        guide_line([[0, 0], [0, 0]], "bs1/A")
