"""Input nodes: `mesh` (solid parts from STL/OBJ/PLY/3MF) and `sketch` (2D curves → midsurface).

Thin adapters over `waamflow.geometry`; files are read through the engine (`ctx.read_bytes`) so
their content is part of the node's signature.
"""

from __future__ import annotations

import dataclasses

from pathlib import PurePosixPath
from typing import Literal

from pydantic import ConfigDict, Field

import numpy as np

from ..core.errors import InputFileError
from ..core.model import MeshData, Midsurface
from ..geometry import MeshLimits, Transform, load_mesh_bytes, load_sketch_bytes
from ..core.tolerances import TOL
from ..geometry.mesh_io import classify_mesh, declared_mesh_unit
from ..geometry.mesh_io import mesh_from_triangles
from ..geometry.sketch import sketch_from_curves
from ..geometry.step_io import (
    MAX_FACE_TRIANGLES,
    is_cad_file,
    read_cad_shape,
    tessellate,
    unit_rescale,
    vertical_midsurface,
)
from ..geometry.units import MAX_PART_MM, conversion_notice, implausible_size, placement_offset
from ..engine.node import FileRef, Node, NodeParams, register, unit
from ..engine.ports import Port

LengthUnit = Literal["file", "mm", "cm", "m", "in", "ft"]
Placement = Literal["as_is", "on_plate", "centred"]
UNITS_DOC = (
    "Length unit of the file's coordinates; 'file': the unit the file declares (DXF $INSUNITS, 3MF unit), else mm"
)
PLACEMENT_DOC = (
    "After the transform: 'as_is' keeps coordinates, 'on_plate' puts the lowest point on z = 0, "
    "'centred' also puts the x/y bounding-box centre on the origin"
)


def _report_part(
    ctx,
    label: str,
    lo,
    hi,
    units: str,
    shift,
    *,
    file_unit: str | None = None,
    notice: str | None = None,
    drawing: bool = False,
) -> None:
    """Report the unit conversion (node report; a notice warning unless mm), an implausible size
    and the placement shift. drawing: a midsurface, whose size is its curves' x/y extent only (the
    extrusion height is the node's, not the drawing's: a 1 mm drawing extruded 30 mm is 1 mm)."""
    from ..geometry.transform import unit_scale

    span = np.asarray(hi) - np.asarray(lo)
    extent = float(np.max(span[:2] if drawing else span))
    if extent > MAX_PART_MM:
        raise InputFileError(
            f"{label}: part is {extent / 1000:.3g} m across, more than the {MAX_PART_MM / 1000:g} m any WAAM cell "
            f"builds (read in {units}): check the node's 'units' (a file in mm read as m or in?) or the file",
            field="units",
        )
    ctx.report({"file_unit": file_unit, "unit": units, "unit_factor": unit_scale(units)})
    if notice:
        ctx.warn(f"{label}: {notice}")
    if (msg := implausible_size(extent)) is not None:
        ctx.warn(f"{label}: {msg}")
    if shift is not None and np.any(shift):
        ctx.warn(f"{label}: placed by translate ({shift[0]:.3f}, {shift[1]:.3f}, {shift[2]:.3f}) mm")


