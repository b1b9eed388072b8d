"""Sketches: 2D curves extruded along +Z to a midsurface (thin-wall parts), from JSON or DXF.

JSON: ``{"curves": [[[x, y], ...], ...], "height": h, "z0": z}`` ("height", "z0" optional; the
node's params win). A closed curve repeats its first point.

DXF (modelspace, via ezdxf): LINE, LWPOLYLINE (with bulges), POLYLINE (2D with bulges, 3D),
ARC, CIRCLE, plus ELLIPSE and SPLINE, and INSERT/MINSERT (block references and
arrays of them, exploded through ezdxf's `multi_insert`/`virtual_entities`). Arcs are
discretised so that no chord deviates from the true arc by more than `arc_tolerance`: a chord
spanning angle Δ of radius r has sagitta r·(1 − cos(Δ/2)), hence Δ ≤ 2·acos(1 − tol/r).
Entities in an OCS (extrusion ±Z, e.g. mirrored arcs) are mapped to world coordinates.
Entities without geometry for a midsurface (TEXT, DIMENSION, HATCH, POINT, ...) are skipped and
reported. Open curves that meet end to end, with exactly two ends at the meeting point, are
joined into one polyline (a DXF outline drawn as separate LINEs/ARCs is one wall); points where
three or more ends meet stay curve ends, they are wall junctions. Ends within `TOL.join` (mm)
meet.
"""

from __future__ import annotations

import io
import json
import math
from dataclasses import dataclass
from pathlib import PurePosixPath
from typing import Any, Iterable

import numpy as np

from ..core.errors import InputFileError
from ..core.model import Midsurface
from ..core.tolerances import TOL
from .units import conversion_notice, dxf_units

SKETCH_FORMATS = ("json", "dxf", "step", "stp", "iges", "igs")


@dataclass(frozen=True)
class SketchResult:
    """midsurface: the extruded curves (mm). skipped: DXF entity types ignored → count.
    units: the length unit the file's coordinates were read in."""

    midsurface: Midsurface
    skipped: dict[str, int]
    units: str = "mm"
    file_unit: str | None = None  # the unit the file declares (DXF $INSUNITS), None: none
    notice: str | None = None  # the unit conversion, said (units.conversion_notice)
    defects: tuple[str, ...] = ()  # DXF entities skipped as degenerate, each naming type, handle and why
    repairs: tuple[str, ...] = ()  # what ezdxf's recover/audit repaired while reading the DXF


# ------------------------------------------------------------------------------------------
# Arc discretisation
# ------------------------------------------------------------------------------------------
def arc_segments(radius: float, sweep: float, tol: float) -> int:
    """Number of chords for an arc of `radius` (mm) and |sweep| (rad) with sagitta ≤ tol (mm)."""
    sweep = abs(sweep)
    if radius <= tol:
        return max(1, math.ceil(sweep / (math.pi / 2)))
    max_step = 2.0 * math.acos(1.0 - tol / radius)
    return max(1, math.ceil(sweep / max_step - 1e-9))


def arc_points(center, radius: float, start: float, sweep: float, tol: float) -> np.ndarray:
    """(k, 2) points along an arc from angle `start` (rad) by `sweep` (rad, + = CCW)."""
    n = arc_segments(radius, sweep, tol)
    if abs(sweep) >= 2 * math.pi - 1e-12:
        n = max(n, 3)
    t = start + sweep * np.linspace(0.0, 1.0, n + 1)
    return np.column_stack([center[0] + radius * np.cos(t), center[1] + radius * np.sin(t)])


def bulge_points(p0, p1, bulge: float, tol: float) -> np.ndarray:
    """(k, 2) points from p0 to p1 along the DXF bulge arc (bulge = tan(sweep/4), + = CCW)."""
    p0 = np.asarray(p0, dtype=float)
    p1 = np.asarray(p1, dtype=float)
    chord = float(np.hypot(*(p1 - p0)))
    if bulge == 0.0 or chord == 0.0:
        return np.array([p0, p1])
    sweep = 4.0 * math.atan(bulge)
    radius = chord / (2.0 * math.sin(abs(sweep) / 2.0))
    mid = (p0 + p1) / 2.0
    d = (p1 - p0) / chord
    left = np.array([-d[1], d[0]])
    # signed offset of the centre from the chord midpoint, + = left of p0→p1: a CCW arc under
    # half a turn has its centre on the left; past half a turn (cos < 0) it flips side.
    h = (1.0 if bulge > 0 else -1.0) * radius * math.cos(abs(sweep) / 2.0)
    center = mid + left * h
    start = math.atan2(p0[1] - center[1], p0[0] - center[0])
    pts = arc_points(center, radius, start, sweep, tol)
    pts[0], pts[-1] = p0, p1
    return pts


