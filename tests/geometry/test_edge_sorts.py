"""A mesh read sorts its edges once (issue #30: three sorts of the 3 M edges of the bench vase's
1,008,000 triangles): `edge_report_twins` gives what `edge_report` and `edge_twins` give."""

import numpy as np
import pytest
import trimesh

from waamflow.geometry import mesh_io, topology


@pytest.mark.parametrize("path", ["graphs/parts/bracket.stl", "graphs/parts/duct.stl", "graphs/parts/cross.stl"])
def test_report_and_twins_from_one_sort_equal_the_two_calls(path):
    m = trimesh.load(path, force="mesh")
    faces, n = np.asarray(m.faces, np.int64), len(m.vertices)
    rep, twin = topology.edge_report_twins(faces, n)
    assert rep == topology.edge_report(faces, n) and rep.closed and rep.edges == len(faces) * 3 // 2
    assert np.array_equal(twin, topology.edge_twins(faces, n))
    opened = faces[1:]  # a face less: 3 open edges, no twins
    rep2, twin2 = topology.edge_report_twins(opened, n)
    assert rep2 == topology.edge_report(opened, n) and rep2.open == 3 and twin2 is None
    assert topology.edge_report_twins(faces[:0], n) == (topology.EdgeReport(0, 0, 0, 0), None)


def test_a_closed_mesh_read_sorts_its_edges_once(monkeypatch):
    calls = []
    sort = topology._edge_sort

    def counted(faces, n):
        calls.append(len(faces))
        return sort(faces, n)

    monkeypatch.setattr(topology, "_edge_sort", counted)
    with open("graphs/parts/duct.stl", "rb") as fh:
        data = fh.read()
    stats: dict = {}
    md = mesh_io.load_mesh_bytes(
        data, "duct.stl", require_closed=False, weld_tolerance=0.001, stats=stats, crack_tolerance=0.01
    )
    assert calls == [len(md.faces)] and stats["edges"].closed and stats["faces_rewound"] == 0


def _sorts_and_components(monkeypatch):
    from waamflow.slicing import planar

    calls = []
    sort, comps = topology._edge_sort, topology.face_components

    def counted(faces, n):
        calls.append("edges")
        return sort(faces, n)

    def counted_comps(twin, m):
        calls.append("bodies")
        return comps(twin, m)

    monkeypatch.setattr(topology, "_edge_sort", counted)
    monkeypatch.setattr(mesh_io, "face_components", counted_comps)
    monkeypatch.setattr(planar, "face_components", counted_comps)
    return calls


@pytest.mark.parametrize("path", ["graphs/parts/duct.stl", "graphs/parts/cross.stl"])
def test_read_then_slice_sorts_edges_and_labels_bodies_once(path, monkeypatch):
    """The slicer takes the twins and bodies the mesh read worked out (geometry/topology.py
    `remember_topology`): one edge sort and one body labelling for read + slice, the same loops."""
    from waamflow.slicing.planar import section_loops

    with open(path, "rb") as fh:
        data = fh.read()
    calls = _sorts_and_components(monkeypatch)
    md = mesh_io.load_mesh_bytes(data, path, require_closed=False, crack_tolerance=0.01)
    z0, z1 = md.vertices[:, 2].min(), md.vertices[:, 2].max()
    heights = np.linspace(z0 + 0.5, z1 - 0.5, 17)
    got = section_loops(md.vertices, md.faces, heights)
    assert calls == ["edges", "bodies"]
    assert topology.take_topology(md.faces) is None  # taken once: a second slicer works it out again
    ref = section_loops(md.vertices, md.faces.copy(), heights)
    assert calls == ["edges", "bodies", "edges", "bodies"]
    assert len(got) == len(ref) >= 17 and np.array_equal(got.coords, ref.coords)
    assert np.array_equal(got.offsets, ref.offsets) and np.array_equal(got.plane, ref.plane)
    assert np.array_equal(got.body, ref.body) and np.array_equal(got.void, ref.void)


