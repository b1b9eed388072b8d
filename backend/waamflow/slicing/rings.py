"""Section loops → shapely polygons with holes, one MultiPolygon per plane (even-odd nesting).

A loop's nesting depth is the number of other loops of the same plane that contain it (tested
with one of its vertices: loops of a valid section never cross). Even depth → outer boundary
of a polygon; odd depth → hole of the innermost loop around it. This is the even-odd rule, so
it holds for multi-body parts, islands inside holes, cavity shells and meshes wound inside out
alike; it does not trust loop orientation. Polygons are built in one vectorised
`shapely.polygons` call and oriented CCW outside / CW holes. Where loops of *different* bodies
cross (overlapping bodies that were concatenated, not unioned), that plane is rebuilt as the
union of the solid bodies, each minus the cavity bodies (inside-out shells) inside it.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import MultiPolygon

from ..core.model import as_multipolygon, region_polygons
from ..core.tolerances import TOL
from .planar import Loops

_STRTREE_FROM = 64  # loops per plane above which an STRtree beats the all-pairs test


def _cyclic_neighbours(sizes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For loops of `sizes` points stored back to back: (offsets, prev, next) point indices."""
    offs = np.concatenate([[0], np.cumsum(sizes)])
    idx = np.arange(offs[-1])
    prev, nxt = idx - 1, idx + 1
    live = sizes > 0
    prev[offs[:-1][live]] = offs[1:][live] - 1
    nxt[offs[1:][live] - 1] = offs[:-1][live]
    return offs, prev, nxt