# ------------------------------------------------------------------------------------------
# Curve clean-up and joining
# ------------------------------------------------------------------------------------------
def _dedupe(points: np.ndarray) -> np.ndarray:
    if len(points) < 2:
        return points
    keep = np.concatenate([[True], np.linalg.norm(np.diff(points, axis=0), axis=1) > TOL.merge])
    return points[keep]


def join_curves(curves: list[np.ndarray], tol: float, joints: list | None = None) -> list[np.ndarray]:
    """Join open polylines that meet end to end at points where exactly two ends meet.

    curves: (k, 2) arrays; closed ones (first == last within tol) are kept as they are.
    joints: when given, receives each (x, y) point where two curves were joined (a wall junction
    that is now a vertex inside one polyline; feature recognition reports it).
    Loops over curves (entities), never over points.
    """
    from scipy.spatial import cKDTree

    closed = [c for c in curves if np.linalg.norm(c[0] - c[-1]) <= tol and len(c) > 2]
    open_ = [c for c in curves if not (np.linalg.norm(c[0] - c[-1]) <= tol and len(c) > 2)]
    if len(open_) < 2:
        return closed + open_
    ends = np.array([[c[0], c[-1]] for c in open_]).reshape(-1, 2)
    parent = np.arange(len(ends))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in cKDTree(ends).query_pairs(tol):
        ri, rj = find(i), find(j)
        if ri != rj:
            parent[max(ri, rj)] = min(ri, rj)
    node = np.array([find(i) for i in range(len(ends))])
    degree = np.bincount(node, minlength=len(ends))
    at_node: dict[int, list[int]] = {}
    for e, n in enumerate(node):
        at_node.setdefault(int(n), []).append(e)

    used = np.zeros(len(open_), dtype=bool)

    def oriented(ci: int, from_end: int) -> np.ndarray:
        """Curve ci walked starting at its end `from_end` (0 = its first point, 1 = its last)."""
        c = open_[ci]
        return c if from_end == 0 else c[::-1]

    def walk(ci: int, leave_end: int) -> tuple[list[np.ndarray], int]:
        """Follow the chain from curve ci's end `leave_end` through degree-2 nodes."""
        parts: list[np.ndarray] = []
        while True:
            n = node[2 * ci + leave_end]
            if degree[n] != 2:
                return parts, n
            other = [e for e in at_node[int(n)] if e != 2 * ci + leave_end]
            if not other:
                return parts, n
            nxt, nxt_end = divmod(other[0], 2)
            if used[nxt]:
                return parts, n
            used[nxt] = True
            parts.append(oriented(nxt, nxt_end))
            ci, leave_end = nxt, 1 - nxt_end

    out = list(closed)
    for ci in range(len(open_)):
        if used[ci]:
            continue
        used[ci] = True
        fwd, _ = walk(ci, 1)
        back, _ = walk(ci, 0)
        chain = [p[::-1] for p in reversed(back)] + [open_[ci]] + fwd
        pts = np.vstack([chain[0]] + [p[1:] for p in chain[1:]])
        if joints is not None:
            joints.extend((float(p[0][0]), float(p[0][1])) for p in chain[1:])
        if len(chain) > 1 and np.linalg.norm(pts[0] - pts[-1]) <= tol:
            pts[-1] = pts[0]
            if joints is not None:
                joints.append((float(pts[0][0]), float(pts[0][1])))
        out.append(pts)
    return out