def _report_mesh(ctx, params, mesh: MeshData, st: dict) -> None:
    """Node report and warnings of a mesh file's repair and of how it is read (solid / surface)."""
    rep = st["edges"]
    solid = rep.closed and st["volume_mm3"] > 0
    read_as = "solid" if params.as_ == "solid" or (params.as_ == "auto" and solid) else "surface"
    ctx.report(
        {
            "read_as": read_as,
            "volume_mm3": round(float(st["volume_mm3"]), 3),
            "open_edges": rep.open,
            "nonmanifold_edges": rep.nonmanifold,
            "misoriented_edges": rep.misoriented,
            "vertices_welded": st.get("welded", 0),
            "vertices_merged": st["vertices_merged"],
            "holes_filled": st.get("holes_filled", 0),
            "nonmanifold_edges_split": st["nonmanifold_edges_split"],
            "faces_rewound": st["faces_rewound"],
            "voids": st.get("voids", (0, 0.0))[0],
        }
    )
    if st.get("voids"):
        n, share = st["voids"]
        ctx.warn(
            f"{params.path}: {n} closed void{'s' if n != 1 else ''} inside the part ({share:.1%} of its "
            "volume; shells facing inwards), kept hollow: the layers around a void are frames, and its "
            "roof is an overhang the layers above must bridge"
        )
    for note in st.get("reader_notes", ()):
        ctx.warn(f"{params.path}: the file reader (trimesh) says: {note} (only the geometry is read)")
    if st.get("welded"):
        ctx.warn(
            f"{params.path}: welded {st['welded']} vertices on open edges within weld_tolerance "
            f"{params.weld_tolerance:g} mm (cracks between triangles that should touch)"
        )
    fixes = []
    if st["vertices_merged"]:
        fixes.append(
            f"closed cracks up to crack_tolerance {params.crack_tolerance:g} mm by merging "
            f"{st['vertices_merged']} vertices"
        )
    if st.get("holes_filled"):
        n = st["holes_filled"]
        fixes.append(f"filled {n} hole{'s' if n != 1 else ''} of 3 or 4 edges (missing facets)")
    if st["nonmanifold_edges_split"]:
        fixes.append(f"separated bodies sharing {st['nonmanifold_edges_split']} non-manifold edge(s)")
    if st["faces_rewound"]:
        fixes.append(f"re-wound {st['faces_rewound']} faces (consistent winding, normals outwards)")
    if fixes and solid:
        ctx.warn(f"{params.path}: repaired: {'; '.join(fixes)}; now a closed solid of {st['volume_mm3']:.6g} mm³")
    elif fixes:
        ctx.warn(f"{params.path}: repaired: {'; '.join(fixes)}")
    if params.as_ == "auto" and not solid and rep.open and not rep.nonmanifold and not rep.misoriented:
        ctx.warn(
            f"{params.path}: the mesh is open ({rep.open} open, {rep.nonmanifold} non-manifold edges, "
            f"after repair): read as a single-wall surface, sliced into per-layer curves; if it is a solid "
            f"with gaps wider than crack_tolerance {params.crack_tolerance:g} mm raise it, or set 'as': "
            "'solid' to see the error"
        )


def _shifted(part, shift):
    """The part (MeshData or Midsurface) translated by shift (3,) mm."""
    if isinstance(part, Midsurface):
        return Midsurface(
            curves=tuple(c + shift[:2] for c in part.curves),
            height=part.height,
            z0=part.z0 + float(shift[2]),
            name=part.name,
            joints=tuple((x + float(shift[0]), y + float(shift[1])) for x, y in part.joints),
        )
    return dataclasses.replace(part, vertices=part.vertices + shift)


def _stage(ctx):
    """A kernel's stage callback: report progress, then stop here if the run was cancelled."""

    def stage(fraction: float, message: str) -> None:
        ctx.progress(fraction, message)
        ctx.check_cancelled()

    return stage


