"""Loading solid parts: STL (binary and ASCII), OBJ, PLY, 3MF → `MeshData` in mm.

Binary STL is parsed here with one `np.frombuffer` on the 50-byte record dtype, ASCII STL with
one `np.fromstring` after blanking the keywords (falling back to trimesh if that fails), and both are welded with
`topology.merge_vertices`; every other format goes through trimesh (unprocessed) and is welded
the same way, so all formats give the same vertices/faces for the same part. Measured with
`bench/bench_slice.py` (`mesh_load_50mb_s`): a 50 MB binary STL (1 M triangles, 0.5 M vertices)
parses, welds and passes the closedness check in 0.4-0.5 s on the 2-core dev box when idle
(0.7-1.0 s at load average 4-8); `trimesh.load` of the same file takes 3x as long.

Refused with `InputFileError` (→ exit 2): unknown format, file over the size cap, more triangles
than the cap, no triangles, non-finite coordinates, and meshes that are not closed 2-manifolds
(open, non-manifold or inconsistently wound edges), since those cannot be sliced into closed
loops.
"""

from __future__ import annotations

import io
import logging
import warnings
from dataclasses import dataclass
from pathlib import PurePosixPath
from typing import Any, Callable

import numpy as np

from ..core.errors import InputFileError
from ..core.model import MeshData
from .topology import (
    EdgeReport,
    check_closed,
    drop_degenerate,
    edge_report_twins,
    edge_uses,
    face_components,
    face_volumes,
    merge_vertices,
    remember_topology,
    signed_volume,
    split_nonmanifold,
)
from .transform import Transform, unit_scale
from .units import threemf_units

MESH_FORMATS = ("stl", "obj", "ply", "off", "3mf")

# One binary STL record: normal, three corners (float32), attribute byte count (uint16).
STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attr", "<u2")])
assert STL_RECORD.itemsize == 50


@dataclass(frozen=True)
class MeshLimits:
    """Input caps. max_bytes: file size (bytes). max_triangles: triangle count."""

    max_bytes: int = 512 * 2**20
    max_triangles: int = 10_000_000


def mesh_format(filename: str) -> str:
    ext = PurePosixPath(filename).suffix.lower().lstrip(".")
    if ext not in MESH_FORMATS:
        raise InputFileError(f"{filename}: unsupported mesh format {ext!r}; use one of {', '.join(MESH_FORMATS)}")
    return ext


def is_binary_stl(data: bytes) -> bool:
    """Binary iff the triangle count in the header matches the file size exactly (ASCII files,
    even those whose 80-byte header starts with 'solid', practically never do)."""
    if len(data) < 84:
        return False
    n = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
    return 84 + 50 * n == len(data)


def binary_stl_triangles(data: bytes, *, filename: str = "mesh.stl", max_triangles: int | None = None) -> np.ndarray:
    """Corners of a binary STL: (m, 3, 3) float32, file units (a read-only view on `data`)."""
    n = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
    if max_triangles is not None and n > max_triangles:
        raise InputFileError(f"{filename}: {n} triangles exceed the cap of {max_triangles}")
    if 84 + 50 * n != len(data):
        raise InputFileError(
            f"{filename}: binary STL header says {n} triangles ({84 + 50 * n} bytes) but the file has {len(data)} bytes"
        )
    return np.frombuffer(data, dtype=STL_RECORD, count=n, offset=84)["corners"]


# bytes.translate table: every letter except the exponent marks e/E, and every whitespace, → " "
_STL_BLANK = bytes(ord(" ") if (chr(c).isalpha() and chr(c) not in "eE") or chr(c).isspace() else c for c in range(256))