# ------------------------------------------------------------------------------------------
# Midsurface construction
# ------------------------------------------------------------------------------------------
def sketch_from_curves(
    curves: Iterable[Any],
    *,
    height: float,
    z0: float = 0.0,
    name: str = "sketch",
    scale: float = 1.0,
    join_tol: float | None = None,
) -> Midsurface:
    """Midsurface from polylines (each (k, 2) in file units, × scale → mm), extruded by height (mm)."""
    if not (height > 0 and math.isfinite(height)):
        raise InputFileError(f"{name}: extrusion height must be > 0 mm (got {height})")
    out = []
    for i, c in enumerate(curves):
        try:
            a = np.asarray(c, dtype=float)
        except (TypeError, ValueError):
            raise InputFileError(f"{name}: curve {i} is not a list of [x, y] points") from None
        if a.ndim != 2 or a.shape[1] != 2:
            raise InputFileError(f"{name}: curve {i} must be a list of [x, y] points (got shape {a.shape})")
        if not np.isfinite(a).all():
            raise InputFileError(f"{name}: curve {i} has non-finite coordinates")
        a = _dedupe(a * scale)
        if len(a) < 2:
            raise InputFileError(f"{name}: curve {i} has fewer than two distinct points")
        out.append(a)
    if not out:
        raise InputFileError(f"{name}: sketch has no curves")
    joints: list = []
    if join_tol is not None:
        out = join_curves(out, join_tol, joints)
    return Midsurface(curves=tuple(out), height=float(height), z0=float(z0), name=name, joints=tuple(joints))


def _json_curves(data: bytes, filename: str) -> tuple[list, float | None, float | None]:
    try:
        doc = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputFileError(f"{filename}: not valid JSON: {exc}") from exc
    if not isinstance(doc, dict) or not isinstance(doc.get("curves"), list):
        raise InputFileError(f'{filename}: expected an object {{"curves": [[[x, y], ...], ...]}}')
    nums = {}
    for k in ("height", "z0"):
        v = doc.get(k)
        if v is not None and not isinstance(v, (int, float)):
            raise InputFileError(f"{filename}: '{k}' must be a number (got {v!r})")
        nums[k] = None if v is None else float(v)
    return doc["curves"], nums["height"], nums["z0"]


def load_sketch_bytes(
    data: bytes,
    filename: str,
    *,
    height: float | None = None,
    z0: float | None = None,
    units: str = "mm",
    arc_tolerance: float = 0.01,
    join: bool = True,
    layout: str = "Model",
) -> SketchResult:
    """Parse a JSON or DXF sketch into a Midsurface in mm.

    units: the file's length unit, or "file": the DXF's $INSUNITS (mm when unitless; JSON: mm).
    height, z0: mm; when None, taken from the JSON file (in file units); height is required one
    way or the other, z0 defaults to 0. arc_tolerance: max chordal deviation of arcs (mm).
    """
    ext = PurePosixPath(filename).suffix.lower().lstrip(".")
    name = PurePosixPath(filename).stem
    skipped: dict[str, int] = {}
    defects: list[str] = []
    repairs: list[str] = []
    file_unit = None
    if ext == "json":
        units, scale, notice = conversion_notice(None, units)
        raw, file_h, file_z0 = _json_curves(data, filename)
        curves = raw
    elif ext == "dxf":
        doc, repairs = read_dxf_audited(data, filename)
        file_unit = dxf_units(doc)
        units, scale, notice = conversion_notice(file_unit, units)
        # DXF coordinates are in file units; discretise with the tolerance in file units
        curves, skipped = dxf_doc_curves(doc, filename, arc_tolerance / scale, layout, defects, repairs)
        if not curves:
            others = [
                f"{lay.name} ({len(lay)} entities)"
                for lay in doc.layouts
                if lay.name.lower() != layout.lower() and len(lay)
            ]
            if others:
                raise InputFileError(
                    f"{filename}: no curves in layout {layout!r}"
                    + (f" (skipped: {', '.join(f'{n} {t}' for t, n in sorted(skipped.items()))})" if skipped else "")
                    + f"; other layouts with entities: {', '.join(others)} — set the node's 'layout'"
                )
            if not skipped and not defects:  # it had said only "sketch has no curves"
                held = sum(1 for _ in dxf_layout(doc, layout, filename))
                raise InputFileError(
                    f"{filename}: no curves in layout {layout!r} ({held} entities, none a LINE, ARC, CIRCLE, "
                    "(LW)POLYLINE, ELLIPSE, SPLINE or a block of them): a sketch is the walls' midsurface drawn "
                    "as lines and arcs in the XY plane"
                )
        file_h = file_z0 = None
    elif ext in ("step", "stp", "iges", "igs"):
        curves, file_h, file_z0, file_unit, units, scale, notice = _cad_curves(data, filename, units, arc_tolerance)
    else:
        raise InputFileError(f"{filename}: unsupported sketch format {ext!r}; use one of {', '.join(SKETCH_FORMATS)}")
    if not curves and (skipped or defects):
        kinds = ", ".join(f"{n} {t}" for t, n in sorted(skipped.items()))
        raise InputFileError(
            f"{filename}: no curves in layout {layout!r}; skipped entities without curve geometry: "
            f"{kinds or 'none'}" + (f"; degenerate: {'; '.join(defects[:5])}" if defects else "")
        )
    if height is None:
        if file_h is None:
            raise InputFileError(f"{filename}: no extrusion height: set the node's 'height' param (mm)")
        height = file_h * scale
    if z0 is None:
        z0 = (file_z0 or 0.0) * scale
    mid = sketch_from_curves(
        curves, height=height, z0=z0, name=filename, scale=scale, join_tol=(TOL.join if join else None)
    )
    return SketchResult(
        midsurface=Midsurface(curves=mid.curves, height=mid.height, z0=mid.z0, name=name, joints=mid.joints),
        skipped=skipped,
        units=units,
        file_unit=file_unit,
        notice=notice,
        defects=tuple(defects),
        repairs=tuple(repairs),
    )


