"""STEP and IGES parts through OpenCascade (`cadquery-ocp`, module OCP): B-rep → triangles, or
a midsurface's curves.

The reader converts the file's length unit to millimetres itself (OCC's `xstep.cascade.unit`
is mm); the file's declared unit is reported. Bodies are the file's solids, its shells outside
solids and its free faces (IGES 144 trimmed surfaces, 143 bounded surfaces). Each face is
tessellated on its own with `BRepMesh_IncrementalMesh` at `chordal_tolerance` (mm, the maximum
distance between the B-rep surface and its triangles) and a 0.5 rad angular limit, so a long
read reports progress and can be cancelled between faces (BRepMesh discretises a shared edge
once, so faces meshed one by one still meet without cracks); faces with reversed orientation
get their triangles flipped, so normals point out of the solid. The triangle count is estimated
first from two coarse tessellations and a tolerance that would exceed the caps (in all, or in one
face: `MAX_FACE_TRIANGLES`) is refused before the long run; the running count is checked after
every face.

Midsurfaces (thin-wall parts, the thin-walls study's input): an open surface whose faces are
all vertical walls between one bottom and one top height is the extrusion of its bottom edges
(`vertical_midsurface`), read as a sketch; a file of curves only (IGES 126 B-splines, 110
lines, 100 arcs) lying in one horizontal plane gives the sketch's curves (`planar_curves`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import PurePosixPath
from typing import Callable

import numpy as np

from ..core.errors import InputFileError
from .through_file import read_through_file

CAD_FORMATS = ("step", "stp", "iges", "igs")

ANGULAR_TOLERANCE = 0.5  # rad, BRepMesh's angular deflection limit
# Triangles one face may get: OpenCascade meshes a face in one call (no progress, no cancel) and
# its time grows faster than the count: a torus face (R 50, r 10 mm) took 2.8 s for 97 k triangles
# and 11-27 s for 194 k on the 2-core dev box; 1 M (0.0005 mm) ran 290 s.
MAX_FACE_TRIANGLES = 250_000
CURVE_ANGLE = 0.1  # rad, tangent turn per chord when a curve is discretised
VERTICAL_SIN = 1e-6  # a wall face's normal has |n_z| below this, or below tol / wall height
LEAN_MAX = 1e-2  # |n_z| above this (0.6°) is no wall whatever its height: no edge is read
Z_TOL = 1e-4  # mm: an edge lies at the bottom / top height within this
EXTRUSION_REL = 1e-3  # relative (+ 2 tol): the top edges are as long as the bottom ones


@dataclass(frozen=True)
class CadShape:
    """A read STEP/IGES file: shape (TopoDS_Shape, mm), roots (top-level shapes), file_unit (the
    length unit the file declares, or None), faces: [(TopoDS_Face, body index)], bodies: count,
    edges: curve edges outside any face (wireframe)."""

    shape: object
    roots: int
    file_unit: str | None
    faces: tuple
    bodies: int
    edges: tuple


@dataclass(frozen=True)
class StepResult:
    """triangles: (m, 3, 3) float64 mm. solids: bodies found. roots: top-level shapes (> 1:
    an assembly or several parts). file_unit: the length unit the file declares (or None).
    faces: faces tessellated."""

    triangles: np.ndarray
    solids: int
    roots: int
    file_unit: str | None
    faces: int = 0


_OCC_UNITS = {
    "MM": "mm",
    "MILLIMETRE": "mm",
    "CM": "cm",
    "CENTIMETRE": "cm",
    "M": "m",
    "METRE": "m",
    "INCH": "in",
    "IN": "in",
    "FT": "ft",
    "FOOT": "ft",
    "UM": "um",
    "MICROMETRE": "um",
}


def is_cad_file(filename: str) -> bool:
    return PurePosixPath(filename).suffix.lower().lstrip(".") in CAD_FORMATS


def _quiet_occ() -> None:
    """OpenCascade's default messenger prints the readers' info lines ('Total number of loaded
    entities') in colour on stdout, into the CLI's output and the server's log: keep only failures
    (the readers' status codes and our own messages say what went wrong)."""
    from OCP.Message import Message, Message_Gravity

    for printer in Message.DefaultMessenger_s().Printers():
        printer.SetTraceLevel(Message_Gravity.Message_Fail)


def _read_shape(data: bytes, filename: str):
    try:
        from OCP.IFSelect import IFSelect_RetDone
        from OCP.IGESControl import IGESControl_Reader
        from OCP.OCP.collections import Sequence_TCollection_AsciiString
        from OCP.STEPControl import STEPControl_Reader
    except ImportError as exc:  # pragma: no cover - dependency declared in pyproject
        raise InputFileError(f"{filename}: STEP/IGES input needs the 'cadquery-ocp-novtk' package") from exc
    _quiet_occ()

    ext = PurePosixPath(filename).suffix.lower().lstrip(".")
    step = ext in ("step", "stp")
    reader = STEPControl_Reader() if step else IGESControl_Reader()
    status = read_through_file(data, "." + ext, reader.ReadFile)  # OCC readers take a path
    if status != IFSelect_RetDone:
        raise InputFileError(
            f"{filename}: not a readable {'STEP' if step else 'IGES'} file (OpenCascade status {int(status)})"
        )
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


def _explore(shape, kind, avoid=None) -> list:
    from OCP.TopExp import TopExp_Explorer

    exp = TopExp_Explorer(shape, kind) if avoid is None else TopExp_Explorer(shape, kind, avoid)
    out = []
    while exp.More():
        out.append(exp.Current())
        exp.Next()
    return out


def read_cad_shape(data: bytes, filename: str) -> CadShape:
    """Read a STEP/IGES file: its shape in mm, its bodies' faces and its free curve edges."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_SHELL, TopAbs_SOLID
    from OCP.TopoDS import TopoDS

    shape, roots, file_unit = _read_shape(data, filename)
    bodies = _explore(shape, TopAbs_SOLID) + _explore(shape, TopAbs_SHELL, TopAbs_SOLID)
    free = _explore(shape, TopAbs_FACE, TopAbs_SHELL)
    faces = [(TopoDS.Face(f), b) for b, body in enumerate(bodies) for f in _explore(body, TopAbs_FACE)]
    faces += [(TopoDS.Face(f), len(bodies)) for f in free]
    edges = tuple(TopoDS.Edge(e) for e in _explore(shape, TopAbs_EDGE, TopAbs_FACE))
    return CadShape(
        shape=shape,
        roots=roots,
        file_unit=file_unit,
        faces=tuple(faces),
        bodies=len(bodies) + (1 if free else 0),
        edges=edges,
    )


def _face_triangles(face) -> np.ndarray:
    """(m, 3, 3) mm triangles of a meshed face, wound along the face's orientation."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_REVERSED
    from OCP.TopLoc import TopLoc_Location

    loc = TopLoc_Location()
    tri = BRep_Tool.Triangulation_s(face, loc)
    if tri is None or tri.NbTriangles() == 0:
        return np.zeros((0, 3, 3))
    trsf = loc.Transformation()
    nodes = np.array(
        [[p.X(), p.Y(), p.Z()] for p in (tri.Node(i).Transformed(trsf) for i in range(1, tri.NbNodes() + 1))]
    )
    idx = np.array([tri.Triangle(i).Get() for i in range(1, tri.NbTriangles() + 1)], dtype=np.int64) - 1
    if face.Orientation() == TopAbs_REVERSED:
        idx = idx[:, ::-1]
    return nodes[idx]


def _count_triangles(faces, tol: float) -> np.ndarray:
    """Triangles of each face meshed at chordal tol (mm) with a loose angular limit (π/2), so that
    the chordal law, which is what a finer tolerance refines, governs the count."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopLoc import TopLoc_Location

    out = np.zeros(len(faces))
    for i, (face, _) in enumerate(faces):
        BRepMesh_IncrementalMesh(face, tol, False, math.pi / 2, False)
        tri = BRep_Tool.Triangulation_s(face, TopLoc_Location())
        out[i] = 0 if tri is None else tri.NbTriangles()
    return out


@dataclass(frozen=True)
class TriangleEstimate:
    """Per face: n1 triangles at the coarse tolerance t1 (mm) and the exponent k of n ∝ tol^-k."""

    n1: np.ndarray
    k: np.ndarray
    t1: float

    def at(self, tol: float) -> np.ndarray:
        """Estimated triangles of each face at chordal tolerance tol (mm)."""
        return self.n1 * (self.t1 / tol) ** self.k

    def tolerance_for(self, tol: float, max_total: float, max_face: float) -> float:
        """The smallest tolerance ≥ tol (in steps of 10 %) whose estimate keeps both caps."""
        t = tol
        while t < self.t1:
            n = self.at(t)
            if n.sum() <= max_total and n.max() <= max_face:
                return t
            t *= 1.1
        return self.t1


def estimate_triangles(faces, chordal_tolerance: float) -> TriangleEstimate:
    """How many triangles each face a tessellation at `chordal_tolerance` (mm) would give,
    extrapolated from two coarse ones (t1 = 32·tol, t0 = 4·t1): n ∝ tol^-k with k fitted per face
    between them and held in [0, 1] (a plane does not refine, a singly curved face refines as
    tol^-1/2, a doubly curved one as tol^-1). Checked: a torus R 50, r 10 at 0.005 mm estimates
    85 k triangles for 97 k; a block with a hole at 0.001 mm 861 for 908. The coarse meshes are
    removed afterwards."""
    t1 = 32.0 * chordal_tolerance
    n0 = np.maximum(_count_triangles(faces, 4.0 * t1), 1.0)
    n1 = np.maximum(_count_triangles(faces, t1), 1.0)
    _clean(faces)
    return TriangleEstimate(n1=n1, k=np.clip(np.log(n1 / n0) / math.log(4.0), 0.0, 1.0), t1=t1)


def _clean(faces) -> None:
    from OCP.BRepTools import BRepTools

    for face, _ in faces:
        BRepTools.Clean_s(face)


def tessellate(
    cad: CadShape,
    filename: str,
    *,
    chordal_tolerance: float = 0.05,
    angular_tolerance: float = ANGULAR_TOLERANCE,
    max_triangles: int | None = None,
    max_face_triangles: int | None = None,
    progress: Callable[[float, str], None] | None = None,
    check_cancelled: Callable[[], None] | None = None,
) -> np.ndarray:
    """Triangles (m, 3, 3) mm of every face, tessellated face by face within chordal_tolerance.

    progress(fraction, message) is called after every face, check_cancelled() before every face
    (it raises to stop). With caps given, the triangle count is estimated first
    (`estimate_triangles`, two coarse tessellations) and a tolerance whose estimate exceeds
    max_triangles in all or max_face_triangles in one face (OpenCascade meshes a face in one call
    that can neither report progress nor be cancelled) is refused before the long run, naming the
    tolerance that would do; the running count is checked after every face as well."""
    from OCP.BRepMesh import BRepMesh_IncrementalMesh

    if not chordal_tolerance > 0:
        raise InputFileError(f"{filename}: chordal_tolerance must be > 0 mm (got {chordal_tolerance})")
    faces = cad.faces
    if not faces:
        raise InputFileError(f"{filename}: no faces to tessellate (wireframe or empty model)")
    cap_total = max_triangles if max_triangles is not None else math.inf
    cap_face = max_face_triangles if max_face_triangles is not None else math.inf
    if max_triangles is not None or max_face_triangles is not None:
        if progress:
            progress(0.0, f"estimating the triangle count at chordal_tolerance {chordal_tolerance:g} mm")
        est = estimate_triangles(faces, chordal_tolerance)
        n = est.at(chordal_tolerance)
        if n.sum() > cap_total or n.max() > cap_face:
            worst = int(np.argmax(n))
            over = (
                f"about {int(n.sum()):,} triangles in all, over the cap of {cap_total:,} (max_triangles)"
                if n.sum() > cap_total
                else f"about {int(n[worst]):,} triangles in face {worst + 1} of {len(faces)}, over the cap of "
                f"{cap_face:,} per face (max_face_triangles: OpenCascade meshes a face in one call that can "
                "neither report progress nor be cancelled, and its time grows faster than the count)"
            )
            raise InputFileError(
                f"{filename}: chordal_tolerance {chordal_tolerance:g} mm would give {over}; a chordal_tolerance of "
                f"{est.tolerance_for(chordal_tolerance, cap_total, cap_face):.2g} mm or more keeps the caps "
                "(triangles grow about as 1/tolerance on doubly curved faces)"
            )
    parts, total = [], 0
    for i, (face, _) in enumerate(faces):
        if check_cancelled:
            check_cancelled()
        BRepMesh_IncrementalMesh(face, chordal_tolerance, False, angular_tolerance, False)
        t = _face_triangles(face)
        parts.append(t)
        total += len(t)
        if total > cap_total:
            raise InputFileError(
                f"{filename}: {total:,} triangles after {i + 1} of {len(faces)} faces at chordal_tolerance "
                f"{chordal_tolerance:g} mm, over the cap of {cap_total:,}; raise 'chordal_tolerance' or 'max_triangles'"
            )
        if progress:
            progress((i + 1) / len(faces), f"tessellated face {i + 1} of {len(faces)} ({total:,} triangles)")
    tri = np.concatenate(parts)
    if len(tri) == 0:
        raise InputFileError(f"{filename}: no faces to tessellate (wireframe or empty model)")
    return tri


def read_cad_triangles(
    data: bytes,
    filename: str,
    *,
    chordal_tolerance: float = 0.05,
    angular_tolerance: float = ANGULAR_TOLERANCE,
    max_triangles: int | None = None,
    max_face_triangles: int | None = None,
    progress=None,
    check_cancelled=None,
) -> StepResult:
    """Triangles (mm) of every face of a STEP/IGES file, tessellated within chordal_tolerance (mm)."""
    if not chordal_tolerance > 0:
        raise InputFileError(f"{filename}: chordal_tolerance must be > 0 mm (got {chordal_tolerance})")
    cad = read_cad_shape(data, filename)
    tri = tessellate(
        cad,
        filename,
        chordal_tolerance=chordal_tolerance,
        angular_tolerance=angular_tolerance,
        max_triangles=max_triangles,
        max_face_triangles=max_face_triangles,
        progress=progress,
        check_cancelled=check_cancelled,
    )
    return StepResult(triangles=tri, solids=cad.bodies, roots=cad.roots, file_unit=cad.file_unit, faces=len(cad.faces))


def unit_rescale(file_unit: str | None, units: str) -> tuple[str, float, str | None]:
    """(unit applied, factor on OpenCascade's mm, notice): OCC has converted the declared unit to
    mm; an overriding `units` reinterprets the file's numbers (`units.conversion_notice`)."""
    from .transform import unit_scale
    from .units import conversion_notice

    applied, factor, notice = conversion_notice(file_unit, units)
    if applied == (file_unit or "mm"):
        return applied, 1.0, notice
    return applied, factor / unit_scale(file_unit or "mm"), notice


def load_cad_bytes(
    data: bytes,
    filename: str,
    *,
    units: str = "file",
    chordal_tolerance: float = 0.05,
    transform=None,
    weld_tolerance: float = 0.0,
    max_triangles: int | None = None,
    max_face_triangles: int | None = None,
    progress=None,
    check_cancelled=None,
    stats: dict | None = None,
    crack_tolerance: float | None = None,
    require_closed: bool = True,
):
    """(MeshData in mm, StepResult, notice) of a STEP/IGES file. OpenCascade converts the declared
    unit (STEP length unit, IGES global unit flag) to mm; units "file" or the declared unit keep
    that conversion (exactly once), another unit reinterprets the file's numbers (an override,
    said in the notice; `units.conversion_notice`). stats, crack_tolerance, require_closed: as
    `mesh_io.mesh_from_triangles` (the repair and classification of mesh files)."""
    from .mesh_io import mesh_from_triangles
    from .transform import Transform

    res = read_cad_triangles(
        data,
        filename,
        chordal_tolerance=chordal_tolerance,
        max_triangles=max_triangles,
        max_face_triangles=max_face_triangles,
        progress=progress,
        check_cancelled=check_cancelled,
    )
    _, k, notice = unit_rescale(res.file_unit, units)
    tri = res.triangles * k if k != 1.0 else res.triangles
    mesh = mesh_from_triangles(
        tri,
        name=PurePosixPath(filename).stem,
        units="mm",
        transform=transform or Transform(),
        source=filename,
        weld_tolerance=weld_tolerance,
        stats=stats,
        crack_tolerance=crack_tolerance,
        require_closed=require_closed,
    )
    return mesh, res, notice


# ------------------------------------------------------------------------------------------
# Midsurfaces: vertical walls and planar curves
# ------------------------------------------------------------------------------------------
def edge_points(edge, tol: float) -> np.ndarray:
    """(k, 3) mm points along an edge, chords within `tol` of the curve (sagitta) and turning at
    most CURVE_ANGLE each, in the edge's own direction."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GCPnts import GCPnts_TangentialDeflection
    from OCP.TopAbs import TopAbs_REVERSED

    c = BRepAdaptor_Curve(edge)
    d = GCPnts_TangentialDeflection(c, CURVE_ANGLE, tol)
    pts = np.array([[p.X(), p.Y(), p.Z()] for p in (d.Value(i) for i in range(1, d.NbPoints() + 1))])
    return pts[::-1] if edge.Orientation() == TopAbs_REVERSED else pts


def _edge_length(edge) -> float:
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GCPnts import GCPnts_AbscissaPoint

    return float(GCPnts_AbscissaPoint.Length_s(BRepAdaptor_Curve(edge), 1e-9))  # (without a tolerance: 0.1 % off)


@dataclass(frozen=True)
class CadCurves:
    """Midsurface curves read from a CAD file: curves (k, 2) mm, z0 mm, height mm (None: the
    file holds curves only), lengths: total curve length mm."""

    curves: list
    z0: float
    height: float | None
    length: float


def _face_edges(faces):
    """The edges of the faces, each once (an edge shared by two faces is one edge)."""
    from OCP.OCP.collections import IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS

    m = ShapeMap()
    for face, _ in faces:
        TopExp.MapShapes_s(face, TopAbs_EDGE, m)
    return [TopoDS.Edge(m.FindKey(i)) for i in range(1, m.Extent() + 1)]


def vertical_midsurface(cad: CadShape, tol: float) -> tuple[CadCurves | None, str]:
    """The sketch of a midsurface made of vertical walls: (CadCurves, "") when every face is
    vertical (its normal, sampled on a 5 × 5 grid of its parameter box, tilts from horizontal by
    less than tol / wall height: the wall leans less than the chordal tolerance), the faces span
    one bottom and one top height, and the top edges are the bottom ones lifted (as long, within
    2·tol of them in plan): a vertical extrusion of the bottom edges; else (None, why not).
    An edge lies at the bottom or top within its own tolerance in the file (at least Z_TOL)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepLProp import BRepLProp_SLProps
    from OCP.BRepTools import BRepTools

    if not cad.faces:
        return None, "no faces"
    tilt = 0.0
    where: tuple[float, float, float] | None = None  # set with tilt: read only when tilt > 0
    for face, _ in cad.faces:
        umin, umax, vmin, vmax = BRepTools.UVBounds_s(face)
        props = BRepLProp_SLProps(BRepAdaptor_Surface(face), 1, 1e-9)
        for u in np.linspace(umin, umax, 5):
            for v in np.linspace(vmin, vmax, 5):
                props.SetParameters(float(u), float(v))
                if props.IsNormalDefined() and abs(props.Normal().Z()) > tilt:
                    tilt, q = abs(props.Normal().Z()), props.Value()
                    where = (q.X(), q.Y(), q.Z())
        if tilt > LEAN_MAX:  # clearly not a wall: stop before the edges
            break
    if tilt > LEAN_MAX:
        assert where is not None
        return (
            None,
            f"a face is not vertical (normal z {tilt:.3g} at ({where[0]:.3f}, {where[1]:.3f}, {where[2]:.3f}) mm)",
        )
    edges = _face_edges(cad.faces)  # free curves beside the walls are not walls
    pts = [edge_points(e, tol) for e in edges]
    z0 = min(float(p[:, 2].min()) for p in pts)
    z1 = max(float(p[:, 2].max()) for p in pts)
    height = z1 - z0
    if not height > Z_TOL:
        return None, "the faces have no height"
    if tilt > max(VERTICAL_SIN, tol / height):
        assert where is not None
        return None, (
            f"a face leans {tilt * height:.3g} mm over its {height:.6g} mm height, more than the "
            f"tolerance {tol:g} mm (normal z {tilt:.3g} at ({where[0]:.3f}, {where[1]:.3f}, {where[2]:.3f}) mm)"
        )
    ztol = [max(Z_TOL, BRep_Tool.Tolerance_s(e)) for e in edges]
    bottom = [i for i, p in enumerate(pts) if np.all(np.abs(p[:, 2] - z0) <= ztol[i])]
    top = [i for i, p in enumerate(pts) if np.all(np.abs(p[:, 2] - z1) <= ztol[i])]
    lb = sum(_edge_length(edges[i]) for i in bottom)
    lt = sum(_edge_length(edges[i]) for i in top)
    if not lb > 0 or abs(lb - lt) > EXTRUSION_REL * lb + 2 * tol:
        return None, (
            f"not one extrusion: bottom edges {lb:.6g} mm long, top edges {lt:.6g} mm (walls {height:.6g} mm high)"
        )
    gap = _plan_gap([pts[i][:, :2] for i in bottom], [pts[i][:, :2] for i in top])
    if gap > 2 * tol + max(ztol):
        return None, f"not one extrusion: the top edges lie up to {gap:.3g} mm off the bottom ones in plan"
    return CadCurves(curves=[pts[i][:, :2] for i in bottom], z0=z0, height=height, length=lb), ""


def _plan_gap(a: list, b: list) -> float:
    """Largest distance (mm) from a point of one set of polylines (k, 2) to the other set, both ways."""
    import shapely

    la, lb = (shapely.MultiLineString([c for c in cs if len(c) > 1]) for cs in (a, b))
    return float(
        max(
            shapely.distance(shapely.points(np.vstack(a)), lb).max(),
            shapely.distance(shapely.points(np.vstack(b)), la).max(),
        )
    )


def planar_curves(cad: CadShape, tol: float, filename: str) -> CadCurves:
    """The curve edges of a wireframe file (no faces) as sketch curves; they must lie in one
    horizontal plane (within Z_TOL), else InputFileError naming the heights found."""
    if not cad.edges:
        raise InputFileError(f"{filename}: the file holds neither faces nor curves")
    pts = [edge_points(e, tol) for e in cad.edges]
    z = np.concatenate([p[:, 2] for p in pts])
    if z.max() - z.min() > Z_TOL:
        raise InputFileError(
            f"{filename}: the {len(pts)} curves are not in one horizontal plane (z from "
            f"{z.min():.6g} to {z.max():.6g} mm); a sketch's curves lie in a plane z = const"
        )
    return CadCurves(
        curves=[p[:, :2] for p in pts], z0=float(z.min()), height=None, length=sum(_edge_length(e) for e in cad.edges)
    )
