import json

import numpy as np
import pytest

from shapely.geometry import Polygon

from waamflow.core import serialize
from waamflow.core.errors import PlanningError
from waamflow.core.model import Layered, MeshData
from waamflow.geometry.mesh_io import mesh_from_triangles
from waamflow.slicing import empty_layers_inside, layer_schedule, section_loops, slice_part

from .meshes import as_mesh, box, cylinder, frustum, ngon_area, ribbed_tube, tube, union


def test_tube_20_layers_one_hole_area_within_1_percent():
    layers = slice_part(as_mesh(tube(20, 30, 30)), layer_height=1.5)
    assert len(layers) == 20
    np.testing.assert_allclose([l.z for l in layers], 1.5 * np.arange(1, 21))
    assert all(l.thickness == 1.5 for l in layers)
    target = np.pi * (30**2 - 20**2)
    for l in layers:
        assert len(l.region.geoms) == 1
        poly = l.region.geoms[0]
        assert len(poly.interiors) == 1
        assert abs(l.area - target) / target < 0.01
        # exactly the faceted section, and outer ring CCW, hole CW
        assert l.area == pytest.approx(ngon_area(30) - ngon_area(20), rel=1e-9)
        assert poly.exterior.is_ccw and not poly.interiors[0].is_ccw


def test_tube_layers_json_matches_contract():
    layers = slice_part(as_mesh(tube(20, 30, 30)), layer_height=1.5)
    doc = json.loads(serialize.dumps(serialize.layers_json(Layered(layers))))
    assert len(doc["layers"]) == 20
    first = doc["layers"][0]
    assert (first["index"], first["z"], first["thickness"]) == (0, 1.5, 1.5)
    assert len(first["polygons"]) == 1 and len(first["polygons"][0]["holes"]) == 1
    assert first["curves"] == []
    ring = np.array(first["polygons"][0]["exterior"])
    assert np.allclose(np.hypot(ring[:, 0], ring[:, 1]), 30.0, atol=1e-3)


def test_frustum_area_follows_mid_layer_radius():
    r0, r1, h = 30.0, 10.0, 20.0
    layers = slice_part(as_mesh(frustum(r0, r1, h)), layer_height=2.0)
    assert len(layers) == 10
    for l in layers:
        cut = l.z - l.thickness / 2
        r = r0 + (r1 - r0) * cut / h
        assert len(l.region.geoms) == 1 and not l.region.geoms[0].interiors
        assert l.area == pytest.approx(ngon_area(r), rel=1e-9)
    areas = [l.area for l in layers]
    assert all(a > b for a, b in zip(areas, areas[1:]))


def test_two_bodies_two_polygons_per_layer():
    part = union(box((10, 10, 12)), box((10, 20, 12), corner=(30, 0, 0)))
    layers = slice_part(as_mesh(part), layer_height=1.5)
    assert len(layers) == 8
    for l in layers:
        assert len(l.region.geoms) == 2
        assert sorted(p.area for p in l.region.geoms) == pytest.approx([100.0, 200.0])
        # straight runs hold only their corners
        assert sorted(len(p.exterior.coords) for p in l.region.geoms) == [5, 5]


def test_island_in_hole_and_nested_rings():
    # tube 20/30 with a solid rod r 10 standing in its hole, inside a tube 40/50
    part = union(tube(20, 30, 10), cylinder(10, 10), tube(40, 50, 10))
    layers = slice_part(as_mesh(part), layer_height=2.0)
    assert len(layers) == 5
    for l in layers:
        polys = sorted(l.region.geoms, key=lambda p: p.area)
        assert len(polys) == 3
        assert [len(p.interiors) for p in polys] == [0, 1, 1]
        assert polys[0].area == pytest.approx(ngon_area(10), rel=1e-9)
        assert l.area == pytest.approx(
            ngon_area(10) + ngon_area(30) - ngon_area(20) + ngon_area(50) - ngon_area(40), rel=1e-9
        )


def test_inside_out_mesh_slices_the_same():
    tm = tube(20, 30, 6)
    tm.invert()
    verts, faces = np.asarray(tm.vertices, float), np.asarray(tm.faces)
    layers = slice_part(MeshData(verts, faces), layer_height=1.5)
    assert len(layers) == 4
    for l in layers:
        assert len(l.region.geoms) == 1 and len(l.region.geoms[0].interiors) == 1
        assert l.area == pytest.approx(ngon_area(30) - ngon_area(20), rel=1e-9)