def _cad_curves(data: bytes, filename: str, units: str, arc_tolerance: float):
    """(curves in OpenCascade's mm, height, z0, file unit, unit applied, scale, notice) of a STEP/IGES
    midsurface: the bottom curves of vertical wall faces with their height, or, in a file without
    faces, its curves (IGES 126 B-splines, 110 lines, 100 arcs) in one horizontal plane at its z."""
    from .step_io import planar_curves, read_cad_shape, unit_rescale, vertical_midsurface

    cad = read_cad_shape(data, filename)
    units, scale, notice = unit_rescale(cad.file_unit, units)
    if cad.faces:
        cc, why = vertical_midsurface(cad, arc_tolerance / scale)
        if cc is None:
            raise InputFileError(
                f"{filename}: the faces are not a midsurface of vertical walls ({why}); read the "
                "file with a 'mesh' node ('as': 'surface') for a tessellated single-wall surface"
            )
    else:
        cc = planar_curves(cad, arc_tolerance / scale, filename)
    return cc.curves, cc.height, cc.z0, cad.file_unit, units, scale, notice


# ------------------------------------------------------------------------------------------
# DXF
# ------------------------------------------------------------------------------------------
def read_dxf_audited(data: bytes, filename: str):
    """(ezdxf document, repairs): the document read in ezdxf's recover mode (ASCII) or read and
    audited (binary), and every fix and unfixed error its auditor reports, as text naming the
    entity (ezdxf's own messages, e.g. 'Removed invalid color index of LINE(#2F).')."""
    from ezdxf import recover
    from ezdxf.lldxf.const import DXFStructureError

    try:
        if data.startswith(b"AutoCAD Binary DXF"):
            # binary DXF: ezdxf.readfile detects and reads it (the recover module reads ASCII only)
            import ezdxf

            from .through_file import read_through_file

            doc = read_through_file(data, ".dxf", ezdxf.readfile)
            auditor = doc.audit()
        else:
            doc, auditor = recover.read(io.BytesIO(data))
    except (DXFStructureError, UnicodeDecodeError, ValueError, OSError) as exc:
        raise InputFileError(f"{filename}: not a readable DXF file: {exc}") from exc
    repairs = [f"repaired: {f.message}" for f in auditor.fixes]
    repairs += [f"unrepaired error: {e.message}" for e in auditor.errors]
    return doc, repairs


def dxf_layout(doc, layout: str, filename: str):
    """The layout named `layout` ("Model" / "modelspace" = the modelspace, else a paperspace
    layout's name), or InputFileError listing the layouts the file has."""
    if layout.lower() in ("model", "modelspace"):
        return doc.modelspace()
    names = list(doc.layouts.names())
    for n in names:
        if n.lower() == layout.lower():
            return doc.layouts.get(n)
    raise InputFileError(f"{filename}: no layout {layout!r}; the file has: {', '.join(names)}")


