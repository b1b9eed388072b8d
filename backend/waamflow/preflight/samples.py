"""Coverage of a part by 3D samples: the preflight's check for walls (a sketch's midsurface) and
for fan layers (a mesh's surface), where the layers are no horizontal planes of a solid (those
are `check.coverage_planar`'s). The part is sampled, each sample measured to the nearest bead of
the program as written, and the gap past the last layer found along the build direction."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .grouped import Grouped
from .holes import wall_holes
from .kd import query
from .report import Report
from .report import rounded as _r
from .settings import PreflightSettings

if TYPE_CHECKING:
    from .check import Coverage, Part

#: The most samples of the 3D coverage check: a mesh's even samples (trimesh's rejection sampling
#: is their cost) and a midsurface's grid (one k-d query each). A larger part is sampled coarser,
#: its spacing stated as `coverage_sample_mm` (a 93 × 78 m wall plan, a DXF read in the wrong
#: units, was sampled every 1 mm: 28.5 million samples, minutes of preflight).
MAX_SAMPLES = 200_000
MAX_GRID_SAMPLES = 1_000_000
#: A surface face this close to horizontal (|normal z| ≥ cos 10°) is one no planar layer cuts (`coverage_3d`).
FLAT_COS = 0.985


def _resample(points: np.ndarray, step: float) -> np.ndarray:
    d = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(d)])
    if s[-1] <= 0:
        return points[:1]
    t = np.linspace(0.0, s[-1], max(2, int(math.ceil(s[-1] / step)) + 1))
    return np.column_stack([np.interp(t, s, points[:, k]) for k in range(3)])


def segment_samples(a: np.ndarray, b: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Straight segments a[i] → b[i] ((k, 3) each), each cut into pieces of at most `step`, both
    ends included: (points, the segment each lies on, its fraction along it)."""
    n = np.maximum(1, np.ceil(np.linalg.norm(b - a, axis=1) / step).astype(int)) + 1
    seg = np.repeat(np.arange(len(a)), n)
    frac = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n - 1, n)
    return a[seg] + (b[seg] - a[seg]) * frac[:, None], seg, frac


def _part_samples(part: Part, step: float) -> tuple[np.ndarray, float, float, np.ndarray | None]:
    """(n, 3) samples, the measure they stand for (a wall: area × 1, multiplied by the width later)
    and their spacing, mm: `step`, or on a larger part the spacing of the most samples it may have
    (a midsurface's grid: √(area / MAX_GRID_SAMPLES); a mesh's MAX_SAMPLES even samples); and for a
    surface mesh which samples lie on a horizontal face (`FLAT_COS`; else None)."""
    if part.kind == "midsurface":
        lengths = [float(np.linalg.norm(np.diff(c, axis=0), axis=1).sum()) for c in part.curves]
        area = sum(length * part.height for length in lengths)
        step = max(step, math.sqrt(area / MAX_GRID_SAMPLES))
        out = []
        zs = np.arange(part.z0 + step / 2, part.z0 + part.height, step)
        for c in part.curves:
            pts = np.column_stack([_resample(np.column_stack([c, np.zeros(len(c))]), step)[:, :2]])
            out.append(np.column_stack([np.repeat(pts, len(zs), axis=0), np.tile(zs, len(pts))]))
        return np.vstack(out), area, step, None
    import trimesh

    # a solid with non-planar layers is checked on its boundary: every point of it must lie within
    # reach of a bead (interior voids of thick parts are the planar check's to find)
    mesh = trimesh.Trimesh(*part.mesh(), process=False)
    n = int(min(MAX_SAMPLES, max(1000, mesh.area / step**2)))
    pts, face = trimesh.sample.sample_surface_even(mesh, n, seed=0)
    spacing = math.sqrt(mesh.area / max(len(pts), 1))
    if part.kind != "solid":
        flat = np.abs(mesh.face_normals[face][:, 2]) >= FLAT_COS
        return np.asarray(pts), float(mesh.area), spacing, flat
    from .check import mesh_volume  # column by column: trimesh's volume computes the inertia tensor (0.7 s on 1M faces)

    return np.asarray(pts), mesh_volume(*part.mesh()), spacing, None


