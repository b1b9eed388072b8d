"""Section loops → shapely polygons with holes, one MultiPolygon per plane (even-odd nesting).

A loop's nesting depth is the number of other loops of the same plane that contain it (tested
with one of its vertices: loops of a valid section never cross). Even depth → outer boundary
of a polygon; odd depth → hole of the innermost loop around it. This is the even-odd rule, so
it holds for multi-body parts, islands inside holes, and meshes wound inside out alike; it does
not trust loop orientation. Polygons are built in one vectorised `shapely.polygons` call and
oriented CCW outside / CW holes.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import MultiPolygon

from ..core.tolerances import TOL
from .planar import Loops

_STRTREE_FROM = 64  # loops per plane above which an STRtree beats the all-pairs test


def _clean(loops: Loops) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Drop repeated consecutive points and loops under TOL.min_area.

    Returns (coords (n, 2), loop id per point (n,), plane per kept loop, |area| per kept loop).
    """
    c = loops.coords
    k = len(loops)
    sizes = np.diff(loops.offsets)
    lid = np.repeat(np.arange(k), sizes)
    prev = np.arange(len(c)) - 1
    prev[loops.offsets[:-1]] = loops.offsets[1:] - 1       # cyclic predecessor within the loop
    keep = np.any(c != c[prev], axis=1)
    c, lid = c[keep], lid[keep]
    # drop points on a straight run (within TOL.merge of the line through their neighbours):
    # flat faces of triangulated meshes put a crossing point on every internal diagonal
    sizes = np.bincount(lid, minlength=k)
    offs = np.concatenate([[0], np.cumsum(sizes)])
    idx = np.arange(len(c))
    prev, nxt = idx - 1, idx + 1
    live = sizes > 0
    prev[offs[:-1][live]] = offs[1:][live] - 1
    nxt[offs[1:][live] - 1] = offs[:-1][live]
    d_in, d_out = c - c[prev], c[nxt] - c
    chord = np.hypot(*(c[nxt] - c[prev]).T)
    cross_ = np.abs(d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0])
    straight = (cross_ <= TOL.merge * chord) & (np.einsum("ij,ij->i", d_in, d_out) > 0)
    c, lid = c[~straight], lid[~straight]
    sizes = np.bincount(lid, minlength=k)
    offs = np.concatenate([[0], np.cumsum(sizes)])
    # shoelace about each loop's first point (keeps precision for parts far from the origin)
    first = c[offs[:-1][lid]] if len(c) else c
    rel = c - first
    nxt = np.arange(len(c)) + 1
    ends = offs[1:][sizes > 0] - 1
    nxt[ends] = offs[:-1][sizes > 0]
    cross = rel[:, 0] * rel[nxt, 1] - rel[nxt, 0] * rel[:, 1]
    area = np.zeros(k)
    np.add.at(area, lid, cross)
    area = np.abs(area) / 2.0
    good = (sizes >= 3) & (area >= TOL.min_area)
    keep_pt = good[lid]
    new_id = np.cumsum(good) - 1
    return c[keep_pt], new_id[lid[keep_pt]], loops.plane[good], area[good]


def _depth_parent(polys: np.ndarray, probes: np.ndarray, areas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For the loops of one plane: nesting depth and innermost container (-1 if none).

    polys: (r,) loop polygons; probes: (r, 2) one vertex per loop; areas: (r,) |area|.
    """
    r = len(polys)
    if r > _STRTREE_FROM:
        tree = shapely.STRtree(polys)
        pi, gi = tree.query(shapely.points(probes), predicate="within")
    else:
        inside = shapely.contains_xy(polys[:, None], probes[None, :, 0], probes[None, :, 1])  # [container, probe]
        gi, pi = np.nonzero(inside)
    mask = pi != gi
    pi, gi = pi[mask], gi[mask]
    depth = np.bincount(pi, minlength=r)
    parent = np.full(r, -1)
    if len(pi):
        # innermost container = the one with the smallest area
        o = np.lexsort((areas[gi], pi))
        pi, gi = pi[o], gi[o]
        firsts = np.concatenate([[True], pi[1:] != pi[:-1]])
        parent[pi[firsts]] = gi[firsts]
    return depth, parent


def loops_to_regions(loops: Loops, n_planes: int) -> list[MultiPolygon]:
    """One MultiPolygon (possibly empty) per plane from the loops of `section_loops`."""
    regions: list[MultiPolygon] = [MultiPolygon() for _ in range(n_planes)]
    if len(loops) == 0:
        return regions
    coords, lid, plane, area = _clean(loops)
    k = len(plane)
    if k == 0:
        return regions
    rings = shapely.linearrings(coords, indices=lid)
    starts = np.concatenate([[0], np.flatnonzero(lid[1:] != lid[:-1]) + 1])
    probes = coords[starts]

    is_shell = np.ones(k, dtype=bool)
    owner = np.arange(k)                     # the shell each loop belongs to
    pstart = np.concatenate([[0], np.flatnonzero(plane[1:] != plane[:-1]) + 1, [k]])
    for a, b in zip(pstart[:-1], pstart[1:]):
        if b - a == 1:
            continue
        depth, parent = _depth_parent(shapely.polygons(rings[a:b]), probes[a:b], area[a:b])
        hole = depth % 2 == 1
        is_shell[a:b] = ~hole
        owner[a:b][hole] = a + parent[hole]

    shell_ids = np.flatnonzero(is_shell)
    poly_of_shell = np.empty(k, dtype=np.int64)
    poly_of_shell[shell_ids] = np.arange(len(shell_ids))
    poly_index = poly_of_shell[owner]
    order = np.lexsort((~is_shell, poly_index))          # per polygon: shell first, then holes
    polys = shapely.polygons(rings[order], indices=poly_index[order])
    polys = shapely.orient_polygons(polys, exterior_cw=False)
    poly_plane = plane[shell_ids]
    out = np.empty(n_planes, dtype=object)
    for i in range(n_planes):
        out[i] = regions[i]
    multi = shapely.multipolygons(polys, indices=poly_plane, out=out)
    return list(multi)