def dxf_doc_curves(
    doc, filename: str, tol: float, layout: str = "Model", defects: list | None = None, repairs: list | None = None
) -> tuple[list[np.ndarray], dict[str, int]]:
    """Polylines (k, 2) in file units from a layout of an ezdxf document (default: the
    modelspace), and the skipped entity types → count. defects (optional list) receives one
    text per degenerate entity skipped (zero radius, fewer than two vertices, a spline or ellipse
    that cannot be discretised), naming its type and handle; they are skipped either way. repairs
    (optional list) receives what was read otherwise than written (a block placed with z scale 0)."""
    curves: list[np.ndarray] = []
    skipped: dict[str, int] = {}
    sink = [] if defects is None else defects
    fixed = [] if repairs is None else repairs
    for e in dxf_layout(doc, layout, filename):
        _entity_curves(e, filename, tol, curves, skipped, depth=0, defects=sink, repairs=fixed)
    return curves, skipped


def _where(filename: str, e) -> str:
    return f"{filename}: {_entity(e)}"


def _entity(e) -> str:
    """'CIRCLE (handle 30, layer WALLS)': how messages name a DXF entity (an entity exploded from a
    block reference has no handle of its own: its block is named instead)."""
    handle = e.dxf.get("handle", None)
    layer = e.dxf.get("layer", None)
    src = f"handle {handle}" if handle else "in a block reference"
    return f"{e.dxftype()} ({src}" + (f", layer {layer})" if layer else ")")


def _skip(defects: list, skipped: dict, e, why: str) -> None:
    """Skip a degenerate entity: counted under its type and named with its handle in defects."""
    key = f"degenerate {e.dxftype()}"
    skipped[key] = skipped.get(key, 0) + 1
    defects.append(f"{_entity(e)}: {why}")


def _ocs_to_xy(e, pts2d: np.ndarray, filename: str) -> np.ndarray:
    """OCS (x, y) points of a planar entity → world (x, y); the entity must lie in an XY plane."""
    extr = np.asarray(e.dxf.get("extrusion", (0.0, 0.0, 1.0)), dtype=float)
    if abs(abs(extr[2]) - np.linalg.norm(extr)) > 1e-9:
        x, y, z = (float(v) for v in extr)
        raise InputFileError(
            f"{_where(filename, e)} does not lie in an XY plane (its extrusion direction is "
            f"({x:g}, {y:g}, {z:g}), not ±Z): a sketch is drawn in the XY plane; rotate or flatten "
            "the entity in CAD (world UCS) or delete it"
        )
    if extr[2] > 0:
        return pts2d
    # OCS of extrusion (0, 0, -1): x axis is world -x (arbitrary axis algorithm), y stays world y
    return np.column_stack([-pts2d[:, 0], pts2d[:, 1]])


def _add(out: list, skipped: dict, kind: str, pts: np.ndarray) -> None:
    """Keep a curve unless it has no length (zero-length LINEs are common CAD debris)."""
    pts = _dedupe(np.asarray(pts, dtype=float))
    if len(pts) < 2:
        key = f"zero-length {kind}"
        skipped[key] = skipped.get(key, 0) + 1
        return
    out.append(pts)