def test_faces_turned_inside_out_by_the_repair_are_not_remembered():
    """A body wound inside out is flipped after its twins were found: those twins are not its."""
    m = trimesh.creation.box(extents=(10, 20, 30))
    tri = np.asarray(m.vertices)[np.asarray(m.faces)[:, ::-1]]  # every face inside out
    stats: dict = {}
    md = mesh_io.mesh_from_triangles(tri, crack_tolerance=0.01, stats=stats)
    assert stats["volume_mm3"] == pytest.approx(6000.0) and topology.take_topology(md.faces) is None
    good = mesh_io.mesh_from_triangles(np.asarray(m.vertices)[np.asarray(m.faces)], crack_tolerance=0.01)
    twin, bodies = topology.take_topology(good.faces)
    assert np.array_equal(twin, topology.edge_twins(good.faces, len(good.vertices))) and bodies[0] == 1


def test_only_the_last_meshes_read_keep_their_topology():
    m = trimesh.creation.box(extents=(10, 20, 30))
    tri = np.asarray(m.vertices)[np.asarray(m.faces)]
    meshes = [mesh_io.mesh_from_triangles(tri + k, crack_tolerance=0.01) for k in range(5)]
    kept = [topology.take_topology(md.faces) is not None for md in meshes]
    assert kept == [False] * (5 - topology.KEEP_TOPOLOGIES) + [True] * topology.KEEP_TOPOLOGIES


