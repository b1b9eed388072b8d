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