def test_explicit_thicknesses_give_listed_planes_then_layer_height():
    layers = slice_part(as_mesh(box((10, 10, 10))), layer_height=1.5, thicknesses=[0.5, 1.0, 2.0])
    # issue #22: the 0.5 mm left above 9.5 (1/3 of a layer) is merged into the last layer (2.0 mm),
    # which now tops at the part's top 10 instead of 0.5 mm below it
    np.testing.assert_allclose([l.thickness for l in layers], [0.5, 1.0, 2.0, 1.5, 1.5, 1.5, 2.0])
    np.testing.assert_allclose([l.z for l in layers], [0.5, 1.5, 3.5, 5.0, 6.5, 8.0, 10.0])
    assert all(l.area == pytest.approx(100.0) for l in layers)


def test_start_offset_shifts_layer_zero():
    layers = slice_part(as_mesh(box((10, 10, 10), corner=(0, 0, 5))), layer_height=1.5, start_offset=0.75)
    # issue #22: the last layer takes the 0.25 mm left below the top (1.75 mm, top 15 instead of 14.75)
    np.testing.assert_allclose([l.z for l in layers], [7.25, 8.75, 10.25, 11.75, 13.25, 15.0])
    np.testing.assert_allclose([l.thickness for l in layers], [1.5] * 5 + [1.75])
    assert len(layers) == 6


def test_layer_count_and_z_range():
    mesh = as_mesh(box((10, 10, 30)))
    assert len(slice_part(mesh, layer_height=1.0, layer_count=5)) == 5
    layers = slice_part(mesh, layer_height=1.0, z_min=10.0, z_max=20.0)
    np.testing.assert_allclose([l.z for l in layers], np.arange(11.0, 21.0))


def test_schedule_uniform_tops_are_exact_multiples():
    s = layer_schedule(0.0, 30.0, layer_height=0.1)
    assert len(s) == 300
    assert s.tops[-1] == pytest.approx(30.0, abs=1e-12)
    np.testing.assert_allclose(s.cuts, s.tops - 0.05)
    with pytest.raises(ValueError):
        layer_schedule(0.0, 1e7, layer_height=0.01)


def _ring_by_angle(points: np.ndarray) -> Polygon:
    return Polygon(points[np.argsort(np.arctan2(points[:, 1], points[:, 0])), :2])


def test_planes_through_vertices_still_close():
    """Cut planes exactly at vertex rows: loops stay closed and areas exact (symbolic perturbation)."""
    mesh = mesh_from_triangles(ribbed_tube(96, 10, radius=30, wall=5, height=10, ribs=6, rib_depth=2))
    # cuts at z = 0, 1, ..., 9: vertex rows ('nearest': with 'ceil' an 11th layer of 0.5 mm would
    # end on the top at 10 and be cut at 9.75, between the rows this test is about)
    layers = slice_part(mesh, layer_height=1.0, z_min=-0.5, top="nearest")
    assert len(layers) == 10
    assert layers[0].region.is_empty  # a plane through the bottom face touches no volume
    v = mesh.vertices
    for l in layers[1:]:
        row = v[np.isclose(v[:, 2], l.z - l.thickness / 2)]
        r = np.hypot(row[:, 0], row[:, 1])
        expected = _ring_by_angle(row[r > 25.5]).area - _ring_by_angle(row[r <= 25.5]).area
        assert len(l.region.geoms) == 1 and len(l.region.geoms[0].interiors) == 1
        assert l.area == pytest.approx(expected, rel=1e-9)


def test_open_mesh_cannot_be_sliced():
    tm = box((10, 10, 10))
    verts, faces = np.asarray(tm.vertices, float), np.asarray(tm.faces)[1:]
    with pytest.raises(PlanningError):
        section_loops(verts, faces, np.array([5.0]))


def test_empty_layers_inside_gap_between_stacked_bodies():
    part = union(box((10, 10, 3)), box((10, 10, 3), corner=(0, 0, 6)))
    mesh = as_mesh(part)
    layers = slice_part(mesh, layer_height=1.0)
    assert len(layers) == 9
    assert [l.index for l in layers if l.region.is_empty] == [3, 4, 5]
    assert empty_layers_inside(layers, mesh) == [3, 4, 5]


def test_overlapping_bodies_are_united():
    """Two boxes concatenated (not unioned) overlap by 5 × 10: the section is their union."""
    part = union(box((20, 10, 6)), box((20, 10, 6), corner=(15, 0, 0)), box((4, 4, 6), corner=(50, 0, 0)))
    layers = slice_part(as_mesh(part), layer_height=2.0)
    assert len(layers) == 3
    for l in layers:
        assert l.area == pytest.approx(350.0 + 16.0)
        assert sorted(p.area for p in l.region.geoms) == pytest.approx([16.0, 350.0])
        assert all(p.is_valid for p in l.region.geoms)


