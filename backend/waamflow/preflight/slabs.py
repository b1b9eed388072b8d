"""The planar-slab coverage of the preflight, cut into tasks that stand alone (issue #30).

Each deposited layer is checked on its own: the part's section at the middle of the layer's slab
(trimesh's `mesh_plane` on the triangles spanning that plane, chained into loops, even-odd) and
the footprint of the layer's arc-ON runs (check.footprint) give the layer's part area and the area
no bead covers (the deposit beyond the part is the `outside` check's: outside.py). Nothing of one layer depends on
another, so the layers can be computed in any process: a task carries the triangles its planes
cut and its layers' runs, never the planner's sections (the check stays independent of the plan).

Which triangles a plane cuts is found for every plane at once: each triangle's z range gives the
range of planes it spans (two binary searches), so a million-triangle part is not scanned once per
plane (`_multiplane_sections` did: 3.2 of the 14.5 s the vase's sections took under the profiler).
Each plane's triangles keep the order of a stable sort by their lowest z, and each plane's slab
mesh its vertices in ascending index order, whatever the task they travel in: the sections, and
so every figure of the report, are the same serial or parallel.
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple, Protocol, Sequence, cast

import numpy as np
import shapely
from shapely.geometry import MultiPolygon

from ..core.geom import opened_hole

MAX_PAIRS = 20_000_000  # (triangle, plane) pairs held at once; beyond, each plane scans the part
TASKS_PER_WORKER = 4  # parallel: the smallest (last) task holds 1/(workers · this · 4) of the work (`_spans`)


class Workers(Protocol):
    """The run's worker processes as the preflight sees them (engine/executor.py hands them over)."""

    count: int

    def pays(self, triangles: int, layers: int, points: int, extra_s: float = 0.0) -> bool:
        """Whether work of this size (plus `extra_s` expected serial seconds) is worth sending to the
        workers (the engine's cost model)."""

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any]) -> list[Any]:
        """fn over the items in the workers, results in item order."""


class LayerCover(NamedTuple):
    """One layer's figures: the part's section (shapely), its area, the area of it no footprint
    covers (mm²) and a point (x, y) of the largest uncovered piece."""

    section: Any
    area: float
    uncovered: float
    uncovered_point: tuple[float, float] | None
    excursions: Any = None  # outside.slab_outside's figures of the layer, when its task was given the runs
    hole: float = 0.0  # the largest uncovered piece at least half a bead wide, mm² (core.geom.opened_hole)
    hole_point: tuple[float, float] | None = None

    @property
    def covered(self) -> float:
        """The section's area the footprint covers, mm²."""
        return self.area - self.uncovered


class OutsideRuns(NamedTuple):
    """What a task needs to walk its layers' arc-ON runs for the `outside` check too (outside.py):
    per layer its index and runs (`outside.RunLine`s, in order), the margin and the sample step."""

    layers: list[int]
    runs: list[list[Any]]
    margin: float
    step: float


class SlabTask(NamedTuple):
    """The layers a task checks: the triangles its planes cut (vertices, faces indexing them), per
    plane the faces it cuts, in order, the planes' z and the layers' arc-ON paths ((k, 2) each)."""

    vertices: np.ndarray
    faces: np.ndarray
    plane_faces: list[np.ndarray]
    zs: list[float]
    paths: list[list[np.ndarray]] | None  # None: made from `outside.runs` in the task (sent once, not twice)
    width: float
    outside: OutsideRuns | None = None
    known: dict[int, Any] | None = None  # plane (in the task) → its section, cut ahead (prefetch.py): not cut again


def mid_planes(bottom: float, tops: Sequence[float]) -> list[float]:
    """The plane each layer's section is cut at: halfway down from its top to the previous top
    (to `bottom` for the first), never less than 0.5 µm below it."""
    return [z - max(z - b, 1e-6) / 2 for z, b in zip(tops, [bottom, *tops[:-1]])]


