"""Units declared by files (DXF $INSUNITS, 3MF unit), size plausibility, placement, MINSERT,
content-detected binary STL and the weld hint; files generated here with ezdxf / trimesh."""

import io
import re
import zipfile

import ezdxf
import numpy as np
import pytest
import trimesh

from waamflow.core.errors import InputFileError
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.geometry import load_mesh_bytes, load_sketch_bytes
from waamflow.geometry.units import implausible_size, placement_offset, threemf_units


def _run(tmp_path, node):
    recipe = {"format": "waamflow/1", "name": "t", "nodes": [node], "edges": []}
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))


def _dxf(units: int, build) -> bytes:
    doc = ezdxf.new("R2010", units=units)
    build(doc)
    buf = io.StringIO()
    doc.write(buf)
    return buf.getvalue().encode()


def _rect(doc, w=4.0, h=2.0):
    doc.modelspace().add_lwpolyline([(0, 0), (w, 0), (w, h), (0, h)], close=True)


def _extent(mid) -> np.ndarray:
    pts = np.vstack(mid.curves)
    return pts.max(axis=0) - pts.min(axis=0)


@pytest.mark.parametrize("code,mm", [(1, 25.4), (6, 1000.0), (4, 1.0), (5, 10.0)])
def test_dxf_insunits_scale_the_sketch(code, mm):
    res = load_sketch_bytes(_dxf(code, _rect), "r.dxf", height=10, units="file")
    assert _extent(res.midsurface) == pytest.approx([4.0 * mm, 2.0 * mm], abs=0.1)
    # an explicit unit overrides the file's
    res = load_sketch_bytes(_dxf(code, _rect), "r.dxf", height=10, units="mm")
    assert _extent(res.midsurface) == pytest.approx([4.0, 2.0], abs=0.1)


def test_sketch_node_reads_inch_dxf_and_warns_on_metre_giant(tmp_path):
    (tmp_path / "in.dxf").write_bytes(_dxf(1, _rect))
    res = _run(tmp_path, {"id": "sk", "type": "sketch", "params": {"path": "in.dxf", "height": 20}})
    assert _extent(res.outputs["sk"]["mesh"]) == pytest.approx([101.6, 50.8], abs=0.1)
    assert any("file unit inch → mm ×25.4" in w["message"] for w in res.warnings)
    (tmp_path / "m.dxf").write_bytes(_dxf(6, lambda d: _rect(d, 40, 2)))  # 40 m: a typo in units
    res = _run(tmp_path, {"id": "sk", "type": "sketch", "params": {"path": "m.dxf", "height": 20}})
    assert _extent(res.outputs["sk"]["mesh"])[0] == pytest.approx(40_000.0, abs=0.1)
    assert any("40 m across" in w["message"] and "'units'" in w["message"] for w in res.warnings)


def test_minsert_5x5_gives_25_copies():
    def build(doc):
        blk = doc.blocks.new("CELL")
        blk.add_lwpolyline([(0, 0), (10, 0), (10, 10), (0, 10)], close=True)
        ins = doc.modelspace().add_blockref("CELL", (100, 200))
        ins.grid(size=(5, 5), spacing=(20, 30))  # 5 rows × 5 columns

    mid = load_sketch_bytes(_dxf(4, build), "grid.dxf", height=5, units="file").midsurface
    assert len(mid.curves) == 25
    pts = np.vstack(mid.curves)
    assert pts.min(axis=0) == pytest.approx([100, 200], abs=0.1)
    assert pts.max(axis=0) == pytest.approx([100 + 4 * 30 + 10, 200 + 4 * 20 + 10], abs=0.1)


def test_hatch_only_dxf_says_what_was_skipped():
    def build(doc):
        h = doc.modelspace().add_hatch()
        h.paths.add_polyline_path([(0, 0), (10, 0), (10, 10)], is_closed=True)

    with pytest.raises(InputFileError, match=r"no curves.*1 HATCH"):
        load_sketch_bytes(_dxf(4, build), "h.dxf", height=5, units="file")


def _threemf_with_unit(tm: trimesh.Trimesh, unit: str) -> bytes:
    src = zipfile.ZipFile(io.BytesIO(tm.export(file_type="3mf")))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        for n in src.namelist():
            data = src.read(n)
            if n.lower().endswith(".model"):
                text = re.sub(r'\sunit="[a-z]+"', "", data.decode())
                data = re.sub(r"<model\b", f'<model unit="{unit}"', text, count=1).encode()
            z.writestr(n, data)
    return out.getvalue()


def test_3mf_in_inch(tmp_path):
    box = trimesh.creation.box(extents=(2, 1, 0.5))  # inches
    data = _threemf_with_unit(box, "inch")
    assert threemf_units(data) == "in"
    mesh = load_mesh_bytes(data, "b.3mf", units="file")
    assert mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0) == pytest.approx([50.8, 25.4, 12.7], abs=0.1)
    (tmp_path / "b.3mf").write_bytes(data)
    res = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "b.3mf", "placement": "on_plate"}})
    v = res.outputs["m"]["mesh"].vertices
    assert v.min(axis=0)[2] == pytest.approx(0.0, abs=1e-9)
    assert v.max(axis=0) == pytest.approx([25.4, 12.7, 12.7], abs=0.1)
    msgs = " | ".join(w["message"] for w in res.warnings)
    assert "file unit inch → mm ×25.4" in msgs and "placed by translate (0.000, 0.000, 6.350) mm" in msgs