def coverage_3d(part: Part, layers, width: float, rep: Report, s: PreflightSettings, planar: bool = False) -> Coverage:
    """The part's surface (or midsurface) sampled every `s.sample_mm` (coarser where that needs more
    samples than `_part_samples` takes), each sample covered when it lies in the slab a bead tops
    and within half a bead across (`wall_cover`), each layer's places with no bead (holes.py) and,
    on a wall of layers that go straight up, each layer's slab of it (`wall_slab_volumes`).
    `planar`: the layers are horizontal planes, so the build goes up (+z); else it goes from each
    layer to the next (fan layers)."""
    from scipy.spatial import cKDTree

    step = s.sample_mm or max(width / 4.0, 0.5)
    samples, measure, sample_mm, flat = _part_samples(part, step)
    dep_runs: list[np.ndarray] = []
    dep_layers: list[np.ndarray] = []
    dep_run: list[np.ndarray] = []  # each point's run, for the section a problem names
    all_runs: list = []
    for idx, runs in layers:
        for r in runs:
            p = _resample(r.points, min(step, width / 4.0))
            dep_runs.append(p)
            dep_layers.append(np.full(len(p), idx))
            dep_run.append(np.full(len(p), len(all_runs)))
            all_runs.append(r)
    if not dep_runs or len(samples) == 0:
        return {
            "part_volume_mm3": measure * (width if part.kind != "solid" else 1.0),
            "uncovered_share": 1.0,
            "method": "3D samples",
            "sample_mm": sample_mm,
            "sample_asked_mm": step,
            "top_gap_mm": None,
        }
    dep = np.vstack(dep_runs)
    dep_layer = np.concatenate(dep_layers)
    by_layer = Grouped(dep_layer)
    # layer spacing measured from the program: each layer's points to the previous layer's (on a
    # program of more than MAX_SAMPLES points, every k-th of them: a percentile of as many)
    spacing = []
    order = [idx for idx, _ in layers]
    stride = max(1, math.ceil(len(dep) / MAX_SAMPLES))
    for a, b in zip(order, order[1:]):
        pa, pb = dep[by_layer.rows(a)], dep[by_layer.rows(b)][::stride]
        if len(pa) and len(pb):
            # distances only: a tree built for speed (the nearest distance is the same whatever
            # the tree's shape; which of two points at one distance it names may differ)
            spacing.append(query(cKDTree(pa, balanced_tree=False, compact_nodes=False), pb)[0])
    h = float(np.percentile(np.concatenate(spacing), 95)) if spacing else width / 2.0
    tree = cKDTree(dep)
    dist, near = query(tree, samples)
    if part.kind == "solid":
        reach = math.hypot(width / 2.0, h) * 1.05 + step / 2.0
    else:
        reach = max(h, width / 2.0) * 1.1 + step / 2.0
    # each layer's median height, in program order (the slabs of wall_cover and wall_slab_volumes)
    heights = np.array([float(np.median(dep[by_layer.rows(i), 2])) for i in order])
    unc, lay, upward = wall_cover(
        samples, dep, by_layer, order, heights, width / 2.0 * 1.1 + step / 2.0, reach, planar, part.bottom, s
    )
    share = float(unc.mean())
    cell = measure / len(samples)
    _layer_figures(part, layers, samples, unc, lay, cell, sample_mm, flat if planar else None, upward, rep)
    if upward and part.kind != "solid":
        for idx, (volume, height) in wall_slab_volumes(part, order, heights, width, s).items():
            rep.layer(idx).update(part_mm3=_r(volume, 1), height_mm=_r(height, 3))
    # walls on planar layers build no horizontal face of a surface (no layer cuts it): a cap over an
    # opening lies above the bead below the opening, and is the uncovered check's, not a top gap
    extra: dict = {}
    skip = flat if planar else None
    if skip is not None:
        extra["uncovered_flat_share"] = float((unc & skip).mean())
    gap, gap_at = _top_gap(samples, dist, near, dep, by_layer, [] if planar else order, reach, skip)
    worst = samples[int(np.argmax(dist))]
    if gap_at is not None:  # the part's point farthest beyond the beads, and its nearest bead
        bead = int(near[gap_at])
        extra |= {
            "top_gap_point": samples[gap_at],
            "top_gap_bead": dep[bead],
            "top_gap_layer": int(dep_layer[bead]),
            "top_gap_section": all_runs[int(np.concatenate(dep_run)[bead])].section,
        }
    return {
        "part_volume_mm3": measure * (width if part.kind != "solid" else 1.0),
        "uncovered_share": share,
        "method": "3D samples",
        "sample_mm": sample_mm,
        "sample_asked_mm": step,
        "layer_spacing_mm": h,
        "top_gap_mm": gap,
        "worst_point": worst,
        "worst_layer": int(lay[int(np.argmax(dist))]),
        "reach_mm": reach,
        "uncovered_by_layer": {},
        **extra,
    }