def plane_faces(vertices: np.ndarray, faces: np.ndarray, zs: Sequence[float]) -> list[np.ndarray]:
    """For each z the faces whose z range holds it (zmin ≤ z ≤ zmax), in the order of a stable
    sort by zmin."""
    if not len(zs):
        return []
    vz = vertices[:, 2]
    c0, c1, c2 = (np.take(vz, faces[:, k]) for k in range(3))
    zmin = np.minimum(np.minimum(c0, c1), c2)  # column by column: 3x faster than .min(axis=1)
    zmax = np.maximum(np.maximum(c0, c1), c2)
    order = np.argsort(zmin, kind="stable")
    z = np.asarray(zs, dtype=float)
    rank = np.argsort(z, kind="stable")
    z_sorted = z[rank]
    lo = np.searchsorted(z_sorted, zmin[order], side="left")  # first plane with z ≥ zmin
    hi = np.searchsorted(z_sorted, zmax[order], side="right")  # past the last plane with z ≤ zmax
    counts = np.maximum(hi - lo, 0)
    total = int(counts.sum())
    if total > MAX_PAIRS:  # huge triangles spanning many planes: one scan per plane
        zmin_sorted = zmin[order]
        out = []
        for zi in z:
            cand = order[: np.searchsorted(zmin_sorted, zi, side="right")]
            out.append(cand[zmax[cand] >= zi])
        return out
    pos = np.repeat(np.arange(len(order)), counts)  # position in `order`, ascending
    first = np.cumsum(counts) - counts
    plane = lo[pos] + (np.arange(total) - first[pos])  # the sorted plane each pair cuts
    by_plane = np.argsort(plane, kind="stable")  # positions stay ascending per plane
    pos, plane = pos[by_plane], plane[by_plane]
    bounds = np.searchsorted(plane, np.arange(len(z) + 1))
    out = [np.zeros(0, dtype=order.dtype)] * len(z)
    for r in range(len(z)):
        out[int(rank[r])] = order[pos[bounds[r] : bounds[r + 1]]]
    return out


def cut_sections(
    vertices: np.ndarray, faces: np.ndarray, per_plane: Sequence[np.ndarray], zs: Sequence[float]
) -> list[Any]:
    """The sections at each z of the faces `per_plane` lists (shapely, even-odd): trimesh's
    `mesh_plane` on a slab mesh of those faces only, as planecut.py computes it."""
    from .check import _chain_loops, _loops_to_geom
    from .planecut import plane_segments

    out: list[Any] = []
    for f, z in zip(per_plane, zs):
        if len(f) == 0:
            out.append(MultiPolygon())
            continue
        segs = plane_segments(vertices, faces[f], z)
        out.append(_loops_to_geom(_chain_loops(segs)) if len(segs) else MultiPolygon())
    return out


class TwoSided(NamedTuple):
    """The part's sections just below and just above a mid-plane that holds a horizontal face of
    the part (`two_sided_sections`): where the section jumps, each half of the slab has its own."""

    below: Any
    above: Any


FACE_IN_PLANE_MM = 1e-3  # a face whose three corners lie this close to a mid-plane lies in it
SIDE_OFFSET_MM = 5e-3  # the planes just below and above such a mid-plane (past a float32 STL's noise)


def two_sided_sections(vertices: np.ndarray, faces: np.ndarray, zs: Sequence[float]) -> dict[int, TwoSided]:
    """{plane: TwoSided} for the mid-planes that hold a horizontal face of the part. There the
    section is a tie: the slicer's kernel takes the plane just below a face (a plate's top at
    mid-slab: the plate, 6,000 mm²), trimesh's the boss above it (400 mm²), and the check failed
    a plan that covered the plate as 87.5 % uncovered with 1,009 mm of weld outside the part (a
    plate with a boss, one 3 mm layer; PrusaSlicer's sign_base_rounded.stl). Each half of the
    slab is checked against its own section instead (`cover_layer`)."""
    if not len(zs) or not len(faces):
        return {}
    vz = np.asarray(vertices, dtype=np.float64)[:, 2]
    c0, c1, c2 = (np.take(vz, faces[:, k]) for k in range(3))
    lo, hi = np.minimum(np.minimum(c0, c1), c2), np.maximum(np.maximum(c0, c1), c2)
    flat = np.sort(((lo + hi) / 2)[hi - lo <= 2 * FACE_IN_PLANE_MM])
    if not len(flat):
        return {}
    z = np.asarray(zs, dtype=float)
    i = np.searchsorted(flat, z)  # the flat faces next above and below each plane
    near = np.minimum(np.abs(flat[np.minimum(i, len(flat) - 1)] - z), np.abs(flat[np.maximum(i - 1, 0)] - z))
    ks = np.flatnonzero(near <= FACE_IN_PLANE_MM).tolist()
    if not ks:
        return {}
    sides = [float(z[k]) + d for k in ks for d in (-SIDE_OFFSET_MM, SIDE_OFFSET_MM)]
    v, f = np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64)
    cut = cut_sections(v, f, plane_faces(v, f, sides), sides)
    return {k: TwoSided(cut[2 * j], cut[2 * j + 1]) for j, k in enumerate(ks)}


