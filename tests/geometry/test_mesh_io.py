import numpy as np
import pytest
import trimesh

from tests.geometry.package3mf import package_3mf
from waamflow.core.errors import InputFileError
from waamflow.geometry import MeshLimits, Transform, edge_report, load_mesh_bytes, merge_vertices
from waamflow.geometry.mesh_io import STL_RECORD, read_triangles
from waamflow.geometry.topology import signed_volume


def _part() -> trimesh.Trimesh:
    """A tube r 5/12 mm, 10 mm high, 48 facets: 384 triangles on 192 shared vertices."""
    outer = trimesh.creation.annulus(r_min=5, r_max=12, height=10, sections=48)
    outer.apply_translation([0, 0, 5])
    return outer


def _export(tm: trimesh.Trimesh, fmt: str) -> bytes:
    if fmt == "stl_ascii":
        return trimesh.exchange.stl.export_stl_ascii(tm).encode()
    out = tm.export(file_type=fmt)
    return out.encode() if isinstance(out, str) else out


@pytest.mark.parametrize(
    "fmt,name",
    [("stl", "p.stl"), ("stl_ascii", "p.stl"), ("obj", "p.obj"), ("ply", "p.ply"), ("off", "p.off"), ("3mf", "p.3mf")],
)
def test_formats_load_the_same_mesh(fmt, name):
    tm = _part()
    mesh = load_mesh_bytes(_export(tm, fmt), name)
    assert len(mesh.faces) == len(tm.faces) == 384
    assert len(mesh.vertices) == len(tm.vertices) == 192
    assert signed_volume(mesh.vertices, mesh.faces) == pytest.approx(tm.volume, rel=1e-6)
    np.testing.assert_allclose(mesh.bounds, tm.bounds, atol=1e-5)
    assert mesh.name == "p"
    assert edge_report(mesh.faces, len(mesh.vertices)).closed


def test_binary_stl_fast_path_welds_corners():
    tm = _part()
    data = _export(tm, "stl")
    assert len(data) == 84 + 50 * len(tm.faces)
    mesh = load_mesh_bytes(data, "p.stl")
    assert mesh.vertices.dtype == np.float64 and mesh.faces.dtype == np.int64
    np.testing.assert_allclose(mesh.vertices[mesh.faces], np.asarray(tm.triangles), atol=1e-5)


def test_units_and_transform():
    tm = trimesh.creation.box(extents=(1, 2, 3))
    tm.apply_translation(-tm.bounds[0])
    data = _export(tm, "stl")
    m = load_mesh_bytes(data, "b.stl", units="in")
    np.testing.assert_allclose(m.bounds[1] - m.bounds[0], [25.4, 50.8, 76.2], rtol=1e-6)
    m = load_mesh_bytes(
        data, "b.stl", units="cm", transform=Transform(translate=(0, 0, 100), rotate_deg=(90, 0, 0), scale=2)
    )
    # (x, y, z) → 20·(x, −z, y) + (0, 0, 100) for a quarter turn about x
    np.testing.assert_allclose(m.bounds, [[0, -60, 100], [20, 0, 140]], atol=1e-9)
    assert signed_volume(m.vertices, m.faces) == pytest.approx(6 * 20**3)


def test_inside_out_mesh_is_flipped_outwards():
    tm = _part()
    tm.invert()
    m = load_mesh_bytes(_export(tm, "stl"), "inv.stl")
    assert signed_volume(m.vertices, m.faces) == pytest.approx(-tm.volume, rel=1e-6) and -tm.volume > 0


def test_open_mesh_refused_with_edge_count():
    tm = _part()
    tm.update_faces(np.arange(1, len(tm.faces)))
    with pytest.raises(InputFileError, match=r"not closed.*3 open edges"):
        load_mesh_bytes(_export(tm, "stl"), "open.stl")


def test_flipped_face_reported_as_inconsistent_winding():
    tm = _part()
    faces = tm.faces.copy()
    faces[0] = faces[0, ::-1]
    bad = trimesh.Trimesh(tm.vertices, faces, process=False)
    with pytest.raises(InputFileError, match=r"3 edges with inconsistent face winding"):
        load_mesh_bytes(_export(bad, "stl"), "flip.stl")