#: Beads looked at per sample by `wall_cover` (its nearest, in chunks of WALL_CHUNK samples): the
#: bead above a sample within a layer's reach, among the points of the layers below and beside it;
#: the WALL_FIRST nearest first, the rest only for the samples those leave uncovered.
WALL_NEAREST = 24
WALL_FIRST = 4
WALL_CHUNK = 50_000
#: Layers grow straight up when their beads' build directions lie within 25° of +z (cos 25°).
UPWARD_COS = 0.906


def _layer_figures(
    part: Part,
    layers,
    samples: np.ndarray,
    unc: np.ndarray,
    lay: np.ndarray,
    cell_mm2: float,
    spacing: float,
    flat: np.ndarray | None,
    upward: bool,
    rep: Report,
) -> None:
    """Each layer's samples and uncovered share (by `lay`, the samples' layers) and its largest
    place with no bead (holes.py; `flat`: the samples on horizontal faces, which no planar
    layer builds)."""
    labels, at = np.unique(lay, return_inverse=True)
    count, uncovered = np.bincount(at, minlength=len(labels)), np.bincount(at, weights=unc, minlength=len(labels))
    where = {int(v): k for k, v in enumerate(labels)}
    for idx, _runs in layers:
        k = where.get(int(idx))
        if k is not None:
            L = rep.layer(idx)
            L.update(samples=int(count[k]), uncovered_share=_r(float(uncovered[k] / count[k])))
    for idx, (area, point, on_flat) in wall_holes(samples, unc, lay, cell_mm2, spacing, flat, upward).items():
        L = rep.layer(idx)
        L.update(hole_mm2=_r(area, 2), hole_kind="wall", hole_point=[round(float(v), 3) for v in point])
        if on_flat:
            L["hole_flat"] = True