def test_cavity_shell_wound_inside_out_is_a_hole():
    """A closed cavity: outer box plus an inner box shell with inward normals (two bodies)."""
    cavity = box((10, 10, 4), corner=(5, 5, 3))
    cavity.invert()
    part = union(box((20, 20, 10)), cavity)
    layers = slice_part(as_mesh(part), layer_height=1.0)
    assert len(layers) == 10
    areas = [round(l.area, 9) for l in layers]
    assert areas == [400.0] * 3 + [300.0] * 4 + [400.0] * 3
    assert [len(l.region.geoms[0].interiors) for l in layers] == [0] * 3 + [1] * 4 + [0] * 3


def test_overlapping_body_with_cavity():
    """A rod crossing a part with a cavity: the rod fills the cavity where they overlap."""
    cavity = box((10, 10, 10), corner=(5, 5, 0))
    cavity.invert()
    rod = box((30, 2, 10), corner=(-5, 9, 0))
    part = union(box((20, 20, 10)), cavity, rod)
    layers = slice_part(as_mesh(part), layer_height=5.0)
    # box − cavity (300) ∪ rod (30 × 2): the rod adds 2 × 5 on either side and 2 × 10 inside the cavity
    assert [round(l.area, 9) for l in layers] == [340.0, 340.0]
    assert all(len(l.region.geoms) == 1 and len(l.region.geoms[0].interiors) == 2 for l in layers)


def test_build_direction_along_x_with_layer_frames():
    layers = slice_part(as_mesh(box((10, 20, 30), corner=(5, 0, 0))), layer_height=2.0, direction=(1, 0, 0))
    assert len(layers) == 5
    np.testing.assert_allclose([l.z for l in layers], [7.0, 9.0, 11.0, 13.0, 15.0])
    for l in layers:
        assert l.area == pytest.approx(600.0)
        world = l.to_world(np.asarray(l.region.geoms[0].exterior.coords))
        np.testing.assert_allclose(world[:, 0], l.z)  # on the layer's top plane
        np.testing.assert_allclose(
            [world[:, 1].min(), world[:, 1].max(), world[:, 2].min(), world[:, 2].max()], [0, 20, 0, 30], atol=1e-9
        )
        np.testing.assert_allclose(l.normal, [1, 0, 0])


def test_build_direction_down_flips_the_stack():
    r0, r1, h = 30.0, 10.0, 20.0
    layers = slice_part(as_mesh(frustum(r0, r1, h)), layer_height=2.0, direction=(0, 0, -1))
    assert len(layers) == 10
    cuts_world = [-(l.z - l.thickness / 2) for l in layers]  # distance along −Z
    np.testing.assert_allclose(cuts_world, 19.0 - 2.0 * np.arange(10))
    for l, zc in zip(layers, cuts_world):
        assert l.area == pytest.approx(ngon_area(r0 + (r1 - r0) * zc / h), rel=1e-9)
    np.testing.assert_allclose(layers[0].to_world([[0.0, 0.0]]), [[0.0, 0.0, 18.0]], atol=1e-12)


def test_crowded_planes_use_the_tree_paths():
    """100 cubes inside a square frame (102 loops a plane, over the all-pairs limit), two of
    them overlapping: nesting and the overlap union go through the STRtree paths."""
    frame = box((120, 120, 4), corner=(-10, -10, 0))
    hole = box((110, 110, 4), corner=(-5, -5, 0))
    hole.invert()  # frame = outer box with a through cavity
    cubes = [box((4, 4, 4), corner=(10 * i, 10 * j, 0)) for i in range(10) for j in range(10)]
    cubes.append(box((4, 4, 4), corner=(2, 0, 0)))  # overlaps the cube at (0, 0) by 2 × 4
    layers = slice_part(as_mesh(union(frame, hole, *cubes)), layer_height=2.0)
    assert len(layers) == 2
    for l in layers:
        polys = l.region.geoms
        assert len(polys) == 101  # 99 cubes, one 6 × 4 block, the frame
        frame_poly = max(polys, key=lambda p: p.area)
        assert frame_poly.area == pytest.approx(120**2 - 110**2) and len(frame_poly.interiors) == 1
        assert l.area == pytest.approx(120**2 - 110**2 + 99 * 16 + 24)
