"""Metal outside the part: arc-ON centre lines, as read back, that leave the part.

The coverage check asks whether the part gets metal; this asks whether metal lands where there is
no part — a weld across a thin-wall panel's gap, a pass shifted off its section. Each arc-ON run is
sampled along its centre line (a quarter bead width apart) and every sample gets its distance
outside the part, mm (0 inside):

- **planar slabs** (solid or region part, planar layers): the distance to the same trimesh section
  at mid-slab the coverage check cuts (`coverage_planar` hands its sections over);
- **walls** (a sketch midsurface or an open single-wall mesh): the distance to the midsurface less
  half a bead width — the wall the part stands for is one bead thick;
- **fan layers of a solid**: the distance to the solid's surface (dense surface samples; points
  inside the mesh are at 0).

An *excursion* is a stretch of a run whose bead clears the part (distance > ½ bead width: the
half-width overhang at an edge is what the bead's own width is for). It **fails** when the centre
line is more than `outside_margin_mm` (default one bead width) off the part over a contiguous
length above `outside_fail_mm` (default two bead widths), and **warns** when it is longer than
`outside_warn_mm` (default one bead width). Travel never counts (only arc-ON runs are read).

Legitimately outside: machining stock at a run's ends — extensions, run-ups/-outs, free-end
extensions and fillet leads that ignite or extinguish beyond the part (Venturini et al. 2018, the
thin-wall rule). An excursion that contains a run's first or last point is excused up to
`stock_mm` (the recipe's longest stated extension/lead plus a bead width; `outside_stock_mm`
overrides); beyond that, or in the middle of a run, it counts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, NamedTuple

import numpy as np
import shapely
from shapely.geometry import MultiLineString

from .kd import query
from .read import Run

if TYPE_CHECKING:  # check imports this module
    from .check import Part

MAX_STEP_MM = 1.0  # the centre line is sampled at most this far apart (and at most ¼ bead width)


@dataclass(frozen=True)
class Excursion:
    """A stretch of one run whose bead clears the part.

    length_mm: along the centre line, where distance > ½ bead width. deep_mm: the longest
    contiguous part of it more than the margin off the part. max_mm: the farthest sample's distance
    outside the part. point: that sample (x, y, z mm). at_end: contains the run's first or last
    point (machining stock there is legitimate up to the stock allowance)."""

    layer: int
    section: str | None
    length_mm: float
    deep_mm: float
    max_mm: float
    point: tuple[float, float, float]
    at_end: bool


def sample_run(run: Run, step: float) -> tuple[np.ndarray, np.ndarray]:
    """((n, 3) samples, (n,) arc length mm) along the run's centre line, every vertex kept."""
    pts = np.asarray(run.points, float)
    d = np.diff(pts, axis=0)
    seg = np.linalg.norm(d, axis=1)
    keep = seg > 0
    a, d, seg = pts[:-1][keep], d[keep], seg[keep]
    if not len(seg):
        return pts[:1], np.zeros(1)
    n = np.maximum(1, np.ceil(seg / step)).astype(np.int64)
    idx = np.repeat(np.arange(len(seg)), n)
    t = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n) + 1) / n[idx]
    before = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    return (np.vstack([pts[:1], a[idx] + d[idx] * t[:, None]]), np.concatenate([[0.0], before[idx] + seg[idx] * t]))


