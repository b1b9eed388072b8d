"""#24 fault 2: one unit rule for every format — the file's own unit is read and converted to mm
exactly once, `units` overrides it deliberately (with a notice), every conversion is reported.
Files generated here with OpenCascade (IGES, STEP), ezdxf (DXF) and a plain XML zip (3MF)."""

import io

import ezdxf
import numpy as np
import pytest

from tests.geometry.package3mf import package_3mf
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.geometry.transform import unit_scale
from waamflow.geometry.units import DXF_INSUNITS, threemf_units


def _run(tmp_path, node):
    recipe = {"format": "waamflow/1", "name": "t", "nodes": [node], "edges": []}
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))


def _extent(mesh):
    return np.asarray(mesh.bounds[1]) - np.asarray(mesh.bounds[0])


def _cad_box(path, unit: str):
    """A 60 × 40 × 30 mm box written by OpenCascade in `unit` (the file's numbers are in it)."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.IGESControl import IGESControl_Writer
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    box = BRepPrimAPI_MakeBox(60.0, 40.0, 30.0).Shape()
    if path.suffix == ".igs":
        w = IGESControl_Writer(unit, 1)
        w.AddShape(box)
        w.ComputeModel()
        assert w.Write(str(path))
    else:
        w = STEPControl_Writer()  # (the constructor resets write.step.unit)
        Interface_Static.SetCVal_s("write.step.unit", unit)
        try:
            w.Transfer(box, STEPControl_AsIs)
            w.Write(str(path))
        finally:
            Interface_Static.SetCVal_s("write.step.unit", "MM")


@pytest.mark.parametrize("name", ["b.igs", "b.step"])
def test_inch_cad_file_is_converted_once_and_reported(tmp_path, name):
    _cad_box(tmp_path / name, "INCH")
    for units in ("file", "in"):  # 'in' agrees with the file: converted once, not twice
        res = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": name, "units": units}})
        assert _extent(res.outputs["m"]["mesh"]) == pytest.approx([60, 40, 30], rel=1e-6)
        assert res.stats["m"].report["file_unit"] == "in" and res.stats["m"].report["unit_factor"] == 25.4
        assert any("file unit inch → mm ×25.4" in w["message"] for w in res.warnings)
    # 'mm' on an inch file is a deliberate override: the file's numbers read as mm, said so
    res = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": name, "units": "mm"}})
    assert _extent(res.outputs["m"]["mesh"]) == pytest.approx(np.array([60, 40, 30]) / 25.4, rel=1e-6)
    assert any("overrides the file unit inch" in w["message"] for w in res.warnings)


@pytest.mark.parametrize(
    "code,mm", [(10, 914.4), (14, 100.0), (7, 1e6), (9, 0.0254), (8, 25.4e-6), (3, 1609344.0), (21, 1200 / 3937 * 1000)]
)
def test_dxf_insunits_full_table(tmp_path, code, mm):
    # a drawing 1 unit across, or 0.001 for the km and the mile (1 km is over MAX_PART_MM: refused)
    d = 1.0 if mm < 1e5 else 1e-3
    doc = ezdxf.new("R2010", units=code)
    doc.modelspace().add_lwpolyline([(0, 0), (d, 0), (d, d)])
    buf = io.StringIO()
    doc.write(buf)
    (tmp_path / "p.dxf").write_text(buf.getvalue())
    res = _run(tmp_path, {"id": "sk", "type": "sketch", "params": {"path": "p.dxf", "height": 30}})
    xy = np.vstack(res.outputs["sk"]["mesh"].curves)
    assert xy.max(axis=0) - xy.min(axis=0) == pytest.approx([mm * d, mm * d], rel=1e-9)
    assert res.stats["sk"].report["unit_factor"] == pytest.approx(mm, rel=1e-12)
    assert any("file unit" in w["message"] and f"×{mm:g}" in w["message"] for w in res.warnings)


def test_dxf_unit_table_agrees_with_ezdxf():
    meter = ezdxf.units.METER_FACTOR
    for code, name in DXF_INSUNITS.items():
        if code < len(meter) and meter[code] is not None:
            # ezdxf rounds the light year (9.46e15 m) and the parsec (3.09e16 m) to 3 digits; ours
            # are the IAU values (9 460 730 472 580 800 m; 648 000/π au): compared to 3 digits there
            rel = 2e-3 if name in ("ly", "pc") else 1e-8
            assert unit_scale(name) == pytest.approx(1000.0 / meter[code], rel=rel), name
    assert set(DXF_INSUNITS) == set(range(1, 25))


def _threemf(unit: str, pad: int) -> bytes:
    v = np.array([[0, 0, 0], [2, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    f = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]
    verts = "".join(f'<vertex x="{x:g}" y="{y:g}" z="{z:g}"/>' for x, y, z in v)
    tris = "".join(f'<triangle v1="{a}" v2="{b}" v3="{c}"/>' for a, b, c in f)
    model = (
        '<?xml version="1.0" encoding="UTF-8"?>\n<!-- ' + "x" * pad + " -->\n"
        f'<model unit="{unit}" xml:lang="en-US" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02">'
        f'<resources><object id="1" type="model"><mesh><vertices>{verts}</vertices><triangles>{tris}</triangles>'
        '</mesh></object></resources><build><item objectid="1"/></build></model>'
    )
    return package_3mf({"3D/3dmodel.model": model})


def test_3mf_unit_after_the_first_4_kb_is_read(tmp_path):
    data = _threemf("inch", pad=6000)
    assert threemf_units(data) == "in"
    (tmp_path / "t.3mf").write_bytes(data)
    res = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "t.3mf"}})
    assert _extent(res.outputs["m"]["mesh"]) == pytest.approx([50.8, 25.4, 25.4], rel=1e-9)
    assert any("file unit inch → mm ×25.4" in w["message"] for w in res.warnings)
    assert threemf_units(_threemf("millimeter", pad=6000)) == "mm"