def _slabs(
    dep: np.ndarray,
    by_layer: Grouped,
    order: list,
    heights: np.ndarray,
    reach: float,
    planar: bool,
    bottom: float,
    s: PreflightSettings,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Each bead point's slab for `wall_cover`: (unit build direction, how far back along it the slab
    goes (mm), whether it has no direction (a program of one layer: covered within `reach`), the
    typical slab depth (mm))."""
    from scipy.spatial import cKDTree

    dep_layer = by_layer.labels
    build = np.full(dep.shape, np.nan)  # each bead point's step from the layer before it
    steps = np.ones(len(dep))  # the layers that step spans by the program's numbers
    if planar:
        # horizontal layers grow straight up from the height below theirs (the part's bottom under the
        # lowest; towers built one after the other share their heights), no k-d query per point
        # (a 50 m wall plan: 1.2 s): a slanted face between two rings is covered where it lies under
        # the upper ring's bead, not along the slant between the two rings
        zs = {i: round(float(z), 6) for i, z in zip(order, heights)}
        levels = sorted(set(zs.values()))
        below = dict(zip(levels, [bottom, *levels[:-1]]))
        for i in order:
            if zs[i] > below[zs[i]] + 1e-9 and zs[i] != levels[0]:
                build[by_layer.rows(i)] = (0.0, 0.0, zs[i] - below[zs[i]])
    else:
        for a, b in zip(order, order[1:]):
            ra, rb = by_layer.rows(a), by_layer.rows(b)
            if len(ra) and len(rb):
                _d, k = query(cKDTree(dep[ra]), dep[rb])
                build[rb] = dep[rb] - dep[ra[k]]
                steps[rb] = max(1, int(b) - int(a))
    length = np.linalg.norm(build, axis=1)
    first = ~np.isfinite(length) | (length <= 1e-9)
    # a bead covers one layer of the layers its step spans: of a skipped layer's step (numbered past
    # the one before it; on horizontal layers, a rise over layer_gap_warn_layers typical heights, as
    # gaps.covered_height) one layer's share, not the metal the skipped layers lack
    share = 1.0 / steps
    if planar:  # the rise, not the step's length: a dome's rings step inward far more than up
        rise = np.where(first, np.nan, np.abs(build[:, 2]) / steps)
        typical_rise = float(np.nanmedian(rise)) if (~first).any() else 0.0
        tall = np.nan_to_num(rise) > s.layer_gap_warn_layers * typical_rise + 1e-6
        share = np.where(tall, share * typical_rise / np.where(tall, rise, 1.0), share)
    cap = length * share
    typical = float(np.nanmedian(np.where(first, np.nan, cap))) if (~first).any() else reach
    unit = build / np.where(first, 1.0, length)[:, None]
    # the first layer grows towards the layer after it and covers down to the part's bottom (at
    # least a layer's reach below it): a sample just above it is the next layer's, as any other's
    start = first & np.isin(dep_layer, order[:1])
    if len(order) > 1 and start.any():
        ra, rb = by_layer.rows(order[0]), by_layer.rows(order[1])
        if len(rb):
            _d, k = query(cKDTree(dep[rb]), dep[ra])
            grow = dep[rb[k]] - dep[ra]
            size = np.linalg.norm(grow, axis=1)
            ok_dir = size > 1e-9
            unit[ra[ok_dir]] = grow[ok_dir] / size[ok_dir, None]
            down = np.maximum(reach, dep[ra, 2] - bottom) if planar else np.full(len(ra), reach)
            cap[ra[ok_dir]] = down[ok_dir] / 1.05
            first[ra[ok_dir]] = False
    return unit, cap, first, typical


def wall_slab_volumes(
    part: Part, order: list, heights: np.ndarray, width: float, s: PreflightSettings
) -> dict[int, tuple[float, float]]:
    """Layer → (the wall its slab holds, a bead `width` thick: mm³; the slab's height, mm) of a wall
    built in layers that go straight up, for each layer's metal balance (deposit.layer_balance):
    the part's section length at the middle of the slab (from the layer below's median height,
    `heights` in program `order`, the
    part's bottom under the first, to its own) × the slab's height × the width. A slanted face's
    beads step across it, not up, and a horizontal face no layer builds: the section length counts
    what a layer's bead builds. Counting the samples in each slab instead aliased with the sample
    grid: a 50 m wall plan sampled every 1.75 mm in 2 mm layers read every other layer 0.5x. Slabs
    over skipped layers (more than `layer_gap_warn_layers` typical) are the hole check's."""
    bottoms = np.concatenate([[part.bottom], heights[:-1]])
    tall = heights - bottoms
    typical = float(np.median(tall)) if len(tall) else 0.0
    mids = (heights + bottoms) / 2.0
    if part.kind == "midsurface":
        total = sum(float(np.linalg.norm(np.diff(c, axis=0), axis=1).sum()) for c in part.curves)
        inside = (mids >= part.z0) & (mids <= part.z0 + part.height)
        lengths = np.where(inside, total, 0.0)
    else:
        import trimesh

        mesh = trimesh.Trimesh(*part.mesh(), process=False)
        cuts = trimesh.intersections.mesh_multiplane(mesh, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], list(mids))[0]
        lengths = np.array([float(np.linalg.norm(c[:, 1] - c[:, 0], axis=1).sum()) if len(c) else 0.0 for c in cuts])
    out = {}
    for idx, length, height in zip(order, lengths, tall):
        if length > 0 and 0 < height <= s.layer_gap_warn_layers * typical + 1e-6:
            out[int(idx)] = (float(length * height * width), float(height))
    return out


