"""Input nodes: `mesh` (solid parts from STL/OBJ/PLY/3MF) and `sketch` (2D curves → midsurface).

Thin adapters over `waamflow.geometry`; files are read through the engine (`ctx.read_bytes`) so
their content is part of the node's signature.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from ..geometry import MeshLimits, Transform, load_mesh, load_sketch_bytes
from ..geometry.sketch import skipped_text
from ..engine.node import FileRef, Node, NodeParams, register, unit
from ..engine.ports import Port

LengthUnit = Literal["auto", "um", "mm", "cm", "dm", "m", "in", "ft"]
Placement = Literal["as_is", "build_plate", "centred"]
Vec3 = tuple[float, float, float]


class TransformParams(NodeParams):
    translate: Vec3 = Field((0.0, 0.0, 0.0), description="Translation after rotation", json_schema_extra=unit("mm"))
    rotate_deg: Vec3 = Field((0.0, 0.0, 0.0), description="Rotation about the x, then y, then z axis (fixed axes)",
                             json_schema_extra=unit("deg"))
    scale: float = Field(1.0, gt=0, le=1000, description="Uniform scale factor, applied first")


@register
class MeshNode(Node):
    """A solid part from a triangle mesh file: STL (binary or ASCII), OBJ, PLY or 3MF.

    Coordinates are converted from `units` to mm (auto: the 3MF file's unit attribute; mm for
    STL/OBJ/PLY, which carry no unit), then scaled, rotated (x, y, z) and translated, then placed
    (`placement`: as_is; build_plate = lowest point to z 0; centred = x/y bounding-box centre to
    the origin and lowest point to z 0; the translation is reported as a warning). A part under
    5 mm or over 5 m across is reported as a probable unit mistake.
    Corners that are bit-identical in the file are welded; where open edges remain, vertices on
    them closer than `weld_tolerance` are merged too (reported as a warning). A binary or ASCII
    STL under another extension is recognised by its content. The mesh must be closed (watertight,
    consistently wound): otherwise the run stops with exit 2 saying how many edges are open,
    non-manifold or misoriented. Files over `max_file_mb` or with more than `max_triangles`
    triangles are refused.
    """

    type = "mesh"
    title = "Mesh"
    category = "inputs"
    outputs = (Port("mesh", "mesh", "Closed triangle mesh in mm (MeshData)"),)

    class Params(NodeParams):
        path: FileRef = Field(description="Mesh file (.stl, .obj, .ply, .3mf), relative to the recipe")
        units: LengthUnit = Field("auto", description="Length unit of the file's coordinates (auto: from the file, else mm)")
        transform: TransformParams = Field(default_factory=TransformParams, description="Placement of the part")
        placement: Placement = Field("as_is", description="After the transform: as_is, build_plate (z min → 0) or "
                                                          "centred (x/y centre → origin, z min → 0)")
        max_file_mb: float = Field(200.0, gt=0, le=512, description="Refuse larger files", json_schema_extra=unit("MB"))
        max_triangles: int = Field(5_000_000, ge=1, le=20_000_000, description="Refuse meshes with more triangles")
        weld_tolerance: float = Field(0.001, ge=0, le=1.0,
                                      description="Merge vertices on open edges closer than this (cracks, seam gaps; "
                                                  "0: bit-identical corners only)",
                                      json_schema_extra=unit("mm"))

    def run(self, ctx, params, inputs):
        data = ctx.read_bytes(params.path, max_bytes=int(params.max_file_mb * 2**20))
        t = params.transform
        res = load_mesh(
            data,
            params.path,
            units=None if params.units == "auto" else params.units,
            transform=Transform(translate=t.translate, rotate_deg=t.rotate_deg, scale=t.scale),
            placement=params.placement,
            limits=MeshLimits(max_bytes=int(params.max_file_mb * 2**20), max_triangles=params.max_triangles),
            weld_tolerance=params.weld_tolerance,
        )
        for note in res.notes:
            ctx.warn(note)
        return {"mesh": res.mesh}


@register
class SketchNode(Node):
    """A thin-wall part given by its midsurface: 2D curves extruded along +Z from z0 by height.

    JSON `{"curves": [[[x, y], ...], ...]}` (optional "height", "z0" in the file's units; a
    closed curve repeats its first point) or DXF (LINE, LWPOLYLINE with bulges, POLYLINE, ARC,
    CIRCLE, ELLIPSE, SPLINE, block INSERTs; arcs discretised within `arc_tolerance`). Curves
    meeting end to end (exactly two ends at a point) are joined into one polyline. DXF entities
    without curve geometry (TEXT, DIMENSION, HATCH, ...) and zero-length ones are skipped with a
    warning.
    """

    type = "sketch"
    title = "Sketch (midsurface)"
    category = "inputs"
    outputs = (Port("mesh", "mesh", "Midsurface: curves extruded along +Z (Midsurface), mm"),)

    class Params(NodeParams):
        path: FileRef = Field(description="Sketch file (.json or .dxf), relative to the recipe")
        height: float | None = Field(None, gt=0, le=10_000,
                                     description="Extrusion height; default: the JSON file's 'height'",
                                     json_schema_extra=unit("mm"))
        z0: float | None = Field(None, ge=-10_000, le=10_000,
                                 description="Bottom of the extrusion; default: the JSON file's 'z0', else 0",
                                 json_schema_extra=unit("mm"))
        units: LengthUnit = Field("auto", description="Length unit of the file's coordinates (auto: DXF $INSUNITS, else mm)")
        layout: str = Field("Model", min_length=1, max_length=255,
                            description="DXF layout to read: Model (modelspace) or a paperspace layout's name")
        arc_tolerance: float = Field(0.01, gt=0, le=10, description="Max chordal deviation when discretising arcs",
                                     json_schema_extra=unit("mm"))
        join: bool = Field(True, description="Join curves that meet end to end into one polyline")
        max_file_mb: float = Field(50.0, gt=0, le=512, description="Refuse larger files", json_schema_extra=unit("MB"))

    def run(self, ctx, params, inputs):
        data = ctx.read_bytes(params.path, max_bytes=int(params.max_file_mb * 2**20))
        res = load_sketch_bytes(
            data, params.path, height=params.height, z0=params.z0,
            units=None if params.units == "auto" else params.units,
            arc_tolerance=params.arc_tolerance, join=params.join, layout=params.layout,
        )
        if res.skipped:
            ctx.warn(f"{params.path}: skipped DXF entities (no curve geometry or zero length): {skipped_text(res.skipped)}")
        for note in res.notes:
            ctx.warn(note)
        return {"mesh": res.midsurface}