def ascii_stl_triangles(data: bytes) -> np.ndarray | None:
    """Corners (m, 3, 3) float64 of an ASCII STL, or None when the file does not parse cleanly.

    Blanks the `solid <name>` lines, turns every keyword letter into a space with one
    `bytes.translate` (keeping e/E, the exponent marks, then dropping the e/E that follow a
    space, i.e. start a keyword letter run), and reads every number in one `np.fromstring`
    pass: 12 numbers per facet (normal, three vertices). 1.5-3x faster than trimesh's ASCII
    reader (55 MB, 200 k facets: 2.1 s vs 3.4 s on the loaded dev box). Anything unexpected (names with digits outside solid lines, nan) makes the count or
    the parse fail, and the caller falls back to trimesh.
    """
    text = bytearray(data)
    low = data.lower()  # SOLID / solid alike
    start = 0
    while (i := low.find(b"solid", start)) >= 0:  # one per body: a short Python loop
        j = low.find(b"\n", i)
        j = len(text) if j < 0 else j
        text[i:j] = b" " * (j - i)
        start = j
    body = bytes(text).translate(_STL_BLANK)
    while b" e" in body or b" E" in body:  # "ee"/"eE" in a keyword: repeat
        body = body.replace(b" e", b"  ").replace(b" E", b"  ")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a stray token warns: fall back
            nums = np.fromstring(body, dtype=np.float64, sep=" ")
    except (ValueError, DeprecationWarning):
        return None
    if nums.size == 0 or nums.size % 12:
        return None
    return nums.reshape(-1, 12)[:, 3:].reshape(-1, 3, 3)


