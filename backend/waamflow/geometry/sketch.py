"""Sketches: 2D curves extruded along +Z to a midsurface (thin-wall parts), from JSON or DXF.

JSON: ``{"curves": [[[x, y], ...], ...], "height": h, "z0": z}`` ("height", "z0" optional; the
node's params win). A closed curve repeats its first point.

DXF (a layout, via ezdxf; `dxf.py`): LINE, LWPOLYLINE, POLYLINE, ARC, CIRCLE, ELLIPSE, SPLINE
and block INSERT/MINSERT, arcs discretised within `arc_tolerance`; entities without geometry for
a midsurface (TEXT, DIMENSION, HATCH, POINT, ...) are skipped and reported. Open curves that meet end to end, with exactly two ends at the meeting point, are
joined into one polyline (a DXF outline drawn as separate LINEs/ARCs is one wall); points where
three or more ends meet stay curve ends, they are wall junctions. Ends within `TOL.join` (mm)
meet.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import PurePosixPath
from typing import Any, Iterable

import numpy as np

from ..core.errors import InputFileError
from ..core.model import Midsurface
from ..core.tolerances import TOL
from .dxf import dedupe, dxf_doc_curves, dxf_layout, read_dxf_audited, unplaced_blocks
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
# Curve clean-up and joining
# ------------------------------------------------------------------------------------------
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
        a = dedupe(a * scale)
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
                    "as lines and arcs in the XY plane" + unplaced_blocks(doc)
                )
        file_h = file_z0 = None
    elif ext in ("step", "stp", "iges", "igs"):
        curves, file_h, file_z0, file_unit, units, scale, notice = _cad_curves(data, filename, units, arc_tolerance)
    else:
        raise InputFileError(f"{filename}: unsupported sketch format {ext!r}; use one of {', '.join(SKETCH_FORMATS)}")
    if not curves and (skipped or defects):
        kinds = ", ".join(f"{n} {t}" for t, n in sorted(skipped.items()))
        raise InputFileError(
            f"{filename}: no curves in layout {layout!r}; skipped entities (no curve geometry, degenerate or "
            f"on a hidden layer): {kinds or 'none'}"
            + (f"; degenerate: {'; '.join(defects[:5])}" if defects else "")
            + ("; turn the layer on (and thaw it) in CAD to read what it holds" if " on layer '" in kinds else "")
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