def _stretches(mask: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges [i0, i1] (inclusive) of consecutive True."""
    if not mask.any():
        return []
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.nonzero(d == 1)[0], np.nonzero(d == -1)[0] - 1))


def _span(s: np.ndarray, i0: int, i1: int) -> float:
    """Length of the samples i0..i1, each extended half-way to its neighbours (a stretch of one
    sample still has the length of its step)."""
    lo = s[i0] - (s[i0] - s[i0 - 1]) / 2 if i0 > 0 else s[i0]
    hi = s[i1] + (s[i1 + 1] - s[i1]) / 2 if i1 + 1 < len(s) else s[i1]
    return float(hi - lo)


def excursions(
    run: Run, layer: int, pts: np.ndarray, s: np.ndarray, dist: np.ndarray, width: float, margin: float
) -> list[Excursion]:
    out = []
    for i0, i1 in _stretches(dist > width / 2.0):
        d = dist[i0 : i1 + 1]
        deep = max((_span(s, i0 + a, i0 + b) for a, b in _stretches(d > margin)), default=0.0)
        k = i0 + int(np.argmax(d))
        x, y, z = (float(v) for v in pts[k][:3])
        out.append(
            Excursion(
                layer, run.section, _span(s, i0, i1), deep, float(d.max()), (x, y, z), bool(i0 == 0 or i1 == len(s) - 1)
            )
        )
    return out


# ---- distance outside the part --------------------------------------------------------------------
def distance_to_section(section, pts: np.ndarray) -> np.ndarray:
    """(n,) mm from each point (xy) to the section polygon, 0 inside; inf when the slab has none."""
    if section is None or section.is_empty:
        return np.full(len(pts), np.inf)
    # GEOS measures a point's distance against every edge of the polygon: only the points the
    # (prepared) polygon does not contain are measured, the rest are at 0 as before
    shapely.prepare(section)
    xy = np.asarray(pts, dtype=float)[:, :2]
    d = np.zeros(len(xy))
    out = ~shapely.contains_xy(section, xy[:, 0], xy[:, 1])
    if out.any():
        d[out] = shapely.distance(section, shapely.points(xy[out]))
    return d


def midsurface_lines(curves) -> MidsurfaceIndex:
    """A midsurface's curves indexed for distance queries (made once a check: made anew for each
    run, it took ~12 of 118 s for ezdxf's recover01.dxf, ~3,000 curves and as many runs a layer)."""
    return MidsurfaceIndex(curves)


class MidsurfaceIndex:
    """A midsurface's curves in an STRtree: a point's distance to the midsurface is its distance to
    the nearest curve (the one GEOS finds through the tree), not a walk over every curve's segments
    per point as the distance to their MultiLineString was (recover01.dxf: 17 of its 45 s)."""

    def __init__(self, curves) -> None:
        self.xy = [np.asarray(c, float)[:, :2] for c in curves]
        pieces = _pieces(self.xy)
        self.tree = shapely.STRtree(pieces) if len(pieces) else None
        self._near: dict[float, Any] = {}  # r → a k-d tree of the curves' points at most r apart (None: no line)

    def within(self, pts: np.ndarray, r: float) -> np.ndarray:
        """(n,) bool: the points (xy) surely within r of the midsurface: within r of a point of a
        curve, the curves' points taken at most r apart (a point on a curve is then within r/2 of
        one). No false yes; a point near r from the curves may be a no, which `distance` measures.
        A k-d tree query: on the outside check's samples, which lie on the curves but for the
        excursions, several times faster than the STRtree's exact distance (wipeout_door.dxf read
        in its file units: 93 × 78 m of walls, 14 million samples, 70 s)."""
        if r not in self._near:  # made once a check: each layer's samples ask again
            from scipy.spatial import cKDTree

            lines = [c for c in self.xy if len(c) >= 2]  # as in the STRtree: a lone point is no line
            self._near[r] = cKDTree(np.vstack([_densified(c, r) for c in lines])) if lines else None
        tree = self._near[r]
        if tree is None:
            return np.zeros(len(pts), bool)
        d = query(tree, np.asarray(pts, float)[:, :2], distance_upper_bound=r)[0]
        return d <= r

    def distance(self, pts: np.ndarray) -> np.ndarray:
        points = shapely.points(pts[:, :2])
        if self.tree is None:
            return shapely.distance(MultiLineString(), points)
        (which, _), d = self.tree.query_nearest(points, return_distance=True, all_matches=False)
        out = np.full(len(points), np.nan)
        out[which] = d
        return out


#: A midsurface curve is indexed in pieces of at most this many segments: the nearest piece's
#: distance is the distance to the curve (the least of its segments'), and a point is measured
#: against the few segments of the pieces near it, not every vertex of a long curve. With whole
#: curves in the tree, the outside check of ezdxf's hatch_issues.dxf (8 helical runs around big
#: circles of thousands of vertices) took 257 of its 272 s.
PIECE_SEGMENTS = 8


def _pieces(xy: list[np.ndarray]):
    """The curves (≥ 2 points each; shorter ones are no line) as linestrings of at most
    PIECE_SEGMENTS segments; consecutive pieces share a vertex, so no segment is lost."""
    coords, owner = [], []
    for c in xy:
        for s in range(0, len(c) - 1, PIECE_SEGMENTS):
            coords.append(c[s : min(s + PIECE_SEGMENTS, len(c) - 1) + 1])
            owner.append(len(coords[-1]))
    if not coords:
        return []
    return shapely.linestrings(np.vstack(coords), indices=np.repeat(np.arange(len(coords)), owner))


def _densified(c: np.ndarray, r: float) -> np.ndarray:
    """A curve's (k, 2) vertices with points added along each segment at most r apart."""
    a, b = c[:-1], c[1:]
    n = np.maximum(1, np.ceil(np.linalg.norm(b - a, axis=1) / r)).astype(np.int64)
    seg = np.repeat(np.arange(len(a)), n)
    t = (np.arange(len(seg)) - np.repeat(np.cumsum(n) - n, n)) / n[seg]
    return np.vstack([a[seg] + t[:, None] * (b - a)[seg], c[-1:]])


def distance_to_midsurface(curves, pts: np.ndarray, width: float) -> np.ndarray:
    """(n,) mm from each point (xy) beyond half a bead from the midsurface (its curves, or
    `midsurface_lines` of them). A point the k-d tree finds within half a bead (less a nanometre,
    for the rounding of either distance) is at 0 without the exact distance, as it would be with."""
    index = curves if isinstance(curves, MidsurfaceIndex) else midsurface_lines(curves)
    out = np.zeros(len(pts))
    far = ~index.within(pts, width / 2.0 - 1e-6)
    if far.any():
        out[far] = np.maximum(0.0, index.distance(pts[far]) - width / 2.0)
    return out


class MeshDistance:
    """Distance from points to a mesh: dense surface samples in a k-d tree (error ≤ the sample
    spacing, stated as `resolution_mm`); a solid's interior is at 0."""

    def __init__(self, vertices, faces, solid: bool, step: float, max_samples: int = 400_000) -> None:
        import trimesh
        from scipy.spatial import cKDTree

        self.mesh = trimesh.Trimesh(vertices, faces, process=False)
        n = int(min(max_samples, max(2000, self.mesh.area / step**2)))
        surf = trimesh.sample.sample_surface_even(self.mesh, n, seed=0)[0]
        self.tree = cKDTree(np.vstack([surf, self.mesh.vertices]))
        self.resolution_mm = math.sqrt(self.mesh.area / max(len(surf), 1))
        self.solid = solid
        self.boxes: Any = None  # geometry.proximity.TriangleBoxes, made on the first few far points

    def __call__(self, pts: np.ndarray, floor: float) -> np.ndarray:
        """floor: points nearer the surface than this are not tested for inside (0 either way)."""
        d, _ = query(self.tree, pts)
        d = np.maximum(0.0, d - self.resolution_mm / 2.0)
        if self.solid:
            far = np.nonzero(d > floor)[0]
            if len(far):
                from ..geometry.proximity import TriangleBoxes, inside_closed, worth_scanning

                if worth_scanning(len(far), len(self.mesh.faces)):  # few: no r-tree of the whole mesh
                    self.boxes = self.boxes or TriangleBoxes(self.mesh.vertices, self.mesh.faces)
                    inside = inside_closed(self.boxes, pts[far])
                else:
                    inside = self.mesh.contains(pts[far])
                d[far[inside]] = 0.0
        return d


# ---- the check ------------------------------------------------------------------------------------
class RunLine(NamedTuple):
    """What the check reads of an arc-ON run: its centre line ((k, 3) mm) and section. A slab task
    carries these, not the whole `Run` (speeds, wire feed)."""

    points: np.ndarray
    section: str | None


def outside_step(width: float) -> float:
    """The sample spacing along a centre line, mm: a quarter bead width, at most MAX_STEP_MM."""
    return min(MAX_STEP_MM, width / 4.0)


def layer_outside(
    idx: int,
    runs,
    width: float,
    margin: float,
    step: float,
    dist: Callable[[np.ndarray], np.ndarray],
    section=None,
) -> tuple[list[Excursion], float, Excursion | None]:
    """One layer's excursions (runs: `Run`s or `RunLine`s, in order), the deposit area beyond the
    section grown by ½ bead (0 without a section) and the farthest excursion. dist: samples → mm
    outside the part, point by point: the layer's samples are measured in one call (a large one
    then runs on every core: kd.py)."""
    from .check import footprint  # check imports this module

    found: list[Excursion] = []
    reach = None  # the section grown by ½ bead: buffered at the layer's first excursion only
    area = 0.0
    worst = None
    sampled = [(r, *sample_run(r, step)) for r in runs if len(r.points) >= 2]
    if not sampled:
        return found, area, worst
    ends = np.cumsum([len(pts) for _r, pts, _s in sampled])
    d_all = dist(np.vstack([pts for _r, pts, _s in sampled]))
    for (r, pts, s), end in zip(sampled, ends):
        ex = excursions(r, idx, pts, s, d_all[end - len(pts) : end], width, margin)
        found += ex
        for e in ex:
            if worst is None or e.max_mm > worst.max_mm:
                worst = e
        if section is not None and ex:
            if reach is None:
                reach = section.buffer(width / 2.0, quad_segs=8)
            area += float(footprint([r.points[:, :2]], width).difference(reach).area)
    return found, area, worst


def slab_outside(
    idx: int, section, runs, width: float, margin: float, step: float
) -> tuple[list[Excursion], float, Excursion | None] | None:
    """`layer_outside` against a planar slab's section (the one the coverage check cut); None when
    the slab has no part (a deposit above the top is top_gap's). Worker side too (slabs.py)."""
    if section is None or section.is_empty:
        return None
    return layer_outside(idx, runs, width, margin, step, lambda pts: distance_to_section(section, pts), section)


def find_outside(
    part: Part,
    layers,
    width: float,
    *,
    planar: bool,
    sections: dict | None,
    margin: float,
    step: float | None = None,
    precomputed: dict | None = None,
) -> tuple[list[Excursion], dict[int, dict], str]:
    """Every excursion of the program's arc-ON runs, the per-layer figures (the deposit area beyond
    the section grown by ½ bead, planar only; the farthest sample) and the method. sections: layer index → the section
    polygon the coverage check cut for it (planar solids/regions). precomputed: layer index → what
    `slab_outside` gave for it in the coverage check's slab task (slabs.py; planar slabs only), on
    the same section, runs, margin and step: those layers are not walked again here."""
    step = step or outside_step(width)
    mesh_dist: MeshDistance | None = None
    slabs: dict | None = None  # the coverage check's sections, planar slabs only
    if part.kind == "midsurface":
        method = "midsurface distance"
    elif planar and part.kind in ("solid", "region") and sections is not None:
        method = "planar slabs"
        slabs = sections
    else:
        method = "surface distance"
        mesh_dist = MeshDistance(*part.mesh(), part.kind == "solid", step)
    found: list[Excursion] = []
    per_layer: dict[int, dict] = {}
    mid = midsurface_lines(part.curves) if slabs is None and mesh_dist is None else None
    for idx, runs in layers:
        if slabs is not None:  # planar slabs: a task of the coverage check may have done the layer
            if precomputed is not None and idx in precomputed:
                got = precomputed[idx]
            else:
                got = slab_outside(idx, slabs.get(idx), runs, width, margin, step)
            if got is None:
                continue  # no part at this slab: a deposit above the top is top_gap's
        elif mesh_dist is not None:  # surface distance
            md = mesh_dist
            surface = part.kind == "surface"

            def dist(pts: np.ndarray) -> np.ndarray:
                d = md(pts, width / 2.0)
                return np.maximum(0.0, d - width / 2.0) if surface else d

            got = layer_outside(idx, runs, width, margin, step, dist)
        else:  # midsurface
            got = layer_outside(idx, runs, width, margin, step, lambda pts: distance_to_midsurface(mid, pts, width))
        ex, area, worst = got
        found += ex
        per_layer[idx] = {
            "outside_mm2": area if method == "planar slabs" else None,
            "outside_max_mm": worst.max_mm if worst else 0.0,
            "outside_point": list(worst.point) if worst else None,
        }
    return found, per_layer, method


def outside_margin(s, width: float) -> float:
    """How far off the part a centre line must be for an excursion's deep part, mm (settings
    `outside_margin_mm`, default one bead width)."""
    return s.outside_margin_mm if s.outside_margin_mm is not None else width


def counted(e: Excursion, stock_mm: float) -> tuple[float, float]:
    """(length, deep length) mm of an excursion that count: a run end's stock is excused up to
    stock_mm."""
    if not e.at_end:
        return e.length_mm, e.deep_mm
    return max(0.0, e.length_mm - stock_mm), max(0.0, e.deep_mm - stock_mm)


def check_outside(
    part: Part,
    layers,
    width: float,
    s,
    rep,
    *,
    planar: bool,
    sections: dict | None,
    stock_mm: float,
    precomputed: dict | None = None,
) -> dict:
    """Adds the `outside` problems to rep (a `check.Report`) and the per-layer figures to its layers
    (outside_mm: weld clear of the part that counts; outside_stock_mm: at run ends, excused;
    outside_mm2; outside_max_mm and outside_point: the farthest sample). Returns the program's
    figures: outside_mm (the longest counted stretch), outside_mm_total, outside_mm2 (planar: the
    largest layer's deposit area beyond the section grown by ½ bead), outside_max_mm (the farthest
    counted sample), outside_share (counted length / arc-ON length), outside_method,
    outside_stock_mm."""
    margin = outside_margin(s, width)
    fail_len = s.outside_fail_mm if s.outside_fail_mm is not None else 2.0 * width
    warn_len = s.outside_warn_mm if s.outside_warn_mm is not None else width
    found, per_layer, method = find_outside(
        part, layers, width, planar=planar, sections=sections, margin=margin, precomputed=precomputed
    )
    arc_len = sum(r.length for _i, runs in layers for r in runs)
    rated = [(e, *counted(e, stock_mm)) for e in found]
    total = sum(c for _e, c, _d in rated)
    share = total / arc_len if arc_len > 0 else 0.0
    for idx, fig in per_layer.items():
        L = rep.layer(idx)
        mine = [(e, c) for e, c, _d in rated if e.layer == idx]
        L["outside_mm"] = round(sum(c for _e, c in mine), 3)
        L["outside_stock_mm"] = round(sum(e.length_mm - c for e, c in mine), 3)
        if fig["outside_mm2"] is not None:
            L["outside_mm2"] = round(fig["outside_mm2"], 2)
        if fig["outside_point"] is not None:
            L["outside_max_mm"] = round(fig["outside_max_mm"], 3)
            L["outside_point"] = [round(v, 3) for v in fig["outside_point"]]
    out = {
        "outside_method": method,
        "outside_stock_mm": stock_mm,
        "outside_mm": max((c for _e, c, _d in rated), default=0.0),
        "outside_mm_total": total,
        "outside_mm2": max((f["outside_mm2"] or 0.0 for f in per_layer.values()), default=0.0)
        if method == "planar slabs"
        else None,
        "outside_max_mm": max((e.max_mm for e, c, _d in rated if c > 0), default=0.0),
        "outside_share": share,
    }
    if s.outside == "off":
        return out
    deep = [(e, c, d) for e, c, d in rated if d > fail_len]
    long = [(e, c, d) for e, c, d in rated if c > warn_len and d <= fail_len]
    for group, sev in ((deep, s.outside), (long, "warn")):
        if not group:
            continue
        e, c, d = max(group, key=lambda t: t[1])
        layers_hit = sorted({x.layer for x, _c, _d in group})
        where = ", ".join(str(i) for i in layers_hit[:8]) + (" …" if len(layers_hit) > 8 else "")
        what = (
            f"its centre line more than {margin:g} mm off the part over {d:.1f} mm"
            if group is deep
            else f"its bead clear of the part over {c:.1f} mm"
        )
        rep.problem(
            "outside",
            sev,
            f"{len(group)} arc-ON stretch(es) deposit outside the part (layers {where}); the longest: layer "
            f"{e.layer}, section {e.section}, {c:.1f} mm of weld beyond the part, up to {e.max_mm:.1f} mm off "
            f"it ({what}"
            + (f"; a run end's machining stock up to {stock_mm:g} mm is allowed" if e.at_end else "")
            + "): metal where there is no part; check the sequence and its links (arc off between walls)",
            layer=e.layer,
            section=e.section,
            value=c,
            limit=fail_len if group is deep else warn_len,
            point=e.point,
        )
    if not deep and not long and share > s.outside_share_warn:
        rep.problem(
            "outside",
            "warn",
            f"{share * 100:.1f} % of the arc-ON length deposits clear of the part in short stretches",
            value=share,
            limit=s.outside_share_warn,
        )
    return out


__all__ = [
    "Excursion",
    "check_outside",
    "counted",
    "MeshDistance",
    "MidsurfaceIndex",
    "RunLine",
    "distance_to_midsurface",
    "distance_to_section",
    "excursions",
    "layer_outside",
    "outside_margin",
    "outside_step",
    "slab_outside",
    "sample_run",
]