def test_off_with_quad_faces_comments_and_colours_is_triangulated():
    """OFF (Princeton/CGAL's format; trimesh's models/whitespace.off was refused as unsupported):
    a 20 mm cube of 6 quads with a comment and per-face colours is 12 triangles, 8000 mm³."""
    v = [(x, y, z) for z in (0, 20) for y in (0, 20) for x in (0, 20)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    text = "OFF # a cube\n8 6 12\n" + "".join(f"{x} {y} {z}\n" for x, y, z in v)
    text += "".join(f"4 {a} {b} {c} {d} 1.0 0.0 0.0 0.75\n" for a, b, c, d in quads)
    mesh = load_mesh_bytes(text.encode(), "cube.off")
    assert len(mesh.faces) == 12 and len(mesh.vertices) == 8
    assert abs(signed_volume(mesh.vertices, mesh.faces)) == pytest.approx(8000.0)
    np.testing.assert_allclose(mesh.bounds, [[0, 0, 0], [20, 20, 20]])


def test_empty_and_malformed_files():
    empty = b"x" * 80 + np.uint32(0).tobytes()
    with pytest.raises(InputFileError, match="e.stl: mesh is empty"):
        load_mesh_bytes(empty, "e.stl")
    with pytest.raises(InputFileError, match="header says 5 triangles"):
        load_mesh_bytes(b"y" * 80 + np.uint32(5).tobytes() + b"z" * 100, "t.stl")
    with pytest.raises(InputFileError, match="unsupported mesh format"):
        load_mesh_bytes(b"abc", "part.step")
    with pytest.raises(InputFileError, match="bad.obj: mesh is empty"):
        load_mesh_bytes(b"\xff\xfe\x00garbage", "bad.obj")


def test_caps():
    data = _export(_part(), "stl")
    with pytest.raises(InputFileError, match="384 triangles exceed the cap of 100"):
        load_mesh_bytes(data, "p.stl", limits=MeshLimits(max_triangles=100))
    with pytest.raises(InputFileError, match="exceeds the cap"):
        load_mesh_bytes(data, "p.stl", limits=MeshLimits(max_bytes=1000))


def test_merge_vertices_exact_and_signed_zero():
    pts = np.array([[0.0, 0, 0], [1, 2, 3], [-0.0, 0, 0], [1, 2, 3.0000000001], [1, 2, 3]])
    v, inv = merge_vertices(pts)
    assert len(v) == 3
    assert inv[0] == inv[2] and inv[1] == inv[4] and inv[3] != inv[1]
    np.testing.assert_array_equal(v[inv], pts + 0.0)


def test_merge_vertices_random_soup_matches_numpy_unique():
    rng = np.random.default_rng(1)
    base = rng.normal(size=(5000, 3)).astype(np.float32)
    pts = base[rng.integers(0, 5000, 60000)]
    v, inv = merge_vertices(pts)
    assert len(v) == len(np.unique(pts, axis=0))
    np.testing.assert_array_equal(v[inv], pts)


def test_binary_stl_record_layout():
    rec = np.zeros(1, dtype=STL_RECORD)
    rec["corners"] = [[[1, 2, 3], [4, 5, 6], [7, 8, 9]]]
    raw = rec.tobytes()
    assert len(raw) == 50
    assert np.frombuffer(raw[12:48], "<f4").tolist() == list(range(1, 10))


def test_weld_tolerance_closes_rounding_cracks():
    tm = _part()
    tri = np.asarray(tm.triangles).copy()
    rng = np.random.default_rng(3)
    tri += rng.uniform(-2e-6, 2e-6, tri.shape)  # every corner written slightly differently
    noisy = trimesh.Trimesh(tri.reshape(-1, 3), np.arange(len(tri) * 3).reshape(-1, 3), process=False)
    data = _export(noisy, "stl")
    with pytest.raises(InputFileError, match="open edges"):
        load_mesh_bytes(data, "noisy.stl")
    # vertices on open edges within 1e-3 mm merge: all copies of a corner become one
    m = load_mesh_bytes(data, "noisy.stl", weld_tolerance=1e-3)
    assert len(m.vertices) == 192 and len(m.faces) == 384
    assert signed_volume(m.vertices, m.faces) == pytest.approx(tm.volume, rel=1e-4)  # corners moved ≤ 0.9 µm


def test_ascii_stl_fast_parser_multi_solid_uppercase_and_fallback():
    from waamflow.geometry.mesh_io import ascii_stl_triangles

    text = (
        b"SOLID part1\n  FACET NORMAL 0 0 1E+0\n    OUTER LOOP\n\tVERTEX 0 0 0\n VERTEX 1.5e1 0 0\n"
        b" VERTEX 0 1 0\n ENDLOOP\n ENDFACET\nENDSOLID part1\nsolid b2\nfacet normal 0 0 1\nouter loop\n"
        b"vertex 0 0 -2.5E-1\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid b2\n"
    )
    tri = ascii_stl_triangles(text)
    np.testing.assert_array_equal(tri, [[[0, 0, 0], [15, 0, 0], [0, 1, 0]], [[0, 0, -0.25], [1, 0, 0], [0, 1, 0]]])
    nan_file = (
        b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 nan\nvertex 1 0 0\nvertex 0 1 0\n"
        b"endloop\nendfacet\nendsolid x\n"
    )
    assert ascii_stl_triangles(nan_file) is None
    # the fast path refuses it; trimesh reads it and the NaN is reported
    with pytest.raises(InputFileError, match="non-finite"):
        load_mesh_bytes(nan_file, "nan.stl")


def _production_3mf(transforms: list[str]) -> bytes:
    """A 3MF of the production extension: the root model's build items name their objects in
    other model parts (`p:path`), as 3MF Consortium's cube_gears_prod_req.3mf does."""
    cube = trimesh.creation.box((10, 10, 10))
    cube.apply_translation((5, 5, 5))
    verts = "".join(f'<vertex x="{x}" y="{y}" z="{z}"/>' for x, y, z in cube.vertices)
    tris = "".join(f'<triangle v1="{a}" v2="{b}" v3="{c}"/>' for a, b, c in cube.faces)
    core = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
    prod = "http://schemas.microsoft.com/3dmanufacturing/production/2015/06"
    part = (
        f'<?xml version="1.0" encoding="UTF-8"?><model xmlns="{core}" unit="millimeter"><resources>'
        f'<object id="1" type="model"><mesh><vertices>{verts}</vertices><triangles>{tris}</triangles>'
        "</mesh></object></resources><build/></model>"
    )
    items = "".join(
        f'<item objectid="1" p:path="/3D/Objects/cube_{i}.model" transform="{t}"/>' for i, t in enumerate(transforms)
    )
    root = (
        f'<?xml version="1.0" encoding="UTF-8"?><model xmlns="{core}" xmlns:p="{prod}" unit="millimeter" '
        f'requiredextensions="p"><resources/><build>{items}</build></model>'
    )
    parts = {"3D/3dmodel.model": root}
    parts.update({f"3D/Objects/cube_{i}.model": part for i in range(len(transforms))})
    return package_3mf(parts)


def test_3mf_build_items_in_other_model_parts_are_read():
    """3MF Consortium's cube_gears_prod_req.3mf (production extension): every build item names its
    object in another model part (p:path); trimesh reads such components but not such items, and
    the mesh node said "mesh is empty (no triangles)" of a file of 17 parts."""
    data = _production_3mf(["1 0 0 0 1 0 0 0 1 0 0 0", "1 0 0 0 1 0 0 0 1 30 0 0"])
    tri = read_triangles(data, "p.3mf")
    assert tri.shape == (24, 3, 3)
    assert tri[:, :, 0].min() == pytest.approx(0.0) and tri[:, :, 0].max() == pytest.approx(40.0)
    assert tri[:, :, 2].max() == pytest.approx(10.0)
