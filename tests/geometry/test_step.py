"""STEP/IGES in through OpenCascade: files written here with the same library (OCP)."""

import math
import os
import tempfile

import numpy as np
import pytest


from OCP.BRep import BRep_Builder  # noqa: E402
from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut  # noqa: E402
from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder  # noqa: E402
from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt  # noqa: E402
from OCP.IGESControl import IGESControl_Writer  # noqa: E402
from OCP.Interface import Interface_Static  # noqa: E402
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer  # noqa: E402
from OCP.TopoDS import TopoDS_Compound  # noqa: E402

from waamflow.core.errors import InputFileError  # noqa: E402
from waamflow.engine.executor import FileResolver, execute  # noqa: E402
from waamflow.engine.graph import build_graph  # noqa: E402
from waamflow.engine.recipe import parse_recipe  # noqa: E402
from waamflow.geometry.step_io import load_cad_bytes  # noqa: E402
from waamflow.geometry.topology import face_components, edge_twins, signed_volume  # noqa: E402


def _box_with_hole():
    """40 × 30 × 20 mm block with a Ø10 mm through hole at (20, 15): V = 24000 − 500π mm³."""
    box = BRepPrimAPI_MakeBox(40, 30, 20).Shape()
    cyl = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(20, 15, -1), gp_Dir(0, 0, 1)), 5, 22).Shape()
    return BRepAlgoAPI_Cut(box, cyl).Shape()


def _step(shape, unit="MM") -> bytes:
    w = STEPControl_Writer()
    Interface_Static.SetCVal_s("write.step.unit", unit)
    w.Transfer(shape, STEPControl_AsIs)
    fd, path = tempfile.mkstemp(suffix=".step")
    os.close(fd)
    try:
        w.Write(path)
        return open(path, "rb").read()
    finally:
        os.unlink(path)
        Interface_Static.SetCVal_s("write.step.unit", "MM")


@pytest.mark.parametrize("unit", ["MM", "INCH"])
def test_step_box_with_hole_size_and_volume(unit):
    tol = 0.01
    mesh, res, _ = load_cad_bytes(_step(_box_with_hole(), unit), "block.step", chordal_tolerance=tol)
    assert res.solids == 1 and res.file_unit == ("mm" if unit == "MM" else "in")
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    assert lo == pytest.approx([0, 0, 0], abs=0.1) and hi == pytest.approx([40, 30, 20], abs=0.1)
    exact = 24000 - math.pi * 25 * 20
    # the inscribed polygon of the hole loses at most perimeter × tolerance of area per unit height
    v = signed_volume(mesh.vertices, mesh.faces)
    assert exact <= v <= exact + 2 * math.pi * 5 * tol * 20 + 1e-6
    # chordal tolerance governs the hole's facet count: sagitta r(1 − cos(π/n)) ≤ tol
    mesh_c, _, _ = load_cad_bytes(_step(_box_with_hole()), "block.step", chordal_tolerance=0.5)
    assert len(mesh_c.faces) < len(mesh.faces)


def test_step_units_override_reinterprets_numbers():
    mesh, _, _ = load_cad_bytes(_step(_box_with_hole(), "MM"), "block.step", units="in", chordal_tolerance=0.05)
    assert mesh.vertices.max(axis=0) == pytest.approx([40 * 25.4, 30 * 25.4, 20 * 25.4], abs=0.1)


def test_step_multibody_kept_and_flattening_warned(tmp_path):
    comp = TopoDS_Compound()
    b = BRep_Builder()
    b.MakeCompound(comp)
    b.Add(comp, BRepPrimAPI_MakeBox(10, 10, 10).Shape())
    b.Add(comp, BRepPrimAPI_MakeBox(gp_Pnt(30, 0, 0), 10, 20, 10).Shape())
    (tmp_path / "two.step").write_bytes(_step(comp))
    recipe = {
        "format": "waamflow/1",
        "name": "t",
        "edges": [],
        "nodes": [{"id": "m", "type": "mesh", "params": {"path": "two.step"}}],
    }
    res = execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    mesh = res.outputs["m"]["mesh"]
    n, _ = face_components(edge_twins(mesh.faces, len(mesh.vertices)), len(mesh.faces))
    assert n == 2
    assert signed_volume(mesh.vertices, mesh.faces) == pytest.approx(1000 + 2000, abs=1e-6)
    assert any("2 bodies flattened" in w["message"] for w in res.warnings)


def test_iges_and_garbage():
    w = IGESControl_Writer("MM", 0)
    w.AddShape(BRepPrimAPI_MakeBox(25, 15, 10).Shape())
    w.ComputeModel()
    fd, path = tempfile.mkstemp(suffix=".igs")
    os.close(fd)
    try:
        w.Write(path)
        data = open(path, "rb").read()
    finally:
        os.unlink(path)
    mesh, _, _ = load_cad_bytes(data, "b.igs")
    assert mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0) == pytest.approx([25, 15, 10], abs=0.1)
    with pytest.raises(InputFileError, match="not a readable STEP"):
        load_cad_bytes(b"ISO-10303-21; garbage", "x.step")
    assert np.isfinite(mesh.vertices).all()
