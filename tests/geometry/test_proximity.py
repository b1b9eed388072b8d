"""A few points against a mesh without an index (geometry/proximity.py): the same answers as
trimesh's r-tree based closest point and ray containment, on closed meshes of several shapes."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from waamflow.geometry.proximity import TriangleBoxes, inside_closed, near_surface, point_triangle_distance


def _meshes():
    box = trimesh.creation.box(extents=(40, 30, 20))
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=25.0)
    torus = trimesh.creation.torus(major_radius=30.0, minor_radius=8.0, major_sections=48, minor_sections=24)
    tube = trimesh.creation.annulus(r_min=34.0, r_max=40.0, height=30.0, sections=64)
    return {"box": box, "sphere": sphere, "torus": torus, "tube": tube}


@pytest.mark.parametrize("name", ["box", "sphere", "torus", "tube"])
def test_distance_and_inside_agree_with_trimesh(name):
    mesh = _meshes()[name]
    rng = np.random.default_rng(7)
    lo, hi = mesh.bounds
    pts = rng.uniform(lo - 5.0, hi + 5.0, size=(300, 3))
    # and points close to the surface, both sides: within and beyond a 0.5 mm tolerance
    surf, _ = trimesh.sample.sample_surface(mesh, 100, seed=3)
    normals = mesh.face_normals[trimesh.proximity.closest_point(mesh, surf)[2]]
    pts = np.vstack([pts, surf + 0.3 * normals, surf - 0.3 * normals, surf + 0.7 * normals])
    boxes = TriangleBoxes(mesh.vertices, mesh.faces)
    _c, dist, _t = trimesh.proximity.closest_point(mesh, pts)
    for k, p in enumerate(pts[:50]):
        assert float(point_triangle_distance(p, boxes.tri).min()) == pytest.approx(dist[k], abs=1e-9)
    assert (near_surface(boxes, pts, 0.5) == (dist <= 0.5)).all()
    assert (inside_closed(boxes, pts) == mesh.contains(pts)).all()
    assert 0 < inside_closed(boxes, pts).sum() < len(pts)


def test_a_point_on_an_axis_aligned_edge_line_is_judged_once():
    """A ray straight up from the box's centre line would run through the top face's diagonal
    edge: the leaning ray crosses one face, not two."""
    box = trimesh.creation.box(extents=(40, 30, 20))
    boxes = TriangleBoxes(box.vertices, box.faces)
    pts = np.array([[0.0, 0.0, 0.0], [20.0 - 1e-12, 0.0, 0.0], [0.0, 0.0, 10.5], [0.0, 0.0, -10.5]])
    assert inside_closed(boxes, pts).tolist() == [True, True, False, False]
    assert near_surface(boxes, pts, 0.5).tolist() == [False, True, True, True]


@pytest.mark.parametrize("kind", ["solid", "surface"])
def test_the_preflights_ignition_test_answers_as_trimesh_did(kind):
    """`preflight.deposit.in_part` (a 3D program's ignitions: in the part, or in stock) scans the
    triangles for a few points; the answer is trimesh's closest point + ray containment's."""
    from waamflow.preflight.check import Part
    from waamflow.preflight.deposit import STOCK_TOL_MM, in_part

    mesh = _meshes()["torus"]
    rng = np.random.default_rng(11)
    pts = rng.uniform(mesh.bounds[0] - 3.0, mesh.bounds[1] + 3.0, size=(120, 3))
    part = Part(kind, "part", vertices=np.asarray(mesh.vertices), faces=np.asarray(mesh.faces))
    _c, dist, _t = trimesh.proximity.closest_point(mesh, pts)
    want = dist <= STOCK_TOL_MM + 3.0 if kind == "surface" else mesh.contains(pts) | (dist <= STOCK_TOL_MM)
    got = in_part(part, pts, 6.0)
    assert (got == want).all() and 0 < got.sum() < len(pts)
