"""Tolerant welding, helpful open-mesh errors and content sniffing — meshes generated here."""

import numpy as np
import pytest
import trimesh

from waamflow.core.errors import InputFileError
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.geometry.mesh_io import load_mesh_bytes
from waamflow.geometry.topology import edge_report


def _run(tmp_path, node):
    recipe = {"format": "waamflow/1", "name": "t", "nodes": [node], "edges": []}
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))


def _seam_gap_stl(gap: float) -> tuple[bytes, trimesh.Trimesh]:
    """A closed cylinder whose triangles touching the seam plane x > 0, y = 0 have the seam
    vertices moved by `gap` mm on one side (an exporter's seam that does not quite meet)."""
    cyl = trimesh.creation.cylinder(radius=30, height=40, sections=48)
    tri = np.asarray(cyl.triangles).copy()
    on_seam = (np.abs(tri[:, :, 1]) < 1e-9) & (tri[:, :, 0] > 1)
    centroid_y = tri[:, :, 1].mean(axis=1)
    below = on_seam & (centroid_y[:, None] < 0)                 # corners of faces just below the seam
    tri[below, 1] -= gap
    soup = trimesh.Trimesh(tri.reshape(-1, 3), np.arange(len(tri) * 3).reshape(-1, 3), process=False)
    return trimesh.exchange.stl.export_stl(soup), cyl


def test_seam_gap_stl_welds_by_default_and_is_reported(tmp_path):
    data, cyl = _seam_gap_stl(2e-4)
    (tmp_path / "seam.stl").write_bytes(data)
    with pytest.raises(InputFileError, match="6 open edges"):
        load_mesh_bytes(data, "seam.stl")                               # weld_tolerance 0: bit-exact only
    # the node's default tolerance (0.001 mm) closes it and says how many vertices it merged
    out = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "seam.stl"}})
    mesh = out.outputs["m"]["mesh"]
    assert edge_report(mesh.faces, len(mesh.vertices)).closed
    assert len(mesh.vertices) == len(cyl.vertices)
    assert mesh.bounds[1] - mesh.bounds[0] == pytest.approx([60, 60, 40], abs=1e-3)
    assert any("welded 2 vertices" in w["message"] and "weld_tolerance" in w["message"] for w in out.warnings)


def test_open_mesh_error_suggests_weld_tolerance(tmp_path):
    data, _ = _seam_gap_stl(0.05)                                        # a real 0.05 mm gap
    (tmp_path / "seam.stl").write_bytes(data)
    with pytest.raises(InputFileError, match=r"open edges.*'weld_tolerance'") as err:
        _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "seam.stl"}})
    assert err.value.node == "m"
    out = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "seam.stl", "weld_tolerance": 0.1}})
    mesh = out.outputs["m"]["mesh"]
    assert edge_report(mesh.faces, len(mesh.vertices)).closed


def test_binary_stl_named_obj_is_read_by_content(tmp_path):
    box = trimesh.creation.box(extents=(30, 20, 10))
    (tmp_path / "part.obj").write_bytes(trimesh.exchange.stl.export_stl(box))
    out = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "part.obj"}})
    mesh = out.outputs["m"]["mesh"]
    assert len(mesh.faces) == 12
    assert mesh.bounds[1] - mesh.bounds[0] == pytest.approx([30, 20, 10])
