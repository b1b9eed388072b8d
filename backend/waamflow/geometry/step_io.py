"""STEP and IGES parts through OpenCascade (`cadquery-ocp`, module OCP): B-rep → triangles.

The reader converts the file's length unit to millimetres itself (OCC's `xstep.cascade.unit`
is mm); the file's declared unit is reported. Every solid (or, without solids, every shell) of
the file is tessellated with `BRepMesh_IncrementalMesh` at `chordal_tolerance` (mm, the maximum
distance between the B-rep surface and its triangles) and a 0.5 rad angular limit; faces with
reversed orientation get their triangles flipped, so normals point out of the solid. Several
solids (an assembly, or a multi-body part) stay separate bodies in one mesh; `StepResult.solids`
says how many, the node warns that an assembly was flattened.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import PurePosixPath

import numpy as np

from ..core.errors import InputFileError
from .through_file import read_through_file

CAD_FORMATS = ("step", "stp", "iges", "igs")


@dataclass(frozen=True)
class StepResult:
    """triangles: (m, 3, 3) float64 mm. solids: bodies found. roots: top-level shapes (> 1:
    an assembly or several parts). file_unit: the length unit the file declares (or None)."""

    triangles: np.ndarray
    solids: int
    roots: int
    file_unit: str | None


_OCC_UNITS = {"MM": "mm", "MILLIMETRE": "mm", "CM": "cm", "CENTIMETRE": "cm", "M": "m", "METRE": "m",
              "INCH": "in", "IN": "in", "FT": "ft", "FOOT": "ft", "UM": "um", "MICROMETRE": "um"}


def is_cad_file(filename: str) -> bool:
    return PurePosixPath(filename).suffix.lower().lstrip(".") in CAD_FORMATS


def _read_shape(data: bytes, filename: str):
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.IGESControl import IGESControl_Reader
    from OCP.STEPControl import STEPControl_Reader
    from OCP.OCP.collections import Sequence_TCollection_AsciiString

    ext = PurePosixPath(filename).suffix.lower().lstrip(".")
    step = ext in ("step", "stp")
    reader = STEPControl_Reader() if step else IGESControl_Reader()
    status = read_through_file(data, "." + ext, reader.ReadFile)   # OCC readers take a path
    if status != IFSelect_RetDone:
        raise InputFileError(f"{filename}: not a readable {'STEP' if step else 'IGES'} file (OpenCascade status {int(status)})")
    file_unit = None
    if step:
        lengths, angles, solid = (Sequence_TCollection_AsciiString() for _ in range(3))
        reader.FileUnits(lengths, angles, solid)
        if lengths.Length() >= 1:
            file_unit = _OCC_UNITS.get(lengths.Value(1).ToCString().upper())
    else:
        from .units import IGES_UNIT_FLAGS

        gs = reader.Model().GlobalSection()
        flag = int(gs.UnitFlag())
        uname = gs.UnitName().ToCString() if gs.UnitName() is not None else ""
        file_unit = IGES_UNIT_FLAGS.get(flag) or _OCC_UNITS.get(uname.strip().upper().replace("2H", ""))
    roots = reader.TransferRoots()
    if roots == 0 or reader.NbShapes() == 0:
        raise InputFileError(f"{filename}: the file holds no shape OpenCascade can transfer")
    return reader.OneShape(), int(reader.NbShapes()), file_unit


def _bodies(shape):
    from OCP.TopAbs import TopAbs_SHELL, TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer

    out = []
    for kind in (TopAbs_SOLID, TopAbs_SHELL):
        exp = TopExp_Explorer(shape, kind)
        while exp.More():
            out.append(exp.Current())
            exp.Next()
        if out:
            return out
    return [shape]


def _triangles(body) -> np.ndarray:
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    tris = []
    exp = TopExp_Explorer(body, TopAbs_FACE)
    while exp.More():
        face = TopoDS.Face(exp.Current())
        loc = TopLoc_Location()
        tri = BRep_Tool.Triangulation_s(face, loc)
        exp.Next()
        if tri is None:
            continue
        trsf = loc.Transformation()
        nodes = np.array([[p.X(), p.Y(), p.Z()] for p in
                          (tri.Node(i).Transformed(trsf) for i in range(1, tri.NbNodes() + 1))])
        idx = np.array([tri.Triangle(i).Get() for i in range(1, tri.NbTriangles() + 1)], dtype=np.int64) - 1
        if face.Orientation() == TopAbs_REVERSED:
            idx = idx[:, ::-1]
        tris.append(nodes[idx])
    return np.concatenate(tris) if tris else np.zeros((0, 3, 3))


def read_cad_triangles(data: bytes, filename: str, *, chordal_tolerance: float = 0.05,
                       angular_tolerance: float = 0.5) -> StepResult:
    """Triangles (mm) of every solid of a STEP/IGES file, tessellated within chordal_tolerance (mm)."""
    try:
        from OCP.BRepMesh import BRepMesh_IncrementalMesh
    except ImportError as exc:  # pragma: no cover - dependency declared in pyproject
        raise InputFileError(f"{filename}: STEP/IGES input needs the 'cadquery-ocp-novtk' package") from exc
    if not chordal_tolerance > 0:
        raise InputFileError(f"{filename}: chordal_tolerance must be > 0 mm (got {chordal_tolerance})")
    shape, roots, file_unit = _read_shape(data, filename)
    BRepMesh_IncrementalMesh(shape, chordal_tolerance, False, angular_tolerance, True)
    bodies = _bodies(shape)
    tri = np.concatenate([_triangles(b) for b in bodies])
    if len(tri) == 0:
        raise InputFileError(f"{filename}: no faces to tessellate (wireframe or empty model)")
    return StepResult(triangles=tri, solids=len(bodies), roots=roots, file_unit=file_unit)


def load_cad_bytes(data: bytes, filename: str, *, units: str = "file", chordal_tolerance: float = 0.05,
                   transform=None, weld_tolerance: float = 0.0):
    """(MeshData in mm, StepResult, notice) of a STEP/IGES file. OpenCascade converts the declared
    unit (STEP length unit, IGES global unit flag) to mm; units "file" or the declared unit keep
    that conversion (exactly once), another unit reinterprets the file's numbers (an override,
    said in the notice; `units.conversion_notice`)."""
    from .mesh_io import mesh_from_triangles
    from .transform import Transform, unit_scale
    from .units import conversion_notice

    res = read_cad_triangles(data, filename, chordal_tolerance=chordal_tolerance)
    tri = res.triangles
    applied, factor, notice = conversion_notice(res.file_unit, units)
    if applied != (res.file_unit or "mm"):
        tri = tri / unit_scale(res.file_unit or "mm") * factor
    mesh = mesh_from_triangles(tri, name=PurePosixPath(filename).stem, units="mm",
                               transform=transform or Transform(), source=filename, weld_tolerance=weld_tolerance)
    return mesh, res, notice
