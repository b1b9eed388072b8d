"""Ring centre line (curved/centerline.py): nearest points from the hole's prepared facets agree
with GEOS projection point by point; a concentric ring gives the mid circle and the width."""

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Polygon

from waamflow.curved.centerline import nearest_on_polyline, ring_centerline


def test_nearest_points_agree_with_geos_projection():
    rng = np.random.default_rng(7)
    line = np.cumsum(rng.normal(0.0, 3.0, (400, 2)), axis=0)  # a wiggly open polyline
    pts = rng.uniform(line.min(0) - 5, line.max(0) + 5, (2000, 2))
    ours = nearest_on_polyline(line, pts)
    ls = LineString(line)
    geos = shapely.get_coordinates(
        shapely.line_interpolate_point(ls, shapely.line_locate_point(ls, shapely.points(pts)))
    )
    # the same distance everywhere (a tie between two segments may pick the other, equally near point)
    d_ours = np.hypot(*(pts - ours).T)
    d_geos = np.hypot(*(pts - geos).T)
    assert np.max(np.abs(d_ours - d_geos)) < 1e-9
    assert np.mean(np.all(np.abs(ours - geos) < 1e-9, axis=1)) > 0.99


def test_concentric_ring_gives_the_mid_circle():
    th = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    ring = Polygon(np.c_[80 * np.cos(th), 80 * np.sin(th)], [np.c_[74 * np.cos(th), 74 * np.sin(th)][::-1]])
    mid, width = ring_centerline(ring, spacing=1.0)
    r = np.hypot(*mid.T)
    assert np.all(np.abs(r - 77.0) < 0.01)  # chords of the 2,000-gon: sagitta < 0.001 mm
    assert width == pytest.approx(6.0, abs=0.01)
    assert np.allclose(mid[0], mid[-1]) and Polygon(mid).exterior.is_ccw
    assert 480 <= len(mid) - 1 <= 510  # ≤ 1 mm spacing on a 503 mm lap


def _slot(length=60.0, radius=10.0, start=0.0, spacing=1.0):
    """Closed CCW centre line of a slot (two straights of `length`, two half circles of
    `radius`), first point repeated, starting `start` mm along the lap from the lower straight's
    left end."""
    from waamflow.curved.centerline import resample_ring

    th = np.linspace(-np.pi / 2, np.pi / 2, 200)
    right = np.c_[length + radius * np.cos(th), radius * np.sin(th)]
    left = np.c_[-radius * np.cos(th), -radius * np.sin(th)]
    ring = np.vstack([[0.0, -radius], right, left, [[0.0, -radius]]])
    ring = resample_ring(ring, spacing)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(ring, axis=0).T))])
    i = int(np.searchsorted(s, start))
    return np.vstack([ring[i:-1], ring[:i], ring[i : i + 1]])


@pytest.mark.parametrize("start", [0.0, 17.0, 70.0, 101.0])
def test_seam_in_the_middle_of_the_longest_straight(start):
    from waamflow.curved.centerline import seam_index

    mid = _slot(length=60.0, radius=10.0, start=start)
    seam = mid[seam_index(mid)]
    # the straights are 60 mm long; the longer-by-sampling one wins, its middle is x = 30 mm
    assert abs(seam[0] - 30.0) <= 1.0 and abs(abs(seam[1]) - 10.0) < 1e-6


def test_seam_of_a_circle_is_its_farthest_x_and_near_follows_the_seam_below():
    from waamflow.curved.centerline import seam_index, start_at

    th = np.linspace(0, 2 * np.pi, 361)
    circle = np.c_[40 + 15 * np.cos(th + 1.0), 15 * np.sin(th + 1.0)]
    i = seam_index(circle)
    assert circle[i] == pytest.approx([55.0, 0.0], abs=0.14)  # samples 1° (0.26 mm) apart
    below = np.array([40.0, 0.0]) + 15.3 * np.array([np.cos(2.0), np.sin(2.0)])  # just outside the lap
    j = seam_index(circle, near=below)
    assert np.hypot(*(circle[j] - [40 + 15 * np.cos(2.0), 15 * np.sin(2.0)])) < 0.2
    lap = start_at(circle, j)
    assert np.allclose(lap[0], circle[j]) and np.allclose(lap[-1], lap[0]) and len(lap) == len(circle)