def _judge(tree, pts: np.ndarray, n_near: int, slabs: tuple) -> tuple[np.ndarray, np.ndarray]:
    """`wall_cover`'s test of samples `pts` against their `n_near` nearest beads: (covered, the
    layer of the covering bead, else of the bead above the sample nearest it along the build
    (within twice the reach across), else of the nearest)."""
    dep, dep_layer, unit, cap, up, first, reach_xy, reach, bound = slabs
    d, j = query(tree, pts, k=n_near, distance_upper_bound=bound)
    d, j = d.reshape(len(pts), n_near), j.reshape(len(pts), n_near)
    real = np.isfinite(d)
    jj = np.where(real, j, 0)
    off = pts[:, None, :] - dep[jj]
    along = np.einsum("ijk,ijk->ij", off, unit[jj])
    across = np.sqrt(np.maximum(np.einsum("ijk,ijk->ij", off, off) - along**2, 0.0))
    slab = (across <= reach_xy) & (along <= up[jj]) & (along >= -cap[jj] * 1.05)
    ok = real & np.where(first[jj], d <= reach, slab)
    hit = ok.any(axis=1)
    above = real & (along <= up[jj]) & (across <= 2.0 * reach_xy)
    closest = np.argmax(np.where(above, along, -np.inf), axis=1)
    pick = np.where(hit, np.argmax(ok, axis=1), np.where(above.any(axis=1), closest, 0))
    got = dep_layer[jj[np.arange(len(pts)), pick]]
    none = ~real[:, 0]
    if none.any():  # no bead within the bound: the nearest one anywhere names the layer
        got[none] = dep_layer[query(tree, pts[none])[1]]
    return hit, got


def wall_cover(
    samples: np.ndarray,
    dep: np.ndarray,
    by_layer: Grouped,
    order: list,
    heights: np.ndarray,
    reach_xy: float,
    reach: float,
    planar: bool,
    bottom: float,
    s: PreflightSettings,
) -> tuple[np.ndarray, np.ndarray, bool]:
    """Which samples of a wall (a midsurface or an open surface) no bead covers, the layer of the
    bead that covers each (else of the bead above it), and whether the layers go straight up (an
    uncovered sample's layer then the first at or above its height, `heights`: each layer's median
    height in program `order`). A bead point covers the slab it tops: from itself back along its
    layer's build (`_slabs`: horizontal layers straight down to the height below, others to their
    nearest point of the layer before; of a step over skipped layers one layer's share, as
    `gaps.covered_height`) and within `reach_xy` (mm) across; the first layer's points back from
    the way to the next layer, down to the part's `bottom` (planar) or `reach` (mm); a program of
    one layer, anything within `reach`. A sample up to a tenth of a layer above a bead (half a layer
    above the last layer's) is in its slab too. The nearest bead within a layer spacing in any
    direction (what covered a wall before) covered a missing stretch from the layers above and
    below it: thin-wall-panel with its layer 7 deleted from the G-code, or half a section's moves
    welded arc OFF, passed "ok"."""
    from scipy.spatial import cKDTree

    from .check import PLANAR_TOL_MM

    dep_layer = by_layer.labels
    unit, cap, first, typical = _slabs(dep, by_layer, order, heights, reach, planar, bottom, s)
    last = np.isin(dep_layer, [order[-1]]) if order else np.zeros(len(dep), bool)
    # a sample stands for its grid cell: it lies in a bead's slab when its centre does (no cell's
    # slack along the build, which covered a skipped layer's slab from the layer above); a sample
    # above the last layer's bead by up to top_gap_max_layers of its layer (+10 %) is the top gap
    # check's (curved-duct's fan ends 0.68° short of the duct's end: 1.4 mm at its outer side,
    # 0.44 of that side's 3.16 mm layers)
    up = np.where(last, s.top_gap_max_layers * np.maximum(cap, typical) * 1.1, 0.1 * typical)
    tree = cKDTree(dep)
    bound = math.hypot(reach_xy, s.layer_gap_warn_layers * typical)
    unc = np.ones(len(samples), dtype=bool)
    lay = np.zeros(len(samples), dtype=dep_layer.dtype)
    slabs = (dep, dep_layer, unit, cap, up, first, reach_xy, reach, max(bound, reach))
    # the beads nearest a sample first (the covering one is mostly among them), then the rest of
    # WALL_NEAREST for the samples they leave: the same answer as all at once, in 40 % of the time
    todo = np.arange(len(samples))
    for n_near in (WALL_FIRST, WALL_NEAREST):
        n_near = min(n_near, len(dep))
        left = []
        for lo in range(0, len(todo), WALL_CHUNK):
            rows = todo[lo : lo + WALL_CHUNK]
            hit, got = _judge(tree, samples[rows], n_near, slabs)
            unc[rows], lay[rows] = ~hit, got
            left.append(rows[~hit])
        todo = np.concatenate(left) if left else todo[:0]
        if not len(todo):
            break
    # layers that go straight up one above the other (horizontal, or ramped as a tube's; not a fan's,
    # which turns): an uncovered sample is in the slab of the first layer at or above its height,
    # whatever beads lie near it
    upward = planar or bool(np.mean(unit[~first, 2] >= UPWARD_COS) >= 0.95) if (~first).any() else planar
    upward = upward and len(heights) > 1 and bool(np.all(np.diff(heights) > 0))
    if upward:
        at = np.minimum(np.searchsorted(heights, samples[unc, 2] - PLANAR_TOL_MM, "left"), len(order) - 1)
        lay[unc] = np.asarray(order)[at]
    return unc, lay, upward