def test_bodies_numbered_by_their_lowest_face_as_scipy_numbers_a_coo_graph():
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    parts = [trimesh.creation.box(extents=(5, 5, 5)), trimesh.creation.icosphere(2), trimesh.creation.box()]
    faces, off = [], 0
    for k, p in enumerate(parts):
        faces.append(np.asarray(p.faces) + off)
        off += len(p.vertices)
    faces = np.vstack(faces)[np.random.default_rng(2).permutation(sum(len(p.faces) for p in parts))]
    twin = topology.edge_twins(faces, off)
    n, label = topology.face_components(twin, len(faces))
    m = len(faces)
    g = coo_matrix((np.ones(3 * m), (np.repeat(np.arange(m), 3), twin // 3)), shape=(m, m)).tocsr()
    n_ref, ref = connected_components(g, directed=False)
    assert n == n_ref == 3 and np.array_equal(label, ref) and label[0] == 0
    assert sorted(np.bincount(label).tolist()) == sorted(len(p.faces) for p in parts)


def _closed_and_broken_meshes():
    """(name, faces, vertex count): closed parts, inside out, one face flipped, open,
    non-manifold, a doubled surface, and two degenerate faces added."""
    out = []
    for name, m in (("box", trimesh.creation.box()), ("ico", trimesh.creation.icosphere(2))):
        f, n = np.asarray(m.faces, np.int64), len(m.vertices)
        flipped = f.copy()
        flipped[3] = flipped[3, ::-1]
        out += [
            (name, f, n),
            (name + " inside out", f[:, ::-1].copy(), n),
            (name + " one face flipped", flipped, n),
            (name + " open", f[1:], n),
            (name + " non-manifold", np.vstack([f, f[:2]]), n),
            (name + " doubled", np.vstack([f, f[:, ::-1]]), n),
            (name + " degenerate faces", np.vstack([f, [[0, 0, 1], [1, 0, 0]]]), n),
        ]
    return out


def test_a_closed_mesh_reports_from_its_edge_pairs(monkeypatch):
    """Every edge used twice: the report comes from the pairs (no run-length count of the 3 M
    sorted edges) and the twins are not checked again when every pair runs both ways; each
    mesh gives what `edge_report` and `edge_twins` give, closed or not."""
    cases = _closed_and_broken_meshes()
    want = [(topology.edge_report(f, n), topology.edge_twins(f, n)) for _, f, n in cases]
    paired = [r.open == 0 and r.nonmanifold == 0 for r, _ in want]  # every edge used twice
    assert [r.closed for r, _ in want].count(True) == 4 and paired.count(True) == 6
    real = topology._report
    calls = []

    def counted(*a):
        calls.append(1)
        return real(*a)

    monkeypatch.setattr(topology, "_report", counted)
    for (name, f, n), (rep, twin) in zip(cases, want):
        got_rep, got_twin = topology.edge_report_twins(f, n)
        assert got_rep == rep, name
        assert (got_twin is None) == (twin is None) and (twin is None or np.array_equal(got_twin, twin)), name
    assert len(calls) == paired.count(False) == 8  # closed, inside out, one face flipped: no count


def test_merge_vertices_hashes_float32_rows_and_survives_any_hash(monkeypatch):
    """float32 rows are hashed as (x, y) bits in one uint64 and z (`_point_hash`); whatever the
    hash, even one that makes every point collide (the exact lexicographic path), the result
    is the same: vertices in order of first occurrence, -0.0 welded to 0.0."""
    rng = np.random.default_rng(4)
    for dtype in (np.float32, np.float64):
        pts = (rng.integers(-3, 3, size=(6000, 3)) * 0.5).astype(dtype)
        pts[rng.random(pts.shape) < 0.1] = -0.0
        folded = pts + dtype(0.0)
        _, first, inv_ref = np.unique(folded, axis=0, return_index=True, return_inverse=True)
        order = np.argsort(first)  # unique rows in order of first occurrence
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        for label, fortran in (("C", False), ("F", True)):
            v, inv = topology.merge_vertices(np.asfortranarray(pts) if fortran else pts)
            assert v.dtype == dtype and len(v) == len(first) == 216, (dtype, label)
            np.testing.assert_array_equal(v, folded[np.sort(first)])
            np.testing.assert_array_equal(inv, rank[inv_ref.reshape(-1)])
            assert not (np.signbit(v) & (v == 0)).any()  # no -0.0 left
        monkeypatch.setattr(topology, "_point_hash", lambda f, b: np.zeros(len(b), dtype=np.uint64))
        v2, inv2 = topology.merge_vertices(pts)
        monkeypatch.undo()
        np.testing.assert_array_equal(v2, v)
        np.testing.assert_array_equal(inv2, inv)


def test_a_closed_mesh_read_works_out_its_face_volumes_once(monkeypatch):
    """The repair's per-face volumes (for each body's sign) give the part's volume too when the
    vertices are not moved (mm, no transform): the same float64 sum signed_volume gives, one
    pass over 1 M faces less; a scaled or moved part is measured again."""
    m = trimesh.creation.icosphere(3, radius=20.0)
    tri = np.asarray(m.vertices)[np.asarray(m.faces)].astype(np.float32)
    calls = []
    real = topology.face_volumes

    def counted(v, f):
        calls.append(len(f))
        return real(v, f)

    monkeypatch.setattr(topology, "face_volumes", counted)
    monkeypatch.setattr(mesh_io, "face_volumes", counted)
    stats: dict = {}
    md = mesh_io.mesh_from_triangles(tri, crack_tolerance=0.01, stats=stats)
    assert calls == [len(md.faces)] == [1280]
    volume = real(md.vertices, md.faces).sum()  # the icosphere's facets: 33,222 of a sphere's 33,510 mm³
    assert stats["volume_mm3"] == volume == pytest.approx(33221.93, abs=0.01)
    assert "face_volumes" not in stats
    for kw in ({"units": "cm"}, {"transform": mesh_io.Transform(translate=(1.0, 2.0, 3.0))}):
        calls.clear()
        st2: dict = {}
        md2 = mesh_io.mesh_from_triangles(tri, crack_tolerance=0.01, stats=st2, **kw)
        assert len(calls) == 2 and st2["volume_mm3"] == real(md2.vertices, md2.faces).sum()


def test_merge_vertices_takes_an_stls_corner_view_as_it_is():
    """A binary STL's corners are an (m, 3, 3) view with a 50-byte record stride: welded as its
    3m rows without copying them into (3m, 3) first, the same vertices and inverse."""
    m = trimesh.creation.icosphere(2)
    raw = trimesh.exchange.stl.export_stl(m)
    corners = mesh_io.binary_stl_triangles(raw)
    assert corners.shape == (320, 3, 3) and corners.strides[0] == 50 and not corners.flags.c_contiguous
    v, inv = topology.merge_vertices(corners)
    v2, inv2 = topology.merge_vertices(np.ascontiguousarray(corners).reshape(-1, 3))
    assert len(v) == 162 and inv.shape == (960,)
    np.testing.assert_array_equal(v, v2)
    np.testing.assert_array_equal(inv, inv2)
    np.testing.assert_array_equal(v[inv], corners.reshape(-1, 3))
