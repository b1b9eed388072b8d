"""preflight/planecut.py gives what trimesh gives, bit for bit (issue #30): the plane sections
(`mesh_plane`) of parts cut between vertices, through vertices and along edges, and the merged
endpoints (`grouping.unique_rows`) of section points, of rows that fit trimesh's packed integer
hash and of rows it sorts as bytes, with many ties."""

import numpy as np
import pytest
import trimesh
from trimesh import grouping
from trimesh.constants import tol_path

from waamflow.preflight import planecut
from waamflow.preflight.slabs import plane_faces

PARTS = ["graphs/parts/bracket.stl", "graphs/parts/duct.stl", "graphs/parts/curved_bracket.stl"]


def _trimesh_section(vertices, faces, z):
    """What slabs.py did: trimesh's mesh_plane on a slab mesh of the faces, renumbered."""
    used, local = np.unique(faces, return_inverse=True)
    slab = trimesh.Trimesh(vertices[used], np.asarray(local).reshape((-1, 3)), process=False, validate=False)
    return trimesh.intersections.mesh_plane(slab, [0.0, 0.0, 1.0], [0.0, 0.0, z])


def _same_rows(points):
    index, inverse = grouping.unique_rows(points, digits=tol_path.merge_digits)
    got_index, got_inverse = planecut.unique_rows(points)
    assert np.array_equal(got_index, index)
    assert np.array_equal(got_inverse, np.asarray(inverse).ravel())
    return len(index)


@pytest.mark.parametrize("path", PARTS)
def test_sections_and_merged_points_equal_trimesh(path):
    mesh = trimesh.load(path, force="mesh")
    v, f = np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)
    z0, z1 = mesh.bounds[:, 2]
    zs = list(np.linspace(z0 + 0.1, z1 - 0.1, 29)) + sorted({float(z) for z in v[::97, 2]})[:12]
    per_plane = plane_faces(v, f, zs)
    segments = 0
    for z, pf in zip(zs, per_plane):
        ref = _trimesh_section(v, f[pf], z)
        got = planecut.plane_segments(v, f[pf], z)
        assert got.shape == ref.shape and got.dtype == ref.dtype
        assert got.tobytes() == np.asarray(ref).tobytes()
        if len(got):
            assert _same_rows(got.reshape(-1, 3)) > 2
        segments += len(got)
    assert segments > 200


def test_box_cut_at_its_vertices_and_along_its_edges():
    """Every case of mesh_plane: between vertices, a vertex on the plane (the box's triangulated
    side faces have their diagonal's corner on z = 0 planes of a rotated box), an edge on it."""
    box = trimesh.creation.box(extents=(40, 30, 10))
    tilted = box.copy()
    tilted.apply_transform(trimesh.transformations.rotation_matrix(0.3, [1, 1, 0]))
    cases = 0
    for mesh in (box, tilted):
        v, f = np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)
        for z in sorted({*v[:, 2].tolist(), 0.0, 1.234}):
            ref = trimesh.intersections.mesh_plane(mesh, [0.0, 0.0, 1.0], [0.0, 0.0, z])
            got = planecut.plane_segments(v, f, z)
            assert got.tobytes() == np.asarray(ref).tobytes() and got.shape == np.asarray(ref).shape
            cases += len(got) > 0
    assert cases >= 6


def test_merged_rows_equal_trimesh_with_ties_both_hash_kinds():
    rng = np.random.default_rng(11)
    packed = void = 0
    for trial in range(400):
        n = int(rng.integers(1, 400))
        cols = int(rng.integers(2, 4))
        scale = [1e-3, 1.0, 50.0, 1e4, 3e6][trial % 5]  # large values: rows sorted as bytes
        pts = rng.integers(-4, 4, size=(n, cols)) * scale
        pts[rng.random(n) < 0.3] *= -1
        pts += rng.choice([0.0, 2e-6, 1e-7], size=pts.shape)  # within and beyond the 1e-5 merge
        pts = np.vstack([pts, pts[rng.integers(0, n, n // 2)]])  # exact repeats
        void += grouping.hashable_rows(pts, digits=5).dtype.kind == "V"
        packed += grouping.hashable_rows(pts, digits=5).dtype.kind != "V"
        _same_rows(pts)
    assert packed > 100 and void > 100


def test_symmetric_ring_points_share_coordinates():
    """A ring's section points, mirrored: every x twice with two y (and each point three times)."""
    t = np.linspace(0, 2 * np.pi, 2001)[:-1]
    ring = np.column_stack([77.0 * np.cos(t), 77.0 * np.sin(t), np.full(len(t), 50.25)])
    assert _same_rows(np.vstack([ring, ring[::-1], ring * [1, -1, 1]])) == 2000


def test_rows_the_lead_key_cannot_tell_apart_are_sorted_by_all_bytes():
    """Rows whose first 8 distinguishing bytes agree (x's 8 bytes, y differing) tie in the lead
    key: the lexsort of those runs gives numpy's byte order."""
    rng = np.random.default_rng(5)
    x = rng.choice(rng.integers(-(2**62), 2**62, size=7), size=3000)
    y = 12345 + 65536 * rng.integers(0, 4, size=3000)
    as_int = np.column_stack([x, y, np.full(3000, 5025000)]).astype(np.int64)
    keys, lead = planecut._row_keys(as_int)
    assert len(np.unique(lead)) < len(np.unique(keys, axis=0))  # the lead key ties rows that differ
    order, ks = planecut._lex_order(keys, lead)
    ref = np.argsort(np.ascontiguousarray(as_int).view(np.dtype((np.void, 24))).ravel(), kind="stable")
    assert np.array_equal(order, ref)
    assert np.array_equal(ks, keys[ref])


def test_loops_are_walked_by_core_graphs_even_where_scipy_is_loaded(monkeypatch):
    """The slab tasks' loops (check._chain_loops) are always core.graphs' walks, scipy's
    depth-first orders (tests/core/test_graphs.py): with the sort-free neighbours and placement they
    beat scipy's own (the bench vase's 133 planes: 1.04 against 1.25 s, its import aside)."""
    import scipy.sparse.csgraph  # noqa: F401

    from waamflow.core import graphs
    from waamflow.preflight import check

    t = np.linspace(0, 2 * np.pi, 801)[:-1]
    rings = []
    for r in (80.0, 74.0, 20.0):
        p = np.column_stack([r * np.cos(t) + 3.0, r * np.sin(t), np.full(len(t), 5.25)])
        rings.append(np.stack([p, np.roll(p, -1, axis=0)], axis=1))
    segs = np.concatenate(rings)[np.random.default_rng(1).permutation(3 * len(t))]
    calls = []
    real = graphs.cycle_walks
    monkeypatch.setattr(graphs, "cycle_walks", lambda n, e: calls.append(n) or real(n, e))
    loops = check._chain_loops(segs)
    assert calls == [2400] and [len(x) for x in loops] == [801, 801, 801]
    assert all(np.array_equal(x[0], x[-1]) for x in loops)
