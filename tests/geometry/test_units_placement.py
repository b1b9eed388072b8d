"""Units from the file (DXF $INSUNITS, 3MF unit attribute), the units override, size warnings and
placement of mesh parts — with files generated here."""

import io
import zipfile

import ezdxf
import numpy as np
import pytest
import trimesh

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.geometry.mesh_io import load_mesh, threemf_units
from waamflow.geometry.sketch import load_sketch_bytes


def _run(tmp_path, node):
    recipe = {"format": "waamflow/1", "name": "t", "nodes": [node], "edges": []}
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))


def _rect_dxf(w, h, units: int) -> bytes:
    doc = ezdxf.new("R2010", units=units)
    doc.modelspace().add_lwpolyline([(0, 0), (w, 0), (w, h), (0, h)], close=True)
    buf = io.StringIO()
    doc.write(buf)
    return buf.getvalue().encode()


def _extent(mid):
    pts = np.vstack(mid.curves)
    return pts.max(axis=0) - pts.min(axis=0)


def test_dxf_units_from_insunits_inch_and_metre():
    res = load_sketch_bytes(_rect_dxf(4, 2, units=1), "in.dxf", height=10)          # 4 × 2 in
    assert (res.units, res.units_from) == ("in", "file")
    assert _extent(res.midsurface) == pytest.approx([101.6, 50.8], abs=0.1)
    res = load_sketch_bytes(_rect_dxf(0.3, 0.12, units=6), "m.dxf", height=10)      # 0.3 × 0.12 m
    assert (res.units, res.units_from) == ("m", "file")
    assert _extent(res.midsurface) == pytest.approx([300.0, 120.0], abs=0.1)
    assert res.notes == ()
    # the param overrides the file, and says so
    res = load_sketch_bytes(_rect_dxf(300, 120, units=6), "m.dxf", height=10, units="mm")
    assert _extent(res.midsurface) == pytest.approx([300.0, 120.0], abs=0.1)
    assert any("overrides" in n for n in res.notes)
    # unitless drawing → mm
    res = load_sketch_bytes(_rect_dxf(300, 120, units=0), "u.dxf", height=10)
    assert (res.units, res.units_from) == ("mm", "default")


def test_implausible_size_warns_through_the_node(tmp_path):
    (tmp_path / "big.dxf").write_bytes(_rect_dxf(300, 120, units=6))      # 300 m: a unit mistake
    res = _run(tmp_path, {"id": "sk", "type": "sketch", "params": {"path": "big.dxf", "height": 20}})
    msgs = [w["message"] for w in res.warnings]
    assert any("implausibly large" in m and "'units'" in m for m in msgs)
    res = _run(tmp_path, {"id": "sk", "type": "sketch", "params": {"path": "big.dxf", "height": 20, "units": "mm"}})
    assert _extent(res.outputs["sk"]["mesh"]) == pytest.approx([300.0, 120.0], abs=0.1)
    assert not any("implausibly" in w["message"] for w in res.warnings)


def _threemf(mesh: trimesh.Trimesh, unit: str) -> bytes:
    data = trimesh.exchange.threemf.export_3MF(mesh)
    src = zipfile.ZipFile(io.BytesIO(data))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        for n in src.namelist():
            b = src.read(n)
            if n.endswith(".model"):
                b = b.replace(b'unit="millimeter"', f'unit="{unit}"'.encode())
            z.writestr(n, b)
    return out.getvalue()


def test_3mf_in_inch():
    box = trimesh.creation.box(extents=(2.0, 1.0, 0.5))                  # inches
    data = _threemf(box, "inch")
    assert threemf_units(data) == "in"
    res = load_mesh(data, "part.3mf")
    assert (res.units, res.units_from) == ("in", "file")
    ext = res.mesh.bounds[1] - res.mesh.bounds[0]
    assert ext == pytest.approx([50.8, 25.4, 12.7], abs=0.1)
    res = load_mesh(_threemf(box, "millimeter"), "part.3mf", units="in")     # override
    assert (res.mesh.bounds[1] - res.mesh.bounds[0]) == pytest.approx([50.8, 25.4, 12.7], abs=0.1)
    assert res.units_from == "param" and any("overrides" in n for n in res.notes)


def test_cube_placed_on_build_plate_and_centred(tmp_path):
    cube = trimesh.creation.box(extents=(20, 20, 20))
    cube.apply_translation((50, -30, -7))
    cube.export(tmp_path / "c.stl")
    res = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "c.stl", "placement": "build_plate"}})
    lo, hi = res.outputs["m"]["mesh"].bounds
    assert lo[2] == pytest.approx(0.0, abs=1e-9) and hi[2] == pytest.approx(20.0)
    assert lo[0] == pytest.approx(40.0) and lo[1] == pytest.approx(-40.0)              # x, y kept
    assert any("translated by (0.000, 0.000, 17.000) mm" in w["message"] for w in res.warnings)
    res = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "c.stl", "placement": "centred"}})
    lo, hi = res.outputs["m"]["mesh"].bounds
    assert lo == pytest.approx([-10, -10, 0]) and hi == pytest.approx([10, 10, 20])
    res = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "c.stl"}})          # as_is
    assert res.outputs["m"]["mesh"].bounds[0] == pytest.approx([40, -40, -17])
    assert res.warnings == []


def test_tiny_mesh_warns(tmp_path):
    trimesh.creation.box(extents=(0.02, 0.02, 0.02)).export(tmp_path / "t.stl")   # 20 mm cube saved in m
    res = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "t.stl"}})
    assert any("implausibly small" in w["message"] for w in res.warnings)
    res = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "t.stl", "units": "m"}})
    lo, hi = res.outputs["m"]["mesh"].bounds
    assert hi - lo == pytest.approx([20, 20, 20], abs=1e-6)
    assert res.warnings == []
