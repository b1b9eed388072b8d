"""The preflight's fast paths give what the library calls they replaced give (issue #30: the
preflight of a 1,008,000-triangle vase). Sections: our loop chaining against trimesh's
`load_path`; distances: the contains-first shortcut against shapely's distance of every point;
the part volume against trimesh's mass properties."""

import numpy as np
import pytest
import shapely
import trimesh

from waamflow.preflight import check
from waamflow.preflight.outside import distance_to_section

PARTS = ["graphs/parts/bracket.stl", "graphs/parts/duct.stl", "graphs/parts/curved_bracket.stl"]


def _by_trimesh(mesh, z):
    segs = trimesh.intersections.mesh_plane(mesh, [0, 0, 1.0], [0, 0, z])
    return check._loops_to_geom(trimesh.load_path(segs).discrete) if len(segs) else shapely.MultiPolygon()


@pytest.mark.parametrize("path", PARTS)
def test_sections_equal_trimesh_load_path(path):
    mesh = trimesh.load(path, force="mesh")
    z0, z1 = mesh.bounds[:, 2]
    zs = list(np.linspace(z0 + 0.3, z1 - 0.3, 23))
    ours = check._multiplane_sections(mesh, zs)
    areas = []
    for z, got in zip(zs, ours):
        ref = _by_trimesh(mesh, z)
        assert got.area == pytest.approx(ref.area, rel=1e-12, abs=1e-9)
        assert got.symmetric_difference(ref).area < 1e-9
        areas.append(got.area)
    assert sum(a > 0 for a in areas) == len(zs)


def test_a_plane_through_vertices_and_nested_loops_fall_back_or_chain_right():
    """A box with a square hole (nested loops: even-odd gives the ring) cut exactly at a vertex
    height (vertices on the plane: the fallback) and between."""
    outer = trimesh.creation.box(extents=(40, 30, 10))
    hole = trimesh.creation.box(extents=(10, 8, 12))
    ring = outer.difference(hole, engine="manifold")
    for z in (0.0, 2.5, 5.0):  # 5.0: the top face (every top vertex on the plane)
        ref = _by_trimesh(ring, z)
        got = check._multiplane_sections(ring, [z])[0]
        assert got.area == pytest.approx(ref.area, abs=1e-9)
    assert check._multiplane_sections(ring, [2.5])[0].area == pytest.approx(40 * 30 - 10 * 8, rel=1e-12)


def test_distance_shortcut_equals_shapely_distance():
    rng = np.random.default_rng(3)
    section = shapely.Polygon([(0, 0), (50, 0), (50, 20), (0, 20)], [[(10, 5), (20, 5), (20, 15), (10, 15)]])
    pts = np.column_stack([rng.uniform(-10, 60, 4000), rng.uniform(-10, 30, 4000), np.zeros(4000)])
    pts[:4] = [(0, 0, 0), (50, 10, 0), (15, 10, 0), (10, 7, 0)]  # a corner, an edge, in the hole, on the hole
    got = distance_to_section(section, pts)
    ref = shapely.distance(section, shapely.points(pts[:, :2]))
    assert np.array_equal(got, ref)
    assert got[2] == pytest.approx(5.0) and got[0] == got[1] == got[3] == 0.0
    assert (got == 0).sum() > 1000 and (got > 0).sum() > 1000


@pytest.mark.parametrize("path", PARTS)
def test_part_volume_equals_trimesh(path):
    from waamflow.geometry.mesh_io import load_mesh_bytes

    with open(path, "rb") as f:
        md = load_mesh_bytes(f.read(), path)
    ref = abs(trimesh.Trimesh(md.vertices, md.faces, process=False).volume)
    part = check.Part("solid", "part", vertices=md.vertices, faces=md.faces)
    got = check.coverage_planar(part, [], 4.0, check.Report("post", "gcode"))["part_volume_mm3"]
    assert got == pytest.approx(ref, rel=1e-12)