def cover_layer(section: Any, paths: list[np.ndarray], width: float) -> LayerCover:
    """A layer's figures from its part section and arc-ON paths: one overlay, the section less the
    footprint (the area covered is the rest of the section's). A `TwoSided` section: each half of
    the slab on its own (area and uncovered area the means of the two halves'), the section the
    two united (what the `outside` check may weld on)."""
    from .check import footprint

    if isinstance(section, TwoSided):
        return _cover_two_sided(section, footprint(paths, width), width)
    area = float(section.area)
    if area <= 0:
        return LayerCover(section, area, 0.0, None)
    unc = section.difference(footprint(paths, width))
    hole, at = opened_hole(unc, width)
    return LayerCover(section, area, float(unc.area), _largest_piece_point(unc), hole=hole, hole_point=at)


def _cover_two_sided(two: TwoSided, fp: Any, width: float) -> LayerCover:
    halves = [g.difference(fp) if not g.is_empty else g for g in two]
    area = 0.5 * (float(two.below.area) + float(two.above.area))
    unc = 0.5 * sum(float(h.area) for h in halves)
    hole, at = max((opened_hole(h, width) for h in halves), key=lambda t: t[0])
    # each half is half of the slab: its place counts for half the slab's height
    return LayerCover(
        shapely.union(two.below, two.above), area, unc, _largest_piece_point(*halves), hole=0.5 * hole, hole_point=at
    )


def _largest_piece_point(*geoms: Any) -> tuple[float, float] | None:
    """(x, y) inside the largest piece of the uncovered areas given, or None when all are empty."""
    pieces = [g for geom in geoms if not geom.is_empty for g in shapely.get_parts(geom)]
    if not pieces:
        return None
    rp = max(pieces, key=lambda g: g.area).representative_point()
    return (float(rp.x), float(rp.y))


def cover_slabs(task: SlabTask) -> list[LayerCover]:
    """A task's layers (worker side, or the whole part in this process); with `task.outside`, each
    layer's `outside` figures on the section just cut (the parent then has none of it to do)."""
    sections = cut_sections(task.vertices, task.faces, task.plane_faces, task.zs)
    if task.known:  # those planes hold no faces in the task: their sections came cut
        sections = [task.known.get(i, s) for i, s in enumerate(sections)]
    o = task.outside
    paths = task.paths
    if paths is None:  # a task sent with the runs only: their (k, 2) paths, as coverage_planar makes them
        paths = [[r.points[:, :2] for r in runs if len(r.points) > 1] for runs in cast(OutsideRuns, o).runs]
    covers = [cover_layer(sec, p, task.width) for sec, p in zip(sections, paths)]
    if o is None:
        return covers
    from .outside import slab_outside

    return [
        c._replace(excursions=slab_outside(idx, c.section, runs, task.width, o.margin, o.step))
        for c, idx, runs in zip(covers, o.layers, o.runs)
    ]


class Renumber:
    """Masks and maps over the whole part, reused task after task (`_sub_task`): set for a task's
    faces and vertices, read, and cleared again, so a task costs two scans of the part's masks, not
    a cumulative sum over its million faces and another over its vertices."""

    def __init__(self, n_faces: int, n_vertices: int) -> None:
        self.face_in = np.zeros(n_faces, dtype=bool)
        self.vert_in = np.zeros(n_vertices, dtype=bool)
        self.face_new = np.zeros(n_faces, dtype=np.int64)
        self.vert_new = np.zeros(n_vertices, dtype=np.int64)


