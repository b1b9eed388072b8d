"""DXF drawings read through ezdxf: a layout's curves as polylines in file units, the arcs
discretised within a chordal tolerance (used by the sketch node, `sketch.py`).

A chord spanning angle Δ of radius r has sagitta r·(1 − cos(Δ/2)), hence Δ ≤ 2·acos(1 − tol/r).
LINE, LWPOLYLINE (with bulges), POLYLINE (2D with bulges, 3D), ARC, CIRCLE, ELLIPSE, SPLINE and
INSERT/MINSERT (exploded through ezdxf's `multi_insert`/`virtual_entities`); entities in an OCS
(extrusion ±Z) are mapped to world coordinates; entities without curve geometry and those on
layers the drawing hides (off or frozen) are skipped and counted, degenerate ones named (type, handle, why); what ezdxf's recover/audit repaired is said.
"""

from __future__ import annotations

import io
import math
import re

import numpy as np

from ..core.errors import InputFileError
from ..core.tolerances import TOL


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


def dedupe(points: np.ndarray) -> np.ndarray:
    if len(points) < 2:
        return points
    keep = np.concatenate([[True], np.linalg.norm(np.diff(points, axis=0), axis=1) > TOL.merge])
    return points[keep]


# ------------------------------------------------------------------------------------------
# DXF
# ------------------------------------------------------------------------------------------
_ACADVER = re.compile(rb"^[ \t]*9[ \t]*\r?\n[ \t]*\$ACADVER\b", re.MULTILINE)
_SUBCLASS = re.compile(rb"^[ \t]*100[ \t]*\r?\n[ \t]*AcDb", re.MULTILINE)
_HEADER = re.compile(
    rb"^[ \t]*0[ \t]*\r?\n[ \t]*SECTION[ \t]*\r?\n[ \t]*2[ \t]*\r?\n[ \t]*HEADER[ \t]*\r?\n", re.MULTILINE
)
_R2000 = b"  9\n$ACADVER\n  1\nAC1015\n"


def declared_version(data: bytes) -> tuple[bytes, str | None]:
    """(data, note): an ASCII DXF that declares no version ($ACADVER) but writes R2000 subclass
    markers (100 AcDb…) gets `$ACADVER AC1015` in its HEADER (one made when it has none), and a
    note saying so; else the data unchanged and None. ezdxf reads a file without $ACADVER as R12,
    where LWPOLYLINE, SPLINE and MULTILEADER do not exist, and refuses the file ("missing
    'AcDbPolyline' subclass"); CAD programs and other readers take the markers as the version."""
    if _ACADVER.search(data) or not _SUBCLASS.search(data):
        return data, None
    head = _HEADER.search(data)
    if head:
        data = data[: head.end()] + _R2000 + data[head.end() :]
    else:
        data = b"  0\nSECTION\n  2\nHEADER\n" + _R2000 + b"  0\nENDSEC\n" + data
    return data, (
        "read as DXF R2000: the file declares no version ($ACADVER) and its entities carry R2000 "
        "subclass markers (100 AcDb…)"
    )


def unplaced_blocks(doc) -> str:
    """'; …' naming the named blocks that hold entities, when a layout placed none (a block
    library, or a drawing whose content lives in blocks only), else ''."""
    named = [b.name for b in doc.blocks if not b.name.startswith("*") and len(b)]
    if not named:
        return ""
    shown = ", ".join(repr(n) for n in named[:3]) + (f" and {len(named) - 3} more" if len(named) > 3 else "")
    return (
        f"; the file defines {len(named)} block(s) of entities ({shown}) but places none in this layout: "
        "insert the block that is the part (INSERT) in the modelspace, or save the part's own drawing"
    )


