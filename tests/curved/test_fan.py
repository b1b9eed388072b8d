"""Fan slicing: wedge layers whose local height is r·Δθ; frames; overhang; radius search."""

import math

import numpy as np
import pytest
from shapely.geometry import MultiPolygon, box

from waamflow.curved.fan import (
    angular_range,
    fan_dtheta,
    fan_slice,
    height_range,
    local_height,
    make_axis,
    plan_fan,
    to_local,
)
from waamflow.curved.feasibility import max_overhang, search_radius
from waamflow.curved.shapes import bent_tube


@pytest.fixture(scope="module")
def duct():
    return bent_tube(bend=100, mid=15, wall=3, sweep_deg=90, n_phi=36, n_psi=32)


@pytest.fixture(scope="module")
def layers(duct):
    axis = make_axis((-100, 0, 0), (0, -1, 0), duct.vertices)
    return fan_slice(duct, plan_fan(duct, axis, 3.0))


def test_layer_count_and_range(duct, layers):
    axis = make_axis((-100, 0, 0), (0, -1, 0), duct.vertices)
    lo, hi = angular_range(axis, duct.vertices)
    assert math.degrees(hi - lo) == pytest.approx(90.0, abs=1e-6)
    assert len(layers) == 30  # 90° / 3°
    assert all(len(l.region.geoms) == 1 and len(l.region.geoms[0].interiors) == 1 for l in layers)
    ring = 0.5 * 32 * math.sin(2 * math.pi / 32) * (16.5**2 - 13.5**2)  # faceted ring area, mm²
    assert all(l.area == pytest.approx(ring, rel=1e-3) for l in layers)


def test_thickness_is_r_dtheta(layers):
    dth = math.radians(3.0)
    for l in layers:
        assert fan_dtheta(l) == pytest.approx(dth, rel=1e-9)
        assert l.thickness == pytest.approx(l.region.centroid.x * dth, rel=1e-9)
        assert local_height(l, [[100.0, 0.0]])[0] == pytest.approx(100 * dth, rel=1e-9)  # 5.236 mm
        lo, hi = height_range(l)
        # cut planes fall between facet rings: the faceted wall is up to r·(1 − cos 1.25°) ≈ 0.03 mm inside
        assert lo == pytest.approx(83.5 * dth, abs=0.05 * dth) and hi == pytest.approx(116.5 * dth, abs=0.05 * dth)
    assert local_height(layers[0], [[50.0, 3.0], [150.0, -3.0]]).tolist() == pytest.approx([50 * dth, 150 * dth])


def test_frames_put_paths_on_the_top_plane(layers):
    for j, l in enumerate(layers[:5]):
        f = l.frame
        assert np.allclose(f[:3, :3].T @ f[:3, :3], np.eye(3)) and np.linalg.det(f[:3, :3]) == pytest.approx(1.0)
        # local (r, 0) lies at distance r from the axis, (j+1)·3° up from the substrate plane z = 0
        p = l.to_world([[100.0, 0.0]])[0]
        assert np.hypot(p[0] + 100, p[2]) == pytest.approx(100.0)
        assert math.degrees(math.atan2(p[2], p[0] + 100)) == pytest.approx(3.0 * (j + 1))
        assert np.allclose(to_local(l, l.to_world([[90.0, 4.0]])), [[90.0, 4.0]])
    assert layers[0].normal[2] > 0.99  # layer 0 builds up from the substrate


def test_radius_offset_moves_the_axis_outward(duct):
    axis = make_axis((-100, 0, 0), (0, -1, 0), duct.vertices, radius_offset=20.0, part_faces=duct.faces)
    r, _th, _ax = axis.polar(duct.vertices)
    assert r.max() == pytest.approx(136.5, abs=1e-6)  # the start plane's far edge: 116.5 + 20
    # moved within the start plane (z = 0), away from the part: layer 0 still sits on the substrate
    assert np.allclose(axis.point, [-120, 0, 0])
    layers = fan_slice(duct, plan_fan(duct, axis, 3.0))
    first = layers[0].to_world([[130.0, 0.0]])[0]
    assert first[2] == pytest.approx(130 * math.sin(math.radians(3.0)))  # top of a wedge on z = 0


def test_part_around_the_axis_is_refused():
    ring = bent_tube(bend=50, mid=10, wall=2, sweep_deg=360, n_phi=36, n_psi=12)
    axis = make_axis((-50, 0, 0), (0, -1, 0), ring.vertices[:-40])
    with pytest.raises(ValueError, match="surrounds"):
        plan_fan(ring, axis, 3.0)


def test_overhang_of_projected_layers():
    a = MultiPolygon([box(100, -2, 110, 2)])
    b = MultiPolygon([box(101, -2, 111, 2)])  # shifted 1 mm outward
    assert max_overhang([a, b], 0.0) == pytest.approx(1.0, abs=1e-9)
    # projected onto the previous plane x shrinks by cos Δθ: the inner edge lands at 101·cos 10°
    assert max_overhang([a, b], math.radians(10)) == pytest.approx(100 - 101 * math.cos(math.radians(10)), abs=1e-9)


def test_radius_search():
    flat = bent_tube(bend=100, mid=15, wall=3, n_phi=24, n_psi=16)
    res = search_radius(flat, (-100, 0, 0), (0, -1, 0), 2.2, 3.2, max_overhang_mm=1.5, step=10, max_offset=60)
    assert len(res.candidates) == 1 and res.best.offset == 0.0 and res.best.overhang < 0.1
    assert res.min_csratio == pytest.approx(2.7)
    curved = bent_tube(bend=60, mid=15, wall=3, n_phi=24, n_psi=16)  # CSratio 60/33 = 1.82 < 2.7
    res = search_radius(curved, (-60, 0, 0), (0, -1, 0), 2.2, 3.2, max_overhang_mm=1.5, step=10, max_offset=60)
    first = res.candidates[0]
    assert first.csratio == pytest.approx(60 / 33, rel=1e-3) and not first.feasible
    # over a 90° bend, moving the axis within the start plane barely lifts r_min: never fits
    assert len(res.candidates) == 7 and res.best is None
    assert all(c.r_min / c.r_max < 2.2 / 3.2 and c.csratio < 2.7 for c in res.candidates)