def _clean(loops: Loops) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Drop repeated points, points on straight runs, and loops under TOL.min_area.

    Returns (coords (n, 2), loop id per point (n,), plane per kept loop, |area| per kept loop,
    (k,) bool mask of the kept loops).
    Works on separate x / y arrays with `np.take`: 1-D gathers are several times faster than
    (n, 2) row indexing at millions of points.
    """
    k = len(loops)
    x = np.ascontiguousarray(loops.coords[:, 0])
    y = np.ascontiguousarray(loops.coords[:, 1])
    sizes = np.diff(loops.offsets)
    lid = np.repeat(np.arange(k), sizes)
    _, prev, _ = _cyclic_neighbours(sizes)
    # repeated points: a plane through a vertex gives the vertex twice (exactly, or to rounding
    # when the mesh was turned into the plane's frame first); drop both kinds, else the
    # straight-run test below would take each twin for a point on a straight run
    keep = np.hypot(x - np.take(x, prev), y - np.take(y, prev)) > TOL.merge * 1e-3
    x, y, lid = x[keep], y[keep], lid[keep]
    # points on a straight run (within TOL.merge of the line through their neighbours): flat
    # faces of triangulated meshes put a crossing point on every internal diagonal
    sizes = np.bincount(lid, minlength=k)
    _, prev, nxt = _cyclic_neighbours(sizes)
    xp, yp, xn, yn = np.take(x, prev), np.take(y, prev), np.take(x, nxt), np.take(y, nxt)
    ax, ay, bx, by = x - xp, y - yp, xn - x, yn - y
    chord = np.hypot(xn - xp, yn - yp)
    straight = (np.abs(ax * by - ay * bx) <= TOL.merge * chord) & (ax * bx + ay * by > 0)
    keep = ~straight
    x, y, lid = x[keep], y[keep], lid[keep]
    sizes = np.bincount(lid, minlength=k)
    offs, _, nxt = _cyclic_neighbours(sizes)
    # shoelace about each loop's first point (keeps precision for parts far from the origin)
    first = np.take(offs[:-1], lid)
    rx, ry = x - np.take(x, first), y - np.take(y, first)
    cross = rx * np.take(ry, nxt) - np.take(rx, nxt) * ry
    area = np.abs(np.bincount(lid, weights=cross, minlength=k)) / 2.0
    good = (sizes >= 3) & (area >= TOL.min_area)
    keep_pt = np.take(good, lid)
    new_id = np.cumsum(good) - 1
    coords = np.column_stack([x[keep_pt], y[keep_pt]])
    return coords, np.take(new_id, lid[keep_pt]), loops.plane[good], area[good], good


def _plane_pairs(plane: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[tuple[int, int]]]:
    """All ordered pairs (i, j), i ≠ j, of loops in the same plane, for planes with 2 to
    _STRTREE_FROM loops; and (start, count) of the crowded planes left to an STRtree."""
    k = len(plane)
    starts = np.concatenate([[0], np.flatnonzero(plane[1:] != plane[:-1]) + 1])
    counts = np.diff(np.append(starts, k))
    per_loop = np.repeat(counts, counts)  # loops in the plane of each loop
    first_of = np.repeat(starts, counts)
    few = (per_loop > 1) & (per_loop <= _STRTREE_FROM)
    i = np.repeat(np.flatnonzero(few), per_loop[few])
    base = np.repeat(np.cumsum(per_loop[few]) - per_loop[few], per_loop[few])
    j = first_of[i] + (np.arange(len(i)) - base)
    crowded = [(int(a), int(n)) for a, n in zip(starts, counts) if n > _STRTREE_FROM]
    return i[i != j], j[i != j], crowded


def _bbox_overlap(bbox: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    a, b = bbox[i], bbox[j]
    return (a[:, 0] <= b[:, 2]) & (b[:, 0] <= a[:, 2]) & (a[:, 1] <= b[:, 3]) & (b[:, 1] <= a[:, 3])


def _containment_pairs(polys, probes, bbox, plane, group=None) -> tuple[np.ndarray, np.ndarray]:
    """All (probe loop, container loop) pairs of the same plane with the probe inside the container.

    polys: (k,) loop polygons; probes: (k, 2) one vertex per loop; bbox: (k, 4) min x, min y,
    max x, max y; plane: (k,) sorted. Planes with few loops are tested all-pairs in one
    vectorised call (after a bounding-box filter); crowded planes query an STRtree each.
    group: (k,) int or None; when given only loops of the same group are paired.
    """
    probe, container, crowded = _plane_pairs(plane)
    px, py = probes[probe, 0], probes[probe, 1]
    b = bbox[container]
    keep = (px >= b[:, 0]) & (px <= b[:, 2]) & (py >= b[:, 1]) & (py <= b[:, 3])
    if group is not None:
        keep &= group[probe] == group[container]
    probe, container = probe[keep], container[keep]
    inside = shapely.contains_xy(polys[container], probes[probe, 0], probes[probe, 1])
    pi, gi = [probe[inside]], [container[inside]]
    for a, n in crowded:
        tree = shapely.STRtree(polys[a : a + n])
        p_, g_ = tree.query(shapely.points(probes[a : a + n]), predicate="within")
        m = p_ != g_
        if group is not None:
            m &= group[a + p_] == group[a + g_]
        pi.append(a + p_[m])
        gi.append(a + g_[m])
    return np.concatenate(pi), np.concatenate(gi)


def _crossing_planes(rings, bbox, plane, body) -> np.ndarray:
    """Planes where loops of different bodies cross (overlapping bodies: even-odd is wrong there)."""
    i, j, crowded = _plane_pairs(plane)
    m = (i < j) & (body[i] != body[j])
    i, j = i[m], j[m]
    m = _bbox_overlap(bbox, i, j)
    i, j = i[m], j[m]
    hit = [plane[i[shapely.intersects(rings[i], rings[j])]]]
    for a, n in crowded:
        tree = shapely.STRtree(rings[a : a + n])
        p_, g_ = tree.query(rings[a : a + n], predicate="intersects")
        cross = (p_ != g_) & (body[a + p_] != body[a + g_])
        hit.append(plane[a + p_[cross]])
    return np.unique(np.concatenate(hit))


def _valid_polygons(polys: np.ndarray, planes, repairs: list | None) -> np.ndarray:
    """The polygons with each invalid one made valid (`_made_valid`), each repair appended to
    `repairs` as (its plane, `planes[i]`, GEOS's reason with where, area before, area after); the
    same array when all are valid. A body whose surface passes through itself crosses its own loop,
    and GEOS stopped the union of the bodies with "TopologyException: side location conflict"
    (ros-industrial/abb's IRB 6640 piston.stl, two shells, one folded)."""
    bad = np.flatnonzero(~shapely.is_valid(polys))
    if not len(bad):
        return polys
    out = polys.copy()
    for i in bad.tolist():
        fixed = _made_valid(out[i])
        if repairs is not None:
            repairs.append((planes[i], str(shapely.is_valid_reason(out[i])), float(out[i].area), float(fixed.area)))
        out[i] = fixed
    return out


def _made_valid(geom) -> MultiPolygon:
    """`geom` made valid by `shapely.make_valid` ('structure': the loops' outlines united, holes
    cut), as one MultiPolygon."""
    fixed = shapely.make_valid(geom, method="structure", keep_collapsed=False)
    if fixed.geom_type == "GeometryCollection":  # polygons nested in it: one areal geometry
        fixed = shapely.union_all([g for g in shapely.get_parts(fixed) if g.geom_type.endswith("Polygon")])
    return as_multipolygon(region_polygons(fixed))


def _unite(polys: np.ndarray, void: np.ndarray, plane: int = -1, repairs: list | None = None):
    """Region of one plane where bodies overlap: every solid polygon minus the cavity polygons
    it holds, then the union of them all.

    polys: (n,) polygons of the plane, each nested even-odd within its own body; void: (n,)
    bool, polygon of a cavity body (inside-out shell). A cavity belongs to the solid polygons
    whose outline (filled) contains it whole, so another body crossing the cavity fills it, as a
    union of the bodies should.
    """
    polys = _valid_polygons(polys, [plane] * len(polys), repairs)
    solids, voids = polys[~void], polys[void]
    if len(voids):
        outlines = shapely.polygons(shapely.get_exterior_ring(solids))
        holds = shapely.contains(outlines[:, None], voids[None, :])  # [solid, void]
        solids = np.array(
            [s.difference(shapely.union_all(voids[holds[i]])) if holds[i].any() else s for i, s in enumerate(solids)],
            dtype=object,
        )
    return as_multipolygon(region_polygons(shapely.union_all(solids)))


def _nesting(polys, probes, bbox, plane, areas, group=None) -> tuple[np.ndarray, np.ndarray]:
    """Nesting depth of each loop and its innermost container (-1 if none), per plane (and per
    group, when given)."""
    k = len(plane)
    pi, gi = _containment_pairs(polys, probes, bbox, plane, group)
    depth = np.bincount(pi, minlength=k)
    parent = np.full(k, -1)
    if len(pi):
        o = np.lexsort((areas[gi], pi))  # innermost container: the smallest one
        pi, gi = pi[o], gi[o]
        firsts = np.concatenate([[True], pi[1:] != pi[:-1]])
        parent[pi[firsts]] = gi[firsts]
    return depth, parent


def loops_to_regions(
    loops: Loops, n_planes: int, repairs: list[tuple[int, str, float, float]] | None = None
) -> list[MultiPolygon]:
    """One MultiPolygon (possibly empty) per plane from the loops of `section_loops`, each valid
    (`repair_regions`; `repairs` receives what was repaired)."""
    regions: list[MultiPolygon] = [MultiPolygon() for _ in range(n_planes)]
    if len(loops) == 0:
        return regions
    return repair_regions(_regions(loops, n_planes, regions, repairs), repairs)


def repair_regions(
    regions: list[MultiPolygon], repairs: list[tuple[int, str, float, float]] | None = None
) -> list[MultiPolygon]:
    """The regions with each invalid one made valid. A mesh whose surface passes through itself
    (two shells that overlap, a fold: trimesh's cow.obj at a third of its height) gives a section
    loop that crosses itself; planned on as it was, GEOS stopped the strategy node with
    "TopologyException: side location conflict". Repaired by `shapely.make_valid` with the
    'structure' method (the loops' outlines united, holes cut: what a closed solid's section
    would be); `repairs` receives (plane, GEOS's reason with where, area before, area after)."""
    if not regions:
        return regions
    arr = np.empty(len(regions), dtype=object)
    arr[:] = regions
    out = _valid_polygons(arr, range(len(arr)), repairs)
    return regions if out is arr else list(out)


def _regions(
    loops: Loops, n_planes: int, regions: list[MultiPolygon], repairs: list | None = None
) -> list[MultiPolygon]:
    coords, lid, plane, area, good = _clean(loops)
    k = len(plane)
    if k == 0:
        return regions
    rings = shapely.linearrings(coords, indices=lid)
    starts = np.concatenate([[0], np.flatnonzero(lid[1:] != lid[:-1]) + 1])
    probes = coords[starts]

    bbox = np.column_stack(
        [
            np.minimum.reduceat(coords[:, 0], starts),
            np.minimum.reduceat(coords[:, 1], starts),
            np.maximum.reduceat(coords[:, 0], starts),
            np.maximum.reduceat(coords[:, 1], starts),
        ]
    )
    # where loops of different bodies cross, or one body's loop lies inside another's (a shell
    # standing in another without a boolean union: even-odd made it a hole), nest each body on its
    # own and unite them after
    crossing = np.zeros(0, dtype=np.int64)
    group = None
    polygons = shapely.polygons(rings)
    if len(loops.body) and len(np.unique(loops.body)) > 1:
        body = loops.body[good]
        pi, gi = _containment_pairs(polygons, probes, bbox, plane)
        inside_other = plane[pi[body[pi] != body[gi]]]
        crossing = np.union1d(_crossing_planes(rings, bbox, plane, body), inside_other)
        group = np.where(np.isin(plane, crossing), body, -1)
    depth, parent = _nesting(polygons, probes, bbox, plane, area, group)
    is_shell = depth % 2 == 0
    owner = np.where(is_shell, np.arange(k), parent)  # the shell each loop belongs to

    shell_ids = np.flatnonzero(is_shell)
    poly_of_shell = np.empty(k, dtype=np.int64)
    poly_of_shell[shell_ids] = np.arange(len(shell_ids))
    poly_index = poly_of_shell[owner]
    order = np.lexsort((~is_shell, poly_index))  # per polygon: shell first, then holes
    polys = shapely.polygons(rings[order], indices=poly_index[order])
    polys = shapely.orient_polygons(polys, exterior_cw=False)
    poly_plane = plane[shell_ids]
    out = np.empty(n_planes, dtype=object)
    for i in range(n_planes):
        out[i] = regions[i]
    simple = ~np.isin(poly_plane, crossing)
    if simple.any():
        out = shapely.multipolygons(polys[simple], indices=poly_plane[simple], out=out)
    multi = list(out)
    if len(crossing):
        poly_void = loops.void[loops.body[good][shell_ids]]
        for p in crossing:
            sel = poly_plane == p
            multi[p] = _unite(polys[sel], poly_void[sel], int(p), repairs)
    return multi
