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