def _sub_task(
    vertices: np.ndarray,
    faces: np.ndarray,
    per_plane: list[np.ndarray],
    zs: list[float],
    paths: list[list[np.ndarray]] | None,
    width: float,
    outside: OutsideRuns | None = None,
    known: dict[int, Any] | None = None,
    buf: Renumber | None = None,
) -> SlabTask:
    """A task holding only the faces its planes cut (and their vertices), renumbered in order: each
    plane's slab mesh is the one the whole part gives. `known`: sections of its planes cut ahead;
    `buf`: the part's masks, for a run of tasks."""
    if not any(len(f) for f in per_plane):  # every plane cut ahead (or empty): no mesh to send
        empty = np.zeros(0, dtype=np.intp)
        return SlabTask(vertices[:0], faces[:0], [empty] * len(per_plane), zs, paths, width, outside, known or None)
    b = buf or Renumber(len(faces), len(vertices))
    # sorted unique faces and vertices by masks (what np.unique gives, without sorting the part)
    for f in per_plane:
        b.face_in[f] = True
    f_all = np.flatnonzero(b.face_in)
    b.face_in[f_all] = False
    fv = faces[f_all]
    b.vert_in[fv.ravel()] = True
    v_all = np.flatnonzero(b.vert_in)
    b.vert_in[v_all] = False
    b.vert_new[v_all] = np.arange(len(v_all))
    b.face_new[f_all] = np.arange(len(f_all))
    return SlabTask(
        vertices[v_all], b.vert_new[fv], [b.face_new[f] for f in per_plane], zs, paths, width, outside, known or None
    )


def _spans(weights: np.ndarray, workers: int) -> list[tuple[int, int]]:
    """Consecutive (start, end) spans, guided: each about 1/(2·workers) of the weight still left,
    down to 1/(workers·TASKS_PER_WORKER·4) of the whole, so the first tasks are large (few round
    trips) and the last small: a worker finishing early waits for a small task, not one of equal
    size (the 500-layer cross in 8 equal tasks of ~0.4 s CPU: with the conservation read-back in
    front, one worker took 2.0 s and the other 1.6)."""
    w = max(1, workers)
    cum = np.cumsum(weights, dtype=float)
    if not len(cum):
        return []
    total = float(cum[-1])
    smallest = total / (w * TASKS_PER_WORKER * 4)
    edges, start, done = [0], 0, 0.0
    while start < len(cum):
        target = done + max(smallest, (total - done) / (2 * w))
        end = int(np.searchsorted(cum, target * (1 - 1e-12), side="left")) + 1
        end = min(max(end, start + 1), len(cum))
        edges.append(end)
        start, done = end, float(cum[end - 1])
    return list(zip(edges[:-1], edges[1:]))


def cover_part(
    vertices: np.ndarray,
    faces: np.ndarray,
    zs: list[float],
    paths: list[list[np.ndarray]],
    width: float,
    pool: Workers | None = None,
    outside: OutsideRuns | None = None,
    known: dict[int, Any] | None = None,
) -> list[LayerCover]:
    """Every layer's figures; with the run's workers, when the cost model says the work pays, in
    tasks of consecutive layers, large first, small last (`_spans`, on faces cut plus path points). `outside`: the
    layers' runs (one entry per z; their (k, 2) centre lines of 2 points or more are `paths`), walked for the
    `outside` check in the same task; a task then carries the runs only and makes its paths from them.
    `known`: {layer: section} of planes cut ahead (prefetch.py), not cut again."""
    v = np.asarray(vertices, dtype=np.float64)  # what trimesh.Trimesh makes of them
    f = np.asarray(faces, dtype=np.int64)
    known = known or {}
    if known:  # only the other planes are searched (a plane's faces do not depend on the others)
        rest = [i for i in range(len(zs)) if i not in known]
        per_plane = [np.zeros(0, dtype=np.intp)] * len(zs)
        for i, pf in zip(rest, plane_faces(v, f, [zs[i] for i in rest])):
            per_plane[i] = pf
    else:
        per_plane = plane_faces(v, f, zs)
    n_cut = np.array([len(pf) for pf in per_plane], dtype=float)
    n_pts = np.array([sum(len(p) for p in ps) for ps in paths], dtype=float)
    if (
        pool is None
        or pool.count < 2
        or len(zs) < 2 * pool.count
        or not pool.pays(int(n_cut.sum()), len(zs), int(n_pts.sum()))
    ):
        return cover_slabs(SlabTask(v, f, per_plane, list(zs), paths, width, outside, known or None))
    buf = Renumber(len(f), len(v))
    tasks = [
        _sub_task(
            v,
            f,
            per_plane[a:b],
            list(zs[a:b]),
            paths[a:b] if outside is None else None,  # with the runs, the task makes its paths from them
            width,
            None if outside is None else outside._replace(layers=outside.layers[a:b], runs=outside.runs[a:b]),
            {i - a: known[i] for i in range(a, b) if i in known},
            buf,
        )
        for a, b in _spans(n_cut + n_pts + 1.0, pool.count)
    ]
    return [c for got in pool.map(cover_slabs, tasks) for c in got]