def _entity_curves(
    e,
    filename: str,
    tol: float,
    out: list,
    skipped: dict,
    depth: int,
    defects: list | None = None,
    repairs: list | None = None,
) -> None:
    defects = [] if defects is None else defects
    t = e.dxftype()
    if t == "LINE":
        s, n = e.dxf.start, e.dxf.end
        _add(out, skipped, t, np.array([[s.x, s.y], [n.x, n.y]]))
    elif t == "LWPOLYLINE":
        pts = np.array([(x, y, b) for x, y, b in e.get_points("xyb")], dtype=float).reshape(-1, 3)
        if len(pts) < 2:
            return _skip(defects, skipped, e, f"{len(pts)} vertex, a curve needs two; skipped")
        _add(out, skipped, t, _ocs_to_xy(e, _bulge_polyline(pts, bool(e.closed), tol, filename, e), filename))
    elif t == "POLYLINE":
        if e.is_2d_polyline:
            pts = np.array(
                [(v.dxf.location.x, v.dxf.location.y, v.dxf.get("bulge", 0.0)) for v in e.vertices], dtype=float
            ).reshape(-1, 3)
            if len(pts) < 2:
                return _skip(defects, skipped, e, f"{len(pts)} vertex, a curve needs two; skipped")
            _add(out, skipped, t, _ocs_to_xy(e, _bulge_polyline(pts, bool(e.is_closed), tol, filename, e), filename))
        elif e.is_3d_polyline:
            pts = np.array([(v.dxf.location.x, v.dxf.location.y) for v in e.vertices], dtype=float).reshape(-1, 2)
            if e.is_closed and len(pts):
                pts = np.vstack([pts, pts[:1]])
            _add(out, skipped, t, pts)
        else:  # polyface / polygon mesh: a surface, no curve of a sketch
            key = "POLYLINE mesh"
            skipped[key] = skipped.get(key, 0) + 1
    elif t in ("ARC", "CIRCLE"):
        r = float(e.dxf.radius)
        if not r > 0:
            return _skip(
                defects,
                skipped,
                e,
                f"radius {r:g}, no curve; skipped (delete it in CAD if it is debris, or give it its radius)",
            )
        c = e.dxf.center
        if t == "CIRCLE":
            start, sweep = 0.0, 2 * math.pi
        else:
            start = math.radians(e.dxf.start_angle)
            sweep = math.radians((e.dxf.end_angle - e.dxf.start_angle) % 360.0) or 2 * math.pi
        pts = arc_points((c.x, c.y), r, start, sweep, tol)
        if t == "CIRCLE":
            pts[-1] = pts[0]
        _add(out, skipped, t, _ocs_to_xy(e, pts, filename))
    elif t in ("ELLIPSE", "SPLINE"):
        try:
            pts = np.array([(v.x, v.y) for v in e.flattening(tol)], dtype=float)
        except Exception:  # ezdxf raises construction errors (even IndexError) for degenerate curves
            return _skip(
                defects,
                skipped,
                e,
                "degenerate (too few distinct control or fit points, or a zero axis): "
                "ezdxf cannot discretise it; skipped (redraw or delete it in CAD)",
            )
        _add(out, skipped, t, pts)
    elif t == "INSERT":
        if depth > 16:
            raise InputFileError(f"{_where(filename, e)}: block references nested deeper than 16 levels")
        # MINSERT: one virtual INSERT per grid cell (ezdxf's multi_insert; a plain INSERT: itself)
        for ins in e.multi_insert() if e.mcount > 1 else (e,):
            subs = _block_entities(ins, skipped, defects, repairs)
            for sub in subs:
                _entity_curves(sub, filename, tol, out, skipped, depth + 1, defects, repairs)
    else:
        skipped[t] = skipped.get(t, 0) + 1


def _block_entities(ins, skipped: dict, defects: list, repairs: list | None) -> list:
    """The entities a block reference places. A zero z scale (a flat block, as some exporters
    write it) leaves a sketch's x and y as they are but cannot be inverted: ezdxf stopped with a
    bare ZeroDivisionError (ezdxf's insert_zscale0.dxf); it is read as 1 and named in the
    defects. A zero x or y scale collapses the block, and a transform ezdxf cannot apply skips
    the reference, each named."""
    sx, sy, sz = (float(ins.dxf.get(k, 1.0)) for k in ("xscale", "yscale", "zscale"))
    name = ins.dxf.get("name", "?")
    if sx == 0 or sy == 0:
        _skip(
            defects,
            skipped,
            ins,
            f"block '{name}' placed at scale ({sx:g}, {sy:g}, {sz:g}): a zero x or y "
            "scale collapses it to nothing; skipped (fix its scale in CAD)",
        )
        return []
    if sz == 0:
        label = _entity(ins)  # the copy has no handle
        ins = ins.copy()
        ins.dxf.zscale = 1.0
        if repairs is not None:
            repairs.append(
                f"{label}: block '{name}' placed with z scale 0: read as 1 (a sketch's x and y do not depend on it)"
            )
    try:
        return list(ins.virtual_entities())
    except (ArithmeticError, ValueError) as exc:  # a transform ezdxf cannot build (a degenerate frame)
        _skip(defects, skipped, ins, f"block '{name}' cannot be placed ({type(exc).__name__}: {exc}); skipped")
        return []


def _bulge_polyline(pts: np.ndarray, closed: bool, tol: float, filename: str, e) -> np.ndarray:
    """(n, 3) rows (x, y, bulge) → (k, 2) polyline with bulge arcs discretised."""
    if len(pts) < 2:
        raise InputFileError(f"{_where(filename, e)}: has {len(pts)} vertex; a curve needs at least 2")
    n = len(pts)
    seg_count = n if closed else n - 1
    parts = [pts[:1, :2]]
    for i in range(seg_count):
        a, b = pts[i], pts[(i + 1) % n]
        seg = bulge_points(a[:2], b[:2], float(a[2]), tol)
        parts.append(seg[1:])
    out = np.vstack(parts)
    if closed:
        out[-1] = out[0]
    return out