def read_dxf_audited(data: bytes, filename: str):
    """(ezdxf document, repairs): the document read in ezdxf's recover mode (ASCII) or read and
    audited (binary), and every fix and unfixed error its auditor reports, as text naming the
    entity (ezdxf's own messages, e.g. 'Removed invalid color index of LINE(#2F).')."""
    from ezdxf import recover
    from ezdxf.lldxf.const import DXFStructureError

    note = None
    try:
        if data.startswith(b"AutoCAD Binary DXF"):
            # binary DXF: ezdxf.readfile detects and reads it (the recover module reads ASCII only)
            import ezdxf

            from .through_file import read_through_file

            doc = read_through_file(data, ".dxf", ezdxf.readfile)
            auditor = doc.audit()
        else:
            data, note = declared_version(data)
            doc, auditor = recover.read(io.BytesIO(data))
    except (DXFStructureError, UnicodeDecodeError, ValueError, OSError) as exc:
        raise InputFileError(f"{filename}: not a readable DXF file: {exc}") from exc
    repairs = [note] if note else []
    repairs += [f"repaired: {f.message}" for f in auditor.fixes]
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
    hidden = hidden_layers(doc)
    for e in dxf_layout(doc, layout, filename):
        if not _hidden(e, hidden, skipped):
            _entity_curves(e, filename, tol, curves, skipped, depth=0, defects=sink, repairs=fixed, hidden=hidden)
    return curves, skipped


def hidden_layers(doc) -> dict[str, str]:
    """Layer name (lower case) → 'off', 'frozen' or 'off, frozen' for the layers the drawing hides:
    what is drawn there (construction lines, a second variant) is not shown, so not a wall."""
    out = {}
    for layer in doc.layers:
        state = ", ".join(w for w, on in (("off", layer.is_off()), ("frozen", layer.is_frozen())) if on)
        if state:
            out[layer.dxf.name.lower()] = state
    return out


def _hidden(e, hidden: dict[str, str], skipped: dict) -> bool:
    """True (and counted as "TYPE on layer 'NAME' (off)") when `e` lies on a hidden layer."""
    name = e.dxf.get("layer", "0")
    state = hidden.get(name.lower()) if hidden else None
    if state is None:
        return False
    key = f"{e.dxftype()} on layer '{name}' ({state})"
    skipped[key] = skipped.get(key, 0) + 1
    return True


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
    pts = dedupe(np.asarray(pts, dtype=float))
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
    hidden: dict[str, str] | None = None,
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
            cycle = _block_cycle(e.doc, e.dxf.get("name", "")) if e.doc is not None else None
            if cycle:
                raise InputFileError(
                    f"{_where(filename, e)}: block '{cycle[0]}' places itself ({' → '.join(cycle)}): a block "
                    "cannot hold itself; fix the block in CAD"
                )
            raise InputFileError(f"{_where(filename, e)}: block references nested deeper than 16 levels")
        # MINSERT: one virtual INSERT per grid cell (ezdxf's multi_insert; a plain INSERT: itself)
        for ins in e.multi_insert() if e.mcount > 1 else (e,):
            subs = _block_entities(ins, skipped, defects, repairs)
            for sub in subs:
                if not _hidden(sub, hidden or {}, skipped):
                    _entity_curves(sub, filename, tol, out, skipped, depth + 1, defects, repairs, hidden)
    else:
        skipped[t] = skipped.get(t, 0) + 1


def _block_cycle(doc, name: str) -> list[str] | None:
    """The blocks from `name` round to a block that places itself again (['A', 'B', 'A']), or None:
    what a reference nested past any sensible depth usually is (vagran/dxf-viewer's
    block-recursive.dxf), named instead of "nested deeper than 16 levels"."""
    path: list[str] = []

    def visit(n: str) -> list[str] | None:
        if n in path:
            return path[path.index(n) :] + [n]
        blk = doc.blocks.get(n)
        if blk is None:
            return None
        path.append(n)
        for ins in blk.query("INSERT"):
            found = visit(ins.dxf.get("name", ""))
            if found:
                return found
        path.pop()
        return None

    return visit(name)


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