def _cad_midsurface(ctx, params, cad, k: float, transform: Transform) -> tuple[Midsurface | None, str]:
    """(the midsurface, "") of a CAD file whose faces are all vertical walls between one bottom and
    one top height (their bottom curves extruded), in mm after the unit factor k and the
    transform; (None, why not) otherwise or when the transform tilts the walls."""
    cc, why = vertical_midsurface(cad, params.chordal_tolerance / k)
    if cc is None:
        return None, why
    if cc.height is None:  # vertical_midsurface measures the walls' height (None: curves-only files)
        return None, "the walls have no height"
    axis = transform.apply(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    up = axis[1] - axis[0]
    if np.hypot(up[0], up[1]) > 1e-9 * abs(up[2]) or up[2] <= 0:
        return None, "the transform tilts the walls out of vertical"
    ends = [transform.apply(np.column_stack([c * k, np.full(len(c), cc.z0 * k)])) for c in cc.curves]
    z0 = float(ends[0][0, 2])
    height = float(cc.height * k * transform.scale)
    mid = sketch_from_curves([p[:, :2] for p in ends], height=height, z0=z0, name=params.path, join_tol=TOL.join)
    mid = Midsurface(
        curves=mid.curves, height=mid.height, z0=mid.z0, name=PurePosixPath(params.path).stem, joints=mid.joints
    )
    ctx.report(
        {
            "read_as": "midsurface",
            "faces": len(cad.faces),
            "curves": len(mid.curves),
            "curve_length_mm": round(
                float(sum(np.linalg.norm(np.diff(c, axis=0), axis=1).sum() for c in mid.curves)), 4
            ),
            "height_mm": round(height, 6),
        }
    )
    ctx.warn(
        f"{params.path}: read as a midsurface (a sketch): {len(cad.faces)} vertical wall face(s), the "
        f"extrusion of {len(mid.curves)} curve(s) of {cc.length * k * transform.scale:.6g} mm from z "
        f"{z0:g} mm by {height:g} mm"
    )
    return mid, ""


def _read_cad_part(ctx, params, data: bytes, transform: Transform):
    """(part, file unit, unit applied, notice) of a STEP/IGES file. Unless `as` is 'solid', faces
    that are all vertical walls are a midsurface (a Midsurface, never tessellated: walls meeting in
    T's and crossings are non-manifold as a mesh, yet the thin-walls study's input). Otherwise the
    faces are tessellated face by face (progress, cancel, triangle caps), repaired and classified
    like a mesh file; an open surface stays a tessellated single-wall surface."""
    cad = read_cad_shape(data, params.path)
    if not cad.faces:
        raise InputFileError(
            f"{params.path}: {len(cad.edges)} curve(s) and no faces (a wireframe): read it with a "
            "'sketch' node, which extrudes the curves by its 'height'"
        )
    units, k, notice = unit_rescale(cad.file_unit, params.units)
    if cad.edges:
        ctx.warn(
            f"{params.path}: {len(cad.edges)} curve(s) outside any face ignored (construction lines? a sketch "
            "node reads the curves of a file without faces)"
        )
    why = "'as': 'solid'"
    if params.as_ != "solid":
        mid, why = _cad_midsurface(ctx, params, cad, k, transform)
        if mid is not None:
            return mid, cad.file_unit, units, notice
    tri = tessellate(
        cad,
        params.path,
        chordal_tolerance=params.chordal_tolerance,
        max_triangles=params.max_triangles,
        max_face_triangles=params.max_face_triangles,
        progress=ctx.progress,
        check_cancelled=ctx.check_cancelled,
    )
    st: dict = {}
    mesh = mesh_from_triangles(
        tri * k,
        name=PurePosixPath(params.path).stem,
        units="mm",
        transform=transform,
        source=params.path,
        weld_tolerance=params.weld_tolerance,
        stats=st,
        crack_tolerance=params.crack_tolerance,
        require_closed=False,
    )
    _report_mesh(ctx, params, mesh, st)
    ctx.report({"faces": len(cad.faces), "triangles": int(len(mesh.faces))})
    if cad.roots > 1 or cad.bodies > 1:
        ctx.warn(
            f"{params.path}: {cad.roots} top-level shape(s) with {cad.bodies} bodies flattened into one part "
            f"(each body kept); tessellated within {params.chordal_tolerance:g} mm"
        )
    if classify_mesh(st, params.as_, params.path) == "surface":
        ctx.warn(f"{params.path}: read as a tessellated single-wall surface, not as a sketch: {why}")
        return (
            MeshData(vertices=mesh.vertices, faces=mesh.faces, name=mesh.name, surface=True),
            cad.file_unit,
            units,
            notice,
        )
    return mesh, cad.file_unit, units, notice


Vec3 = tuple[float, float, float]
MAX_LISTED = 10  # warnings listing one item each (DXF defects, repairs): the first this many, then a count


class TransformParams(NodeParams):
    translate: Vec3 = Field(
        (0.0, 0.0, 0.0),
        description="Translation after rotation",
        json_schema_extra=unit("mm"),
        title="Translation (x, y, z)",
    )
    rotate_deg: Vec3 = Field(
        (0.0, 0.0, 0.0),
        description="Rotation about the x, then y, then z axis (fixed axes)",
        json_schema_extra=unit("deg"),
        title="Rotation (x, y, z)",
    )
    scale: float = Field(1.0, gt=0, le=1000, description="Uniform scale factor, applied first", title="Scale factor")


@register
class MeshNode(Node):
    """A solid part from a triangle mesh file (STL binary or ASCII, OBJ, PLY, OFF, 3MF) or a CAD file
    (STEP, IGES: read and tessellated by OpenCascade within `chordal_tolerance`).

    Coordinates are converted from `units` to mm, then scaled, rotated (x, y, z) and translated.
    Corners that are bit-identical in the file are welded; where open edges remain, vertices on
    them closer than `weld_tolerance` (default 1 µm) are merged too, reported as a warning.
    Mesh files are then repaired where that cannot change the shape (`geometry.mesh_io.repair_mesh`):
    cracks up to `crack_tolerance` (default 0.1 mm) closed when that closes the mesh, missing
    facets (holes of 3 or 4 edges, at most 1 % of the surface) filled when that closes it, bodies
    sharing an edge separated, faces re-wound consistently and outwards (a shell facing inwards
    inside a solid one is a void and is kept, counted and warned); every repair is
    counted in the node report and warned. The repaired mesh is classified by what it measures:
    closed with a positive volume → solid; open without non-manifold or misoriented edges → a
    single-wall surface (`as: auto`, warned); anything else stops the run (exit 2) with the edge
    counts and where the first defect is. `as: solid` refuses an open mesh the same way. Files
    over `max_file_mb` or with more than `max_triangles` triangles are refused.

    STEP/IGES: every face (of solids, shells and free faces such as IGES 144 trimmed surfaces)
    is tessellated one by one, with progress events and cancel between faces; a chordal
    tolerance whose estimated triangle count exceeds `max_triangles` is refused before the long
    run. The triangles are repaired and classified as above; an open surface whose faces are all
    vertical walls between one bottom and one top height (a thin-wall midsurface) is read as a
    sketch: its bottom curves (discretised within `chordal_tolerance`) extruded (a Midsurface, as
    from the `sketch` node; never tessellated, so walls meeting in T's and crossings, which are
    non-manifold as a mesh, are read as the thin-walls study has them); other open
    surfaces stay tessellated single-wall surfaces. A file of curves only is refused here (read
    it with `sketch`).
    """

    type = "mesh"
    version = "4"  # 3: CAD surfaces/midsurfaces, CAD repair + classification, tessellation progress/cancel/estimate; 4: the reader's notes as warnings
    title = "Mesh"
    category = "inputs"
    outputs = (
        Port(
            "mesh",
            "mesh",
            "Triangle mesh in mm (MeshData): a closed solid, or an open single-wall surface; "
            "a CAD midsurface of vertical walls: its curves extruded (Midsurface)",
        ),
    )

    class Params(NodeParams):
        model_config = ConfigDict(extra="forbid", populate_by_name=True)

        path: FileRef = Field(
            description="Mesh or CAD file (.stl, .obj, .ply, .off, .3mf, .step/.stp, .iges/.igs), relative to the recipe",
            title="Mesh or CAD file",
        )
        units: LengthUnit = Field("file", description=UNITS_DOC, title="File units")
        transform: TransformParams = Field(
            default_factory=TransformParams, description="Placement of the part", title="Transform"
        )
        placement: Placement = Field("as_is", description=PLACEMENT_DOC, title="Placement")
        as_: Literal["auto", "solid", "surface"] = Field(
            "auto",
            alias="as",
            description="solid: must be closed (sliced into regions); surface: an open single-wall surface, sliced "
            "into per-layer curves like a sketch; auto: closed → solid, open → surface (with a warning)",
            title="Read as",
        )
        chordal_tolerance: float = Field(
            0.05,
            gt=0,
            le=5,
            description="STEP/IGES: max distance between the CAD surface and its triangles",
            json_schema_extra=unit("mm"),
            title="Chordal tolerance",
        )
        max_file_mb: float = Field(
            200.0, gt=0, le=512, description="Refuse larger files", json_schema_extra=unit("MB"), title="Largest file"
        )
        max_triangles: int = Field(
            5_000_000, ge=1, le=20_000_000, description="Refuse meshes with more triangles", title="Most triangles"
        )
        max_face_triangles: int = Field(
            MAX_FACE_TRIANGLES,
            ge=1,
            le=20_000_000,
            description="STEP/IGES: refuse a chordal_tolerance that would give one face "
            "more triangles (estimated before tessellating; one face is "
            "meshed in one call that cannot be cancelled)",
            title="Most triangles per CAD face",
        )
        weld_tolerance: float = Field(
            0.001,
            ge=0,
            le=1.0,
            description="Merge vertices on open edges closer than this (exporter cracks, "
            "seam gaps; reported). 0: bit-identical corners only",
            json_schema_extra=unit("mm"),
            title="Open-edge weld tolerance",
        )
        crack_tolerance: float = Field(
            TOL.crack,
            ge=0,
            le=1.0,
            description="Mesh files: close cracks up to this size between faces of a solid "
            "(merging vertices on open edges; kept only when that closes the "
            "mesh, reported), and fill missing facets (holes of 3 or 4 edges, "
            "at most 1 % of the surface, when that closes the mesh). 0: neither",
            json_schema_extra=unit("mm"),
            title="Crack closing tolerance",
        )

    def run(self, ctx, params, inputs):
        data = ctx.read_bytes(params.path, max_bytes=int(params.max_file_mb * 2**20))
        ctx.progress(0.0, f"read {params.path} ({len(data) / 2**20:.1f} MB)")
        ctx.check_cancelled()
        t = params.transform
        transform = Transform(translate=t.translate, rotate_deg=t.rotate_deg, scale=t.scale)
        if is_cad_file(params.path):
            mesh, file_unit, units, notice = _read_cad_part(ctx, params, data, transform)
        else:
            file_unit = declared_mesh_unit(data, params.path)
            units, _, notice = conversion_notice(file_unit, params.units)
            weld: dict = {}
            mesh = load_mesh_bytes(
                data,
                params.path,
                require_closed=False,
                units=units,
                transform=transform,
                limits=MeshLimits(max_bytes=int(params.max_file_mb * 2**20), max_triangles=params.max_triangles),
                weld_tolerance=params.weld_tolerance,
                stats=weld,
                crack_tolerance=params.crack_tolerance,
                stage=_stage(ctx),
            )
            _report_mesh(ctx, params, mesh, weld)
            if classify_mesh(weld, params.as_, params.path) == "surface":
                mesh = MeshData(vertices=mesh.vertices, faces=mesh.faces, name=mesh.name, surface=True)
        lo, hi = mesh.bounds
        shift = placement_offset(lo, hi, params.placement)
        if np.any(shift):
            mesh = _shifted(mesh, shift)
        _report_part(
            ctx,
            params.path,
            lo,
            hi,
            units,
            shift,
            file_unit=file_unit,
            notice=notice,
            drawing=isinstance(mesh, Midsurface),
        )
        return {"mesh": mesh}


@register
class SketchNode(Node):
    """A thin-wall part given by its midsurface: 2D curves extruded along +Z from z0 by height.

    JSON `{"curves": [[[x, y], ...], ...]}` (optional "height", "z0" in the file's units; a
    closed curve repeats its first point) or DXF, ASCII or binary (LINE, LWPOLYLINE with bulges,
    POLYLINE, ARC, CIRCLE, ELLIPSE, SPLINE, block INSERTs and MINSERT arrays; arcs discretised
    within `arc_tolerance`), from the modelspace or the paperspace layout named by `layout`. Curves
    meeting end to end (exactly two ends at a point) are joined into one polyline. DXF entities
    without curve geometry (TEXT, DIMENSION, HATCH, ...), zero-length ones and those on layers the
    drawing hides (off or frozen) are skipped with a warning. STEP/IGES (OpenCascade): a midsurface of vertical wall faces gives its bottom curves,
    z0 and height (IGES 144 trimmed surfaces); a file of curves only (IGES 126 B-splines, 110
    lines, 100 arcs) in one horizontal plane gives its curves at that plane's z; curves are
    discretised within `arc_tolerance`.
    """

    type = "sketch"
    version = "3"  # 3: STEP/IGES midsurfaces and curves
    title = "Sketch (midsurface)"
    category = "inputs"
    outputs = (Port("mesh", "mesh", "Midsurface: curves extruded along +Z (Midsurface), mm"),)

    class Params(NodeParams):
        path: FileRef = Field(
            description="Sketch file (.json, .dxf, or .step/.stp/.iges/.igs curves or vertical "
            "wall faces), relative to the recipe",
            title="Sketch file",
        )
        height: float | None = Field(
            None,
            gt=0,
            le=10_000,
            description="Extrusion height; default: the JSON file's 'height', a CAD file's wall height",
            json_schema_extra=unit("mm"),
            title="Extrusion height",
        )
        z0: float | None = Field(
            None,
            ge=-10_000,
            le=10_000,
            description="Bottom of the extrusion; default: the JSON file's 'z0', a CAD file's bottom "
            "(or its curves' plane), else 0",
            json_schema_extra=unit("mm"),
            title="Extrusion bottom",
        )
        units: LengthUnit = Field("file", description=UNITS_DOC, title="File units")
        placement: Placement = Field("as_is", description=PLACEMENT_DOC, title="Placement")
        arc_tolerance: float = Field(
            0.01,
            gt=0,
            le=10,
            description="Max chordal deviation when discretising arcs",
            json_schema_extra=unit("mm"),
            title="Arc tolerance",
        )
        layout: str = Field(
            "Model",
            min_length=1,
            max_length=255,
            description="DXF layout to read: 'Model' (modelspace) or a paperspace layout's name",
            title="DXF layout",
        )
        join: bool = Field(
            True, description="Join curves that meet end to end into one polyline", title="Join touching curves"
        )
        max_file_mb: float = Field(
            50.0, gt=0, le=512, description="Refuse larger files", json_schema_extra=unit("MB"), title="Largest file"
        )

    def run(self, ctx, params, inputs):
        data = ctx.read_bytes(params.path, max_bytes=int(params.max_file_mb * 2**20))
        ctx.progress(0.0, f"read {params.path} ({len(data) / 2**20:.1f} MB)")
        ctx.check_cancelled()
        res = load_sketch_bytes(
            data,
            params.path,
            height=params.height,
            z0=params.z0,
            units=params.units,
            arc_tolerance=params.arc_tolerance,
            join=params.join,
            layout=params.layout,
        )
        if res.skipped:
            kinds = ", ".join(f"{n} {t}" for t, n in sorted(res.skipped.items()))
            ctx.warn(
                f"{params.path}: skipped DXF entities (no curve geometry, zero length, degenerate, or on a layer the drawing hides): {kinds}"
            )
        for what, items in (("degenerate entity skipped", res.defects), ("DXF read", res.repairs)):
            for text in items[:MAX_LISTED]:
                ctx.warn(f"{params.path}: {what}: {text}")
            if len(items) > MAX_LISTED:
                ctx.warn(f"{params.path}: {what}: {len(items) - MAX_LISTED} more not listed")
        ctx.report({"dxf_degenerate_skipped": len(res.defects), "dxf_repairs": len(res.repairs)})
        mid = res.midsurface
        pts = np.vstack(mid.curves)
        lo = np.array([*pts.min(axis=0), mid.z0])
        hi = np.array([*pts.max(axis=0), mid.z0 + mid.height])
        shift = placement_offset(lo, hi, params.placement)
        if np.any(shift):
            mid = _shifted(mid, shift)
        _report_part(
            ctx, params.path, lo, hi, res.units, shift, file_unit=res.file_unit, notice=res.notice, drawing=True
        )
        return {"mesh": mid}