#: A point of the part beyond the beads' reach counts for the top gap when it lies this much along
#: the build direction from its nearest bead (cos 45°): past the last layer, not beside a wall.
TOP_GAP_MIN_COS = 0.7


def _top_gap(
    samples, dist, near, dep, by_layer: Grouped, order, reach: float, skip: np.ndarray | None = None
) -> tuple[float, int | None]:
    """How far the part goes on beyond the beads along the build, mm: of the points of the part out
    of the beads' reach that lie along the build direction from their nearest bead, the farthest
    along it. The build direction: up (+z) for planar layers (`order` empty) and a program of one
    layer; else the nearest bead's offset from the layer before it in `order` (to the layer after it
    on the first layer). A point out of reach beside the beads is an unbuilt wall or a dome's flat
    cap, which the uncovered check names: a panel without one rib had "ends 42.27 mm short of the
    part's top (30.00 mm)", the distance to the rib's far end; without its last 3 layers of 2 mm,
    "3.03 mm short" (the 6 mm less the reach) where it is 6.00. Returns the gap and the sample it is
    measured at (None when no point is out of reach ahead of the beads). `skip`: samples left out (a
    surface's horizontal faces under planar layers)."""
    from scipy.spatial import cKDTree

    out = np.flatnonzero((dist > reach) & (True if skip is None else ~skip))
    if not len(out):
        return 0.0, None
    nd = near[out]
    build = np.zeros((len(out), 3))
    pos = {idx: k for k, idx in enumerate(order)}
    out_layers = Grouped(by_layer.labels[nd])
    for idx in np.unique(out_layers.labels):
        sel = out_layers.rows(idx)
        k = pos.get(int(idx))
        other = None if k is None else order[k - 1] if k > 0 else (order[k + 1] if len(order) > 1 else None)
        if other is None:  # planar layers (no `order` given), or a program of one layer: up
            build[sel] = (0.0, 0.0, 1.0)
            continue
        p = dep[nd[sel]]
        q = dep[by_layer.rows(other)]
        b = q[query(cKDTree(q), p)[1]]
        build[sel] = p - b if k else b - p
    offset = samples[out] - dep[nd]
    nb = np.linalg.norm(build, axis=1)
    no = np.linalg.norm(offset, axis=1)
    along = np.einsum("ij,ij->i", offset, build) / np.where(nb > 0, nb, 1.0)
    ahead = (nb > 0) & (along >= TOP_GAP_MIN_COS * no)
    if not ahead.any():
        return 0.0, None
    k = int(np.argmax(np.where(ahead, along, -np.inf)))
    return float(along[k]), int(out[k])