def test_placement_modes_and_plausibility():
    lo, hi = np.array([10.0, 20.0, -27.6]), np.array([30.0, 60.0, -7.6])
    assert placement_offset(lo, hi, "as_is") == pytest.approx([0, 0, 0])
    assert placement_offset(lo, hi, "on_plate") == pytest.approx([0, 0, 27.6])
    assert placement_offset(lo, hi, "centred") == pytest.approx([-20, -40, 27.6])
    assert implausible_size(20.0) is None and implausible_size(4999.0) is None
    assert "units" in implausible_size(0.02) and "units" in implausible_size(20_000.0)


def test_cube_centred_on_plate(tmp_path):
    cube = trimesh.creation.box(extents=(20, 20, 20))  # centred on the origin: z −10..10
    cube.apply_translation([5, -3, -17.6])
    cube.export(tmp_path / "c.stl")
    res = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "c.stl", "placement": "centred"}})
    v = res.outputs["m"]["mesh"].vertices
    assert v.min(axis=0) == pytest.approx([-10, -10, 0], abs=1e-6)
    assert v.max(axis=0) == pytest.approx([10, 10, 20], abs=1e-6)


def test_binary_stl_named_obj_is_read_by_content():
    tube = trimesh.creation.annulus(r_min=5, r_max=12, height=10, sections=48)
    mesh = load_mesh_bytes(tube.export(file_type="stl"), "really_an_stl.obj")
    assert len(mesh.faces) == 384


def test_seam_gap_error_names_weld_tolerance():
    box = trimesh.creation.box(extents=(30, 30, 30))
    tri = np.asarray(box.triangles, dtype=np.float64).copy()
    tri[0, 0] += 2e-4  # a 0.2 µm crack at one corner
    data = trimesh.Trimesh(**trimesh.triangles.to_kwargs(tri), process=False).export(file_type="stl")
    with pytest.raises(InputFileError, match="weld_tolerance"):
        load_mesh_bytes(data, "seam.stl")
    mesh = load_mesh_bytes(data, "seam.stl", weld_tolerance=0.01)
    assert mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0) == pytest.approx([30, 30, 30], abs=0.1)


def test_binary_dxf_and_layouts(tmp_path):
    import os
    import tempfile

    doc = ezdxf.new("R2010", units=1)  # inch
    doc.modelspace().add_lwpolyline([(0, 0), (2, 0), (2, 1)])
    lay = doc.layouts.new("Sheet A")
    lay.add_circle((0, 0), radius=1.0)
    fd, path = tempfile.mkstemp(suffix=".dxf")
    os.close(fd)
    try:
        doc.saveas(path, fmt="bin")
        data = open(path, "rb").read()
    finally:
        os.unlink(path)
    assert data.startswith(b"AutoCAD Binary DXF")
    mid = load_sketch_bytes(data, "b.dxf", height=5, units="file").midsurface
    assert _extent(mid) == pytest.approx([50.8, 25.4], abs=0.1)
    mid = load_sketch_bytes(data, "b.dxf", height=5, units="file", layout="sheet a", arc_tolerance=0.001).midsurface
    assert _extent(mid) == pytest.approx([50.8, 50.8], abs=0.1)
    with pytest.raises(InputFileError, match=r"no layout 'Sheet B'.*Sheet A"):
        load_sketch_bytes(data, "b.dxf", height=5, layout="Sheet B")


def test_paperspace_only_drawing_points_to_the_layout():
    def build(doc):
        doc.layouts.new("Plan").add_line((0, 0), (50, 0))

    with pytest.raises(InputFileError, match=r"no curves in layout 'Model'.*Plan \(1 entities\).*'layout'"):
        load_sketch_bytes(_dxf(4, build), "p.dxf", height=5)


def test_a_part_larger_than_any_cell_is_refused_before_it_is_planned(tmp_path):
    """A wall 1e9 mm long in a sketch (a unit slip, or a fuzzer) was planned: the run grew to 23.7 GB
    and was killed by the kernel (1 km: 3 GB, 60 s). A part over MAX_PART_MM across is an input error
    naming its size and the units; 40 m (above) is still a warning only."""
    import json

    from waamflow.core.errors import RecipeError
    from waamflow.geometry.units import MAX_PART_MM

    assert MAX_PART_MM == 100_000.0
    for name, far in (("km.json", 1e6), ("huge.json", 1e9)):
        (tmp_path / name).write_text(json.dumps({"curves": [[[0, 0], [100, 0]], [[0, 10], [far, 10]]]}))
        with pytest.raises(
            RecipeError, match=re.escape(f"part is {far / 1000:.3g} m across, more than the 100 m")
        ) as err:
            _run(tmp_path, {"id": "sk", "type": "sketch", "params": {"path": name, "height": 20}})
        assert err.value.node == "sk" and err.value.field == "units"
    cube = trimesh.creation.box(extents=(200, 200, 200))
    cube.export(tmp_path / "c.stl")
    with pytest.raises(RecipeError, match=r"part is 200 m across"):  # 200 mm read as metres
        _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "c.stl", "units": "m"}})