class _Notes(logging.Handler):
    """The messages (no tracebacks) a library logs at WARNING and above while it reads a file."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        msg = record.getMessage().strip()
        if msg and msg not in self.messages:
            self.messages.append(msg)


def trimesh_triangles(data: bytes, fmt: str, *, filename: str, notes: list[str] | None = None) -> np.ndarray:
    """Corners of any trimesh-readable mesh or scene: (m, 3, 3) float64, file units. What trimesh
    logs while reading goes to `notes`, not to stderr: a PLY naming a texture it cannot find logged
    "unable to load image!" with a traceback, which the CLI printed."""
    import trimesh

    log = logging.getLogger("trimesh")
    catch = _Notes()
    propagate = log.propagate
    log.addHandler(catch)
    log.propagate = False
    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=fmt, process=False, force="mesh")
    except Exception as exc:  # trimesh raises many kinds on malformed input
        raise InputFileError(f"{filename}: cannot read {fmt.upper()} file: {exc}") from exc
    finally:
        log.removeHandler(catch)
        log.propagate = propagate
    if notes is not None:
        notes += catch.messages
    faces = getattr(loaded, "faces", None)
    if faces is None or len(faces) == 0:
        return np.zeros((0, 3, 3))
    # force="mesh" gives a Trimesh (typed as trimesh's Geometry base): its vertices, like its faces
    return np.asarray(getattr(loaded, "vertices"), dtype=np.float64)[np.asarray(faces)]


def read_triangles(
    data: bytes, filename: str, *, max_triangles: int | None = None, notes: list[str] | None = None
) -> np.ndarray:
    """Triangle corners (m, 3, 3) in file units, format chosen by the file extension; the reader's
    notes (trimesh's log) to `notes`."""
    fmt = mesh_format(filename)
    if is_binary_stl(data):  # by content: a binary STL named .obj too
        return binary_stl_triangles(data, filename=filename, max_triangles=max_triangles)
    if fmt == "stl" and not data.lstrip()[:5].lower() == b"solid":
        if len(data) >= 84:
            n = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
            raise InputFileError(
                f"{filename}: neither ASCII STL (no 'solid' header) nor binary STL "
                f"(header says {n} triangles = {84 + 50 * n} bytes, file has {len(data)} bytes)"
            )
        raise InputFileError(f"{filename}: too short to be an STL file ({len(data)} bytes)")
    tri = ascii_stl_triangles(data) if fmt == "stl" else None
    if tri is None:
        tri = trimesh_triangles(data, fmt, filename=filename, notes=notes)
    if fmt == "3mf" and not len(tri):
        from .threemf import items_as_components

        rewritten = items_as_components(data)
        if rewritten is not None:
            tri = trimesh_triangles(rewritten, fmt, filename=filename, notes=notes)
    if max_triangles is not None and len(tri) > max_triangles:
        raise InputFileError(f"{filename}: {len(tri)} triangles exceed the cap of {max_triangles}")
    return tri


def weld_open_edges(verts: np.ndarray, faces: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Merge vertices on open edges that lie within `tol` (vertex units) of each other.

    Only boundary vertices are candidates (a crack or seam gap is where open edges are), so a
    closed mesh costs one edge count and nothing else, and no interior detail is ever merged.
    Clusters are the connected components of the within-tol pairs (scipy cKDTree + csgraph);
    each takes the position of its lowest-index vertex. Returns (vertices, faces, number of
    vertices merged away)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    uniq, counts = np.unique(e, axis=0, return_counts=True)
    cand = np.unique(uniq[counts == 1])
    if len(cand) < 2:
        return verts, faces, 0
    pairs = cKDTree(verts[cand]).query_pairs(tol, output_type="ndarray")
    if len(pairs) == 0:
        return verts, faces, 0
    n = len(cand)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    ncomp, label = connected_components(graph, directed=False)
    first = np.full(ncomp, -1, dtype=np.int64)
    first[label[::-1]] = cand[::-1]  # the lowest-index member of each cluster
    remap = np.arange(len(verts))
    remap[cand] = first[label]
    keep = np.unique(remap)
    new_index = np.full(len(verts), -1, dtype=np.int64)
    new_index[keep] = np.arange(len(keep))
    faces = drop_degenerate(new_index[remap][faces])
    return verts[keep], faces, int(len(verts) - len(keep))


# A hole the repair fills: a missing facet or two (3 or 4 open edges, the common STL export
# defect), together at most this share of the mesh's surface. A box's missing lid is a quad too, but
# a sixth of its surface: an open cup, left as it is; longer holes are left too (a fan may cross a
# non-convex hole). With every hole filled the mesh must close, or nothing is filled.
MAX_HOLE_EDGES = 4
MAX_HOLE_SHARE = 0.01
MAX_OPEN_EDGES_FILLED = 4000  # more open edges than this: a surface's rim or a torn mesh, not a few facets


def _area(tri: np.ndarray) -> float:
    """The summed area of triangles (k, 3, 3)."""
    return float(0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum())


def fill_small_holes(verts: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, int]:
    """`faces` with every hole of 3 or 4 open edges closed (one or two triangles wound against
    the hole's edges, so they match their neighbours), when every open edge lies on such a hole
    and all of them together cover at most `MAX_HOLE_SHARE` of the surface; else `faces` as
    given. Returns (faces, holes filled)."""
    f = np.asarray(faces, dtype=np.int64)
    a, b = f.reshape(-1), f[:, [1, 2, 0]].reshape(-1)  # directed edge 3·face + i: corner i → i+1 (topology)
    _edges, counts, eid = edge_uses(f, len(verts))
    single = counts[eid] == 1
    if not 3 <= np.count_nonzero(single) <= MAX_OPEN_EDGES_FILLED:
        return faces, 0
    nxt: dict[int, int] = {}
    for u, v in zip(a[single].tolist(), b[single].tolist()):
        if u in nxt:  # two holes touch at a vertex: not simple loops
            return faces, 0
        nxt[u] = v
    new: list[list[int]] = []
    holes = 0
    while nxt:
        start, loop = next(iter(nxt)), list[int]()
        u = start
        while u in nxt and len(loop) <= MAX_HOLE_EDGES:
            loop.append(u)
            u = nxt.pop(u)
        if u != start or not 3 <= len(loop) <= MAX_HOLE_EDGES:  # a long hole, or a chain that does not close
            return faces, 0
        # the faces run the hole's edges u→v; the new ones run them v→u
        p0, p1, p2 = loop[:3]
        new += [[p0, p2, p1]] if len(loop) == 3 else [[p0, loop[3], p2], [p0, p2, p1]]
        holes += 1
    area, total = _area(verts[np.asarray(new)]), _area(verts[f])
    if not total > 0 or area > MAX_HOLE_SHARE * total:
        return faces, 0
    return np.concatenate([f, np.asarray(new, dtype=np.int64)]), holes


def inside_out_bodies(verts: np.ndarray, faces: np.ndarray, label: np.ndarray, vol: np.ndarray) -> np.ndarray:
    """(n,) bool: the closed bodies to turn inside out, given each face's body `label` and the
    bodies' signed volumes `vol`. A body of negative volume inside a body of positive volume is a
    void (a hollow part's inner shell, written facing inwards) and is kept; any other negative body
    is inside out. A file whose total volume is negative was written inside out as a whole and is
    judged turned round (its void shells then face outwards). Before, every negative body was
    turned: a hollow part read as solid, its void filled."""
    sign = -1.0 if vol.sum() < 0 else 1.0
    v = sign * vol
    void = np.zeros(len(vol), dtype=bool)
    neg = np.flatnonzero(v < 0)
    pos = np.flatnonzero(v > 0)
    if len(neg) and len(pos):
        import trimesh

        tri = verts[faces]
        first = np.full(len(vol), len(faces))
        np.minimum.at(first, label, np.arange(len(faces)))
        probe = tri[first[neg]].mean(axis=1)  # a point on each negative body's surface
        lo = np.full((len(vol), 3), np.inf)
        hi = np.full((len(vol), 3), -np.inf)
        np.minimum.at(lo, label, tri.min(axis=1))
        np.maximum.at(hi, label, tri.max(axis=1))
        for c in pos:
            near = ~void[neg] & np.all((probe >= lo[c]) & (probe <= hi[c]), axis=1)
            if near.any():
                body = trimesh.Trimesh(verts, faces[label == c], process=False)
                void[neg[near]] = body.contains(probe[near])
    want_negative = void  # the final sign of each body: negative for voids only
    return (vol < 0) != want_negative


def repair_mesh(
    verts: np.ndarray,
    faces: np.ndarray,
    *,
    crack_tolerance: float,
    edges: tuple[EdgeReport, np.ndarray | None] | None = None,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Repair what can be repaired without changing the shape; returns (vertices, faces, counts).

    In order: (1) cracks: vertices on open edges within `crack_tolerance` (vertex units) are
    merged (`weld_open_edges`), kept only when that leaves no open edge (a real hole or an open
    surface is left as it is); then missing facets: holes of 3 or 4 edges filled
    (`fill_small_holes`), kept only when that closes the mesh; (2) bodies touching along non-manifold edges (two solids sharing
    an edge) get their own vertices (`split_nonmanifold`), kept only when every body is then
    closed; (3) winding: faces are re-wound consistently with their neighbours
    (`trimesh.repair.fix_winding`: a BFS over the face adjacency, well kept and already a
    dependency, networkx included), then every closed body whose volume is negative and is not a
    void inside a body of positive volume is turned inside out so normals point outwards
    (`inside_out_bodies`). Counts: vertices_merged, holes_filled, nonmanifold_edges_split,
    faces_rewound (faces whose final winding differs from the file's), edges (final EdgeReport),
    and face_volumes (`face_volumes` of the returned vertices and faces) when it worked them out.
    edges: `edge_report_twins` of these faces when the caller has it (one sort of the edges less).
    """
    out: dict[str, Any] = {"vertices_merged": 0, "holes_filled": 0, "nonmanifold_edges_split": 0, "faces_rewound": 0}
    rep, twin = edges if edges is not None else edge_report_twins(faces, len(verts))
    if rep.open and crack_tolerance > 0:
        v2, f2, merged = weld_open_edges(verts, faces, crack_tolerance)
        r2, t2 = edge_report_twins(f2, len(v2))
        if len(f2) and r2.open == 0:
            verts, faces, rep, twin, out["vertices_merged"] = v2, f2, r2, t2, merged
    if rep.open and crack_tolerance > 0:
        f2, holes = fill_small_holes(verts, faces)
        r2, t2 = edge_report_twins(f2, len(verts)) if holes else (rep, twin)
        if holes and r2.open == 0:
            faces, rep, twin, out["holes_filled"] = f2, r2, t2, holes
    if rep.nonmanifold and rep.open == 0:
        f2, src, _ = split_nonmanifold(faces, len(verts))
        r2, t2 = edge_report_twins(f2, len(src))
        if r2.open == 0 and r2.nonmanifold == 0:
            out["nonmanifold_edges_split"] = rep.nonmanifold
            verts, faces, rep, twin = verts[src], f2, r2, t2
    original, before = faces, None
    if rep.misoriented and rep.nonmanifold == 0:
        import trimesh

        before = np.asarray(faces, dtype=np.int64).copy()
        tm = trimesh.Trimesh(vertices=np.asarray(verts, dtype=np.float64), faces=before, process=False)
        trimesh.repair.fix_winding(tm)
        faces = np.asarray(tm.faces, dtype=np.int64)
        rep, twin = edge_report_twins(faces, len(verts))
    if rep.closed and twin is not None:  # closed: the twins exist
        n, label = face_components(twin, len(faces))
        fv = face_volumes(verts, faces)
        vol = np.bincount(label, weights=fv, minlength=n)
        out["bodies"] = int(n)
        flip = inside_out_bodies(verts, faces, label, vol)
        inside_out = flip[label]
        voids = np.where(flip, -vol, vol) < 0
        if voids.any():  # the voids kept: how many, and their volume as a share of the solid bodies'
            solid = float(np.abs(vol[~voids]).sum())
            out["voids"] = (int(voids.sum()), float(np.abs(vol[voids]).sum()) / solid if solid > 0 else 0.0)
        if inside_out.any():
            faces = np.where(inside_out[:, None], faces[:, ::-1], faces)
        else:  # these faces' twins and bodies, for the slicer; their volumes for the caller
            remember_topology(faces, twin, (n, label))
            out["face_volumes"] = fv
    if faces is not original:  # re-wound or turned inside out: count the faces that changed
        before = np.asarray(original, dtype=np.int64) if before is None else before
        same = np.zeros(len(faces), dtype=bool)
        for k in range(3):
            same |= (faces == np.roll(before, k, axis=1)).all(axis=1)
        out["faces_rewound"] = int(np.count_nonzero(~same))
    out["edges"] = rep
    return verts, faces, out


def mesh_from_triangles(
    triangles: np.ndarray,
    *,
    name: str = "mesh",
    units: str = "mm",
    transform: Transform = Transform(),
    require_closed: bool = True,
    source: str | None = None,
    weld_tolerance: float = 0.0,
    stats: dict | None = None,
    crack_tolerance: float | None = None,
    stage: Callable[[float, str], None] | None = None,
) -> MeshData:
    """Weld a triangle soup (m, 3, 3) in `units` into a MeshData in mm.

    Welding happens on the raw file coordinates (bit-exact), before any scaling, so corners
    that are equal in the file stay equal. weld_tolerance (mm) > 0: when the exact weld leaves
    open edges, the vertices on open edges closer than the tolerance are merged too
    (`weld_open_edges`), closing cracks and seam gaps left by exporters that write each
    triangle's corners with slightly different rounding; a closed mesh is left untouched.
    stats (optional dict) receives "welded": the number of vertices merged that way, and
    "edges": the final `EdgeReport`. crack_tolerance (mm): None = no repair (a mesh is used as
    welded); a number = `repair_mesh` with cracks up to it closed, its counts and "volume_mm3"
    (after placement) added to stats. Faces that
    collapse to a line are dropped; a mesh wound inside out (negative volume) is flipped so face
    normals point outwards. source: how error messages name the input (default: name).
    stage(fraction, message), optional: called after welding and after repair (a long read shows
    where it is; the caller may raise from it to cancel).
    """
    label = source or name
    tri = np.asarray(triangles)
    if tri.size == 0:
        raise InputFileError(f"{label}: mesh is empty (no triangles)")
    verts, inverse = merge_vertices(tri)  # (m, 3, 3): its rows in order, no (3m, 3) copy first
    if stage:
        stage(0.5, f"welded {len(tri):,} triangles into {len(verts):,} vertices")
    if not np.isfinite(verts).all():
        raise InputFileError(f"{label}: mesh has non-finite (NaN/inf) vertex coordinates")
    faces = drop_degenerate(inverse.reshape(-1, 3))
    if len(faces) == 0:
        raise InputFileError(f"{label}: mesh is empty (all {len(tri)} triangles are degenerate)")
    welded = 0
    # report and twins from one sort of the edges, handed to the repair (which needs both)
    edges = edge_report_twins(faces, len(verts)) if (weld_tolerance > 0 or require_closed) else None
    rep = edges[0] if edges is not None else None
    if weld_tolerance > 0 and rep is not None and rep.open:
        verts, faces, welded = weld_open_edges(verts, faces, weld_tolerance / unit_scale(units))
        if len(faces) == 0:
            raise InputFileError(f"{label}: mesh is empty after welding within {weld_tolerance:g} mm")
        edges = edge_report_twins(faces, len(verts))
        rep = edges[0]
    fixes: dict = {}
    face_vol = None  # the faces' volumes in file units, when the repair worked them out
    if crack_tolerance is not None:
        verts, faces, fixes = repair_mesh(
            verts, faces, crack_tolerance=crack_tolerance / unit_scale(units), edges=edges
        )
        face_vol = fixes.pop("face_volumes", None)
        rep = fixes["edges"]
        if stage:
            stage(
                0.8,
                f"checked and repaired {len(faces):,} faces ({rep.open} open, {rep.nonmanifold} "
                "non-manifold edges left)",
            )
    if stats is not None:
        stats["welded"] = welded
        stats.update(fixes)
        if rep is not None:
            stats["edges"] = rep
    if require_closed and rep is not None and not rep.closed:
        check_closed(faces, len(verts), name=label)  # raises, saying what is open
    scale = unit_scale(units)
    verts = transform.apply(np.asarray(verts, dtype=np.float64) * scale)
    # in mm and not moved: the repair's face volumes are these vertices' (the same float64 values)
    volume = float(face_vol.sum()) if face_vol is not None and scale == 1.0 and transform.is_identity else None
    if volume is None:
        volume = signed_volume(verts, faces)
    if volume < 0 and crack_tolerance is None:
        faces, volume = faces[:, ::-1], -volume
    if stats is not None:
        stats["volume_mm3"] = volume
        if rep is not None and not rep.closed:
            stats["defect_at"] = first_defect(verts, faces)
    bodies = int(fixes.get("bodies", 0))
    return MeshData(vertices=verts, faces=np.ascontiguousarray(faces, dtype=np.int64), name=name, bodies=bodies)


def mesh_file_units(data: bytes, filename: str) -> str:
    """Length unit the file declares (3MF `unit`), mm for formats without one (STL, OBJ, PLY)."""
    return declared_mesh_unit(data, filename) or "mm"


def declared_mesh_unit(data: bytes, filename: str) -> str | None:
    """Length unit a mesh file declares (3MF `unit`, millimeter by default), None for formats
    that declare none (STL, OBJ, PLY)."""
    if PurePosixPath(filename).suffix.lower() == ".3mf":
        return threemf_units(data) or "mm"
    return None


def load_mesh_bytes(
    data: bytes,
    filename: str,
    *,
    units: str = "mm",
    transform: Transform = Transform(),
    limits: MeshLimits = MeshLimits(),
    weld_tolerance: float = 0.0,
    stats: dict | None = None,
    require_closed: bool = True,
    crack_tolerance: float | None = None,
    stage: Callable[[float, str], None] | None = None,
) -> MeshData:
    """Parse, weld, check and place a mesh file's content. Raises InputFileError on bad input.
    stage(fraction, message): optional progress after parsing, welding and repair.

    units: the file's length unit, or "file" for the unit the file declares (`mesh_file_units`).
    weld_tolerance: mm, 0 = weld bit-identical corners only (see `mesh_from_triangles`)."""
    if units == "file":
        units = mesh_file_units(data, filename)
    if len(data) > limits.max_bytes:
        raise InputFileError(
            f"{filename}: {len(data) / 2**20:.1f} MB exceeds the cap of {limits.max_bytes / 2**20:.0f} MB"
        )
    notes: list[str] = []
    tri = read_triangles(data, filename, max_triangles=limits.max_triangles, notes=notes)
    if stage:
        stage(0.2, f"parsed {len(tri):,} triangles ({len(data) / 2**20:.1f} MB)")
    if stats is not None:
        stats["reader_notes"] = notes
    return mesh_from_triangles(
        tri,
        name=PurePosixPath(filename).stem,
        units=units,
        transform=transform,
        source=filename,
        weld_tolerance=weld_tolerance,
        stats=stats,
        require_closed=require_closed,
        crack_tolerance=crack_tolerance,
        stage=stage,
    )


def classify_mesh(stats: dict, as_: str, label: str) -> str:
    """'solid' or 'surface' for a repaired mesh (stats from `mesh_from_triangles` with repair),
    by what it measures: closed (no open, non-manifold or misoriented edge) with a positive
    volume → solid; no non-manifold and no misoriented edge but open edges → a single-wall
    surface; anything else is neither and is refused with its counts and where the first
    defective edge is. as_ 'solid' / 'surface' force the reading ('solid' refuses an open mesh)."""
    rep: EdgeReport = stats["edges"]
    volume = float(stats.get("volume_mm3", 0.0))
    solid = rep.closed and volume > 0
    surface = rep.open > 0 and rep.nonmanifold == 0 and rep.misoriented == 0
    if as_ == "surface":
        return "surface"
    if solid:
        return "solid"
    if as_ == "auto" and surface:
        return "surface"
    where = f" (first at {stats['defect_at']})" if stats.get("defect_at") else ""
    what = "neither a closed solid nor a single-wall surface" if as_ == "auto" else "not a closed solid"
    raise InputFileError(
        f"{label}: the mesh is {what} after repair: {rep.open} open edges, {rep.nonmanifold} non-manifold edges, "
        f"{rep.misoriented} inconsistently wound edges (of {rep.edges}), volume {volume:.6g} mm³{where}; "
        "non-manifold edges are faces joined to a body by one edge (fins, internal walls) or bodies sharing "
        "faces — repair the model in CAD or a mesh tool (remove the extra faces, close holes), or raise "
        "'crack_tolerance' if these are gaps between faces that should touch"
    )


def first_defect(verts: np.ndarray, faces: np.ndarray) -> str | None:
    """Where the first non-manifold (else open) edge of a mesh is: its midpoint, as text (mm)."""
    if len(faces) == 0:
        return None
    edges, counts, _ = edge_uses(faces, len(verts))
    for bad, kind in ((counts > 2, "non-manifold edge"), (counts == 1, "open edge")):
        if bad.any():
            a, b = edges[np.flatnonzero(bad)[0]]
            p = (np.asarray(verts[a], float) + np.asarray(verts[b], float)) / 2
            return f"{kind} at ({p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}) mm"
    return None
