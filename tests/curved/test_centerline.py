"""Ring centre line (curved/centerline.py): nearest points from the hole's segment R-tree agree
with GEOS projection point by point; a concentric ring gives the mid circle and the width."""

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Polygon

from waamflow.curved.centerline import nearest_on_polyline, ring_centerline


def test_nearest_points_agree_with_geos_projection():
    rng = np.random.default_rng(7)
    line = np.cumsum(rng.normal(0.0, 3.0, (400, 2)), axis=0)        # a wiggly open polyline
    pts = rng.uniform(line.min(0) - 5, line.max(0) + 5, (2000, 2))
    ours = nearest_on_polyline(line, pts)
    ls = LineString(line)
    geos = shapely.get_coordinates(shapely.line_interpolate_point(ls, shapely.line_locate_point(ls, shapely.points(pts))))
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
    assert np.all(np.abs(r - 77.0) < 0.01)                  # chords of the 2,000-gon: sagitta < 0.001 mm
    assert width == pytest.approx(6.0, abs=0.01)
    assert np.allclose(mid[0], mid[-1]) and Polygon(mid).exterior.is_ccw
    assert 480 <= len(mid) - 1 <= 510                        # ≤ 1 mm spacing on a 503 mm lap
