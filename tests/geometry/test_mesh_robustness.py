"""Tolerant welding, helpful open-mesh errors and content sniffing — meshes generated here."""

import json

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
    below = on_seam & (centroid_y[:, None] < 0)  # corners of faces just below the seam
    tri[below, 1] -= gap
    soup = trimesh.Trimesh(tri.reshape(-1, 3), np.arange(len(tri) * 3).reshape(-1, 3), process=False)
    return trimesh.exchange.stl.export_stl(soup), cyl


def test_seam_gap_stl_welds_by_default_and_is_reported(tmp_path):
    data, cyl = _seam_gap_stl(2e-4)
    (tmp_path / "seam.stl").write_bytes(data)
    with pytest.raises(InputFileError, match="6 open edges"):
        load_mesh_bytes(data, "seam.stl")  # weld_tolerance 0: bit-exact only
    # the node's default tolerance (0.001 mm) closes it and says how many vertices it merged
    out = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "seam.stl"}})
    mesh = out.outputs["m"]["mesh"]
    assert edge_report(mesh.faces, len(mesh.vertices)).closed
    assert len(mesh.vertices) == len(cyl.vertices)
    assert mesh.bounds[1] - mesh.bounds[0] == pytest.approx([60, 60, 40], abs=1e-3)
    assert any("welded 2 vertices" in w["message"] and "weld_tolerance" in w["message"] for w in out.warnings)


def test_open_mesh_error_suggests_crack_tolerance(tmp_path):
    # #24: a real 0.05 mm seam gap in a closed cylinder is a crack, closed by the default
    # crack_tolerance (0.1 mm): a solid (it used to be read as an open surface in 'auto')
    data, cyl = _seam_gap_stl(0.05)
    (tmp_path / "seam.stl").write_bytes(data)
    out = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "seam.stl"}})
    mesh = out.outputs["m"]["mesh"]
    assert not mesh.surface and edge_report(mesh.faces, len(mesh.vertices)).closed
    assert len(mesh.vertices) == len(cyl.vertices)
    assert out.stats["m"].report["vertices_merged"] == 2
    # without crack closing, 'solid' refuses it with the open-edge count and the parameter to raise
    with pytest.raises(InputFileError, match=r"6 open edges.*'crack_tolerance'") as err:
        _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "seam.stl", "as": "solid", "crack_tolerance": 0}})
    assert err.value.node == "m"
    auto = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "seam.stl", "crack_tolerance": 0}})
    assert auto.outputs["m"]["mesh"].surface  # open, said so
    assert any("crack_tolerance" in w["message"] and "surface" in w["message"] for w in auto.warnings)


def test_binary_stl_named_obj_is_read_by_content(tmp_path):
    box = trimesh.creation.box(extents=(30, 20, 10))
    (tmp_path / "part.obj").write_bytes(trimesh.exchange.stl.export_stl(box))
    out = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "part.obj"}})
    mesh = out.outputs["m"]["mesh"]
    assert len(mesh.faces) == 12
    assert mesh.bounds[1] - mesh.bounds[0] == pytest.approx([30, 20, 10])


def _tube(tmp_path, name="tube.stl"):
    """An open tube: a 48-sided cylinder r 30, z −20..20 without its caps (a single-wall surface)."""
    cyl = trimesh.creation.cylinder(radius=30, height=40, sections=48)
    side = np.abs(cyl.face_normals[:, 2]) < 0.5
    tube = trimesh.Trimesh(cyl.vertices, cyl.faces[side], process=False)
    tube.export(tmp_path / name)
    return tube


def _slice_recipe(extra_mesh=None, with_features=False):
    nodes = [
        {"id": "m", "type": "mesh", "params": {"path": "tube.stl", "placement": "on_plate", **(extra_mesh or {})}},
        {"id": "layers", "type": "slice", "params": {"layer_height": 2.0}},
    ]
    edges = [{"from": "m.mesh", "to": "layers.mesh"}]
    if with_features:
        nodes += [
            {"id": "features", "type": "features", "params": {}},
            {"id": "walls", "type": "wall-path", "params": {"speed": 10.0}},
        ]
        edges += [
            {"from": "layers.layers", "to": "features.layers"},
            {"from": "layers.layers", "to": "walls.layers"},
            {"from": "features.features", "to": "walls.features"},
        ]
    return {"format": "waamflow/1", "name": "t", "nodes": nodes, "edges": edges}


def test_open_tube_surface_gives_one_closed_curve_per_layer(tmp_path):
    _tube(tmp_path)
    res = execute(build_graph(parse_recipe(_slice_recipe(with_features=True))), resolver=FileResolver(tmp_path))
    assert any("single-wall surface" in w["message"] for w in res.warnings)  # auto → surface, said so
    assert res.outputs["m"]["mesh"].surface
    layers = res.outputs["layers"]["layers"]
    assert len(layers) == 20
    circumference = 2 * np.pi * 30
    for layer in layers:
        assert len(layer.curves) == 1 and layer.curves[0].is_closed and layer.region.is_empty
        assert layer.curves[0].length == pytest.approx(circumference, rel=0.005)
    feats = json.loads(res.artifacts["features.features.json"])["features"]
    assert {f["kind"] for f in feats} == {"tubular"}  # no ends, no junctions: one closed wall
    assert all(f["length_mm"] == pytest.approx(circumference, rel=0.005) for f in feats)
    tp = json.loads(res.artifacts["walls.toolpath.json"])
    assert len(tp["layers"]) == 20
    # 'as': 'solid' refuses it with the open-edge count
    with pytest.raises(InputFileError, match="96 open edges"):
        execute(build_graph(parse_recipe(_slice_recipe({"as": "solid"}))), resolver=FileResolver(tmp_path))


def test_open_surface_strip_gives_open_curves(tmp_path):
    # an L-shaped single wall: two rectangles sharing an edge, 0..50 mm in x, then 0..30 in y, 10 mm tall
    v = np.array([[0, 0, 0], [50, 0, 0], [50, 30, 0], [0, 0, 10], [50, 0, 10], [50, 30, 10]], float)
    f = np.array([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]])
    trimesh.Trimesh(v, f, process=False).export(tmp_path / "tube.stl")
    res = execute(build_graph(parse_recipe(_slice_recipe({"as": "surface"}))), resolver=FileResolver(tmp_path))
    layers = res.outputs["layers"]["layers"]
    assert len(layers) == 5
    for layer in layers:
        assert len(layer.curves) == 1 and not layer.curves[0].is_closed
        assert layer.curves[0].length == pytest.approx(80.0)


def test_open_tube_surface_sizes_to_a_tenth_of_a_millimetre(tmp_path):
    """#14 done-when: the open tube (48-gon, r 30, 40 mm tall) placed on the plate slices to curves
    of the right size: 60 × 60 mm across, the 48-gon's perimeter, layers up to 40 mm."""
    _tube(tmp_path)
    res = execute(build_graph(parse_recipe(_slice_recipe())), resolver=FileResolver(tmp_path))
    layers = res.outputs["layers"]["layers"]
    perimeter = 48 * 2 * 30 * np.sin(np.pi / 48)
    for layer in layers:
        xy = np.asarray(layer.curves[0].coords)
        assert xy.max(axis=0) - xy.min(axis=0) == pytest.approx([60.0, 60.0], abs=0.1)
        assert layer.curves[0].length == pytest.approx(perimeter, abs=0.1)
    assert [round(layer.z, 1) for layer in layers] == [2.0 * (k + 1) for k in range(20)]
    assert any("placed by translate (0.000, 0.000, 20.000) mm" in w["message"] for w in res.warnings)
