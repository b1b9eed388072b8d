"""The preflight kernel: a part and a program read back → figures, problems and a verdict.

Two geometric methods, chosen by what the program is:
- **planar slabs** (a solid or 2D-region part, every run at one height): the part is cut at the
  middle of each deposited layer's slab (trimesh's own section, not our slicer); the slab's
  footprint is the union of its arc-ON runs buffered by half a bead width. Covered volume =
  Σ area(part ∩ footprint) · slab height; uncovered share = 1 − covered / part volume, so layers
  never deposited (a missing top) count in full.
- **3D samples** (midsurfaces, open single-wall surfaces, non-planar layers; `samples.py`): points on the part
  (samples of a wall's midsurface or surface, of a solid's boundary) are covered when they lie in the
  slab a bead tops (back along its layer's build to the layer before) within half a bead across.

Wire ending in the part = Σ over arc-ON segments of length / speed · WFS · π d²/4 · η, from the
values the program commands; compared with the part's volume (a wall: its area × bead width).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import math
from dataclasses import dataclass, field
from typing import Any, NotRequired, TypedDict

import numpy as np
import shapely
from shapely.geometry import LineString, MultiPolygon, Polygon
from shapely.ops import unary_union

from .bottom import bottom_problems
from .dwell import dwell_metal, dwell_problems
from .order import layer_order_problems
from .plane import z_jump_problems
from .retrace import retrace_problems
from .position import weld_position_problems
from .torch import build_directions, torch_axis_problems
from .travel import travel_problems
from .uncovered import uncovered_problem
from .holes import hole_problems
from .deposit import (
    _arc_runs,
    _ignitions,
    _local_deposit,
    _speedless,
    _starved,
    _wire_balance,
    feed_per_mm,
    layer_balance,
)
from .outside import check_outside, outside_margin, outside_step
from .read import ProgramRead, Run
from .report import Report
from .report import rounded as _r
from .samples import coverage_3d
from .settings import PreflightSettings
from .slabs import Workers

PLANAR_TOL_MM = 0.05  # a run whose z varies less than this is planar


@dataclass
class Part:
    """What the part is, for the preflight.

    kind: "solid" (closed mesh: vertices/faces), "surface" (open single-wall mesh), "midsurface"
    (curves extruded from z0 by height), "region" (2D layers: (z, thickness, polygon) triples).
    """

    kind: str
    node: str
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None
    curves: tuple = ()
    z0: float = 0.0
    height: float = 0.0
    regions: list = field(default_factory=list)
    notes: tuple[str, ...] = ()  # how the preflight read the part, when it is worth saying

    def mesh(self) -> tuple[np.ndarray, np.ndarray]:
        """(vertices, faces) of a solid or surface part; ValueError naming the part when it has none."""
        if self.vertices is None or self.faces is None:
            raise ValueError(f"part {self.node} ({self.kind}) has no mesh (vertices and faces)")
        return self.vertices, self.faces

    @property
    def top(self) -> float:
        if self.kind in ("solid", "surface"):
            return float(self.mesh()[0][:, 2].max())
        if self.kind == "midsurface":
            return self.z0 + self.height
        return max(z for z, _t, _g in self.regions)

    @property
    def bottom(self) -> float:
        if self.kind in ("solid", "surface"):
            return float(self.mesh()[0][:, 2].min())
        if self.kind == "midsurface":
            return self.z0
        return min(z - t for z, t, _g in self.regions)


class Coverage(TypedDict):
    """What a coverage check found: the part's volume (mm³; a wall: area × bead width), the share
    of it no bead reaches and the method; planar slabs add the section cut per layer index (shapely
    geometry, handed to the outside check); 3D samples add the samples' spacing, the measured layer
    spacing, the gap above the deposit and the farthest uncovered sample."""

    part_volume_mm3: float
    uncovered_share: float
    method: str
    sections: NotRequired[dict[int, Any]]
    seen_share: NotRequired[float]  # planar slabs: the part's volume share its layers' mid-plane sections hold
    skipped_share: NotRequired[float]  # planar slabs: the part's volume share in layers the program skips
    excursions: NotRequired[dict[int, Any]]  # a solid's layer index → outside.slab_outside's figures
    sample_mm: NotRequired[float]  # the spacing used
    sample_asked_mm: NotRequired[float]  # the spacing asked: the settings' sample_mm, else a quarter bead (≥ 0.5 mm)
    layer_spacing_mm: NotRequired[float]
    top_gap_mm: NotRequired[float | None]
    top_gap_point: NotRequired[np.ndarray]  # 3D samples: the part's point the top gap is measured at,
    top_gap_bead: NotRequired[np.ndarray]  # its nearest bead point,
    top_gap_layer: NotRequired[int]  # that bead's layer
    top_gap_section: NotRequired[str | None]  # and section
    uncovered_flat_share: NotRequired[float]  # planar layers on a surface: share of it uncovered on horizontal faces
    worst_point: NotRequired[np.ndarray]
    worst_layer: NotRequired[int]
    reach_mm: NotRequired[float]
    uncovered_by_layer: NotRequired[dict[int, float]]


# ---- layers of the program ------------------------------------------------------------------------
def program_layers(prog: ProgramRead) -> list[tuple[int, list[Run]]]:
    """The runs grouped into layers in program order: by the program's `layer N` comments, else by
    height (a new layer whenever a run lies higher or lower than the previous one: a program that
    comes back down starts a layer there, for the order check, order.py)."""
    numbered = [(r.layer, r) for r in prog.runs if r.layer is not None]
    if prog.runs and len(numbered) == len(prog.runs):
        groups: dict[int, list[Run]] = {}
        for layer, r in numbered:
            groups.setdefault(layer, []).append(r)
        return list(groups.items())
    out: list[tuple[int, list[Run]]] = []
    last_z = -math.inf
    for r in prog.runs:
        z = float(np.median(r.points[:, 2]))
        if not out or abs(z - last_z) > PLANAR_TOL_MM:
            out.append((len(out), []))
            last_z = z
        out[-1][1].append(r)
    return out


def _planar(layers: list[tuple[int, list[Run]]]) -> bool:
    for _i, runs in layers:
        zs = np.concatenate([r.points[:, 2] for r in runs])
        if zs.max() - zs.min() > PLANAR_TOL_MM:
            return False
    return True


def footprint(paths: list[np.ndarray], width: float):
    """The area the beads of these (k, 2) paths cover: each path buffered by half a bead width, plus
    the weld pool bridging a weave: where a path comes back across within one bead width of travel
    (it turns back by more than a right angle, and the chord of the three points is ≤ width), the
    triangle they span is deposited too — an oscillated bead is as wide as its weave, not a zigzag
    with notches. A smooth curve never comes back: its beads cover their swept disk only (a chord
    triangle there would cover a sliver of the bend's inside that no bead reaches). The triangles
    are united first and buffered once (a union of buffers is the buffer of the union; only the
    round caps' polygon approximation differs: ≤ 0.004 mm² a layer, 1.5e-6 of it, on the bench's
    500-layer oscillated cross, whose footprints took 2.0 s of CPU buffered one by one, 0.83 s so, and
    0.70 s with the triangles made in one call rather than a Polygon each, 39 a layer)."""
    lines, tris = [], []
    for p in paths:
        line = LineString(p)
        lines.append(line)
        # the weave's own vertices: a path resampled into short pieces (wire-feed compensation) has
        # collinear triples only; simplifying by a hundredth of a bead width recovers the strokes
        p = np.asarray(line.simplify(width * 0.01, preserve_topology=False).coords)
        if len(p) >= 3:
            chord = np.linalg.norm(p[2:] - p[:-2], axis=1)
            back = np.einsum("ij,ij->i", p[:-2] - p[1:-1], p[2:] - p[1:-1]) > 0  # an acute turn
            i = np.nonzero((chord <= width * (1 + 1e-9)) & back)[0]
            if len(i):  # the triangles (p[i], p[i+1], p[i+2]) made at once, not a Polygon each
                tri = shapely.polygons(np.stack([p[i], p[i + 1], p[i + 2]], axis=1))
                tris.extend(tri[shapely.area(tri) > 1e-9])
    if not lines:
        return Polygon()
    # the paths buffered at once (their offset curves noded in one pass), not one buffer each
    # united after: the same area (within 1.4e-12 mm² a layer on the bench's 500-layer cross),
    # whose footprints took 0.81-0.87 s of CPU, now 0.71-0.76 s (4 interleaved runs)
    foot = shapely.buffer(shapely.multilinestrings(lines), width / 2.0, quad_segs=8)
    if tris:
        foot = shapely.union(foot, unary_union(tris).buffer(width / 2.0, quad_segs=4))
    return foot


# ---- coverage: planar slabs ----------------------------------------------------------------------
def _section_polygons(part: Part, z: float, mesh=None):
    if part.kind == "region":
        best = min(part.regions, key=lambda r: abs((r[0] - r[1] / 2) - z))
        return best[2]
    sec = mesh.section(plane_origin=[0, 0, z], plane_normal=[0, 0, 1])
    return MultiPolygon() if sec is None else _loops_to_geom(sec.discrete)


def _loops_to_geom(loops) -> Polygon | MultiPolygon:
    polys = []
    for path in loops:
        if len(path) >= 4:
            pg = Polygon(np.asarray(path)[:, :2])
            if not pg.is_valid:
                pg = pg.buffer(0)
            polys.append(pg)
    if not polys:
        return MultiPolygon()
    geom = polys[0]  # even-odd: nested loops are holes
    for pg in polys[1:]:
        geom = geom.symmetric_difference(pg)
    return geom


def _multiplane_sections(mesh, zs: list[float]) -> list:
    """The mesh's horizontal sections at every z, as shapely geometry (even-odd, as
    `_section_polygons`): trimesh's own plane intersection (`mesh_plane`), given for each plane
    only the triangles whose z range spans it (slabs.py), so a million-triangle part is not
    intersected whole 133 times."""
    from .slabs import cut_sections, plane_faces

    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    return cut_sections(vertices, faces, plane_faces(vertices, faces, zs), zs)


def _chain_loops(segs: np.ndarray) -> list[np.ndarray]:
    """Closed loops (each (k, 2), first = last) of a plane section's (n, 2, 3) segments: the
    endpoints merged as trimesh merges them (`unique_rows` at `tol_path.merge_digits`: planecut.py's
    copy, without importing trimesh); where every merged point joins exactly two segments the loops
    are the graph's cycles, each walked as scipy's depth-first search walks it (`core.graphs.
    cycle_walks`, without importing scipy); anything else (a vertex on the plane, an open or branching
    section) goes to trimesh's own `load_path`, which this replaced where it can (its graph
    traversal took 8.4 of 14.8 s of the sections of a 1,008,000-triangle vase)."""
    from ..core.graphs import cycle_walks
    from .planecut import unique_rows

    flat = np.asarray(segs, dtype=float).reshape((-1, 3))
    unique, inverse = unique_rows(flat)
    n = len(unique)
    e = inverse.reshape((-1, 2))
    e = e[e[:, 0] != e[:, 1]]
    # the distinct undirected edges in (low, high) order: np.unique(axis=0) of the sorted pairs,
    # by one sort of packed keys (numpy 2's np.unique hashes: 7x slower here)
    key = np.sort(np.minimum(e[:, 0], e[:, 1]) * max(n, 1) + np.maximum(e[:, 0], e[:, 1]))
    key = key[np.concatenate([[True], key[1:] != key[:-1]])] if len(key) else key
    edges = np.stack([key // max(n, 1), key % max(n, 1)], axis=1)
    if len(edges) < 3 or not np.all(np.bincount(edges.ravel(), minlength=n) == 2):
        import trimesh

        return list(trimesh.load_path(segs).discrete)
    xy = flat[unique][:, :2]
    return [np.vstack([xy[order], xy[order[:1]]]) for order in cycle_walks(n, edges)]


def mesh_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """A closed mesh's volume, mm³: Σ a·(b × c)/6 about the first vertex (geometry.topology, column
    by column: 0.07 s on a million triangles where one (m, 3, 3) array took 0.28 s; trimesh's `volume`
    computes the whole inertia tensor for it: 1.4 of the 15 s preflight of a 1,008,000-triangle vase)."""
    from ..geometry.topology import signed_volume

    return abs(signed_volume(vertices, faces))


def coverage_planar(
    part: Part,
    layers,
    width: float,
    rep: Report,
    pool: Workers | None = None,
    outside: tuple[float, float] | None = None,
    prefetch: Any = None,
    s: PreflightSettings | None = None,
) -> Coverage:
    """Slab by slab (slabs.py); `pool`: the run's workers, which check the layers of a solid
    part in tasks of consecutive layers when that pays (the figures are the same). `outside`:
    (margin, step) of the `outside` check, whose walk of a solid's layers then runs in the same
    tasks, on the sections they cut (`Coverage["excursions"]`, handed to check_outside). `prefetch`
    (prefetch.SectionPrefetch): the sections of planes the run cut ahead; only those at exactly the
    program's planes, on this part's own mesh arrays, are used. `s`: the thresholds of the skipped
    layers (gaps.py; default settings when None)."""
    from .gaps import covered_height, gap_problems, slab_gaps, typical_height
    from .outside import RunLine
    from .slabs import OutsideRuns, cover_layer, cover_part, mid_planes, two_sided_sections

    tops = [float(np.median(np.concatenate([r.points[:, 2] for r in runs]))) for _idx, runs in layers]
    slab_volumes: list[float] | None = None  # the part's own volume in each slab (a solid's)
    if part.kind != "solid":
        part_volume = float(sum(t * g.area for _z, t, g in part.regions))
    prev_top = part.bottom
    sections: dict[int, Any] = {}
    mids = mid_planes(prev_top, tops)
    paths = [[r.points[:, :2] for r in runs if len(r.points) > 1] for _idx, runs in layers]
    if part.kind == "solid":
        vertices, faces = part.mesh()
        walk = None
        if outside is not None:
            runs = [[RunLine(r.points, r.section) for r in rs] for _idx, rs in layers]
            walk = OutsideRuns([idx for idx, _rs in layers], runs, *outside)
        known = prefetch.take(vertices, faces, mids) if prefetch is not None else None
        known = {**(known or {}), **two_sided_sections(vertices, faces, mids)} or None  # faces at mid-slab
        with ThreadPoolExecutor(1) as ex:  # numpy lets go of the interpreter: beside the layers' cover
            volumes = ex.submit(_slab_volumes, vertices, faces, part.bottom, tops)
            covers = cover_part(vertices, faces, mids, paths, width, pool, walk, known)
            part_volume, slab_volumes = volumes.result()
    else:
        covers = [cover_layer(_section_polygons(part, m), p, width) for m, p in zip(mids, paths)]
    s = s if s is not None else PreflightSettings()
    covered_vol = seen_vol = skipped_vol = 0.0
    typical = typical_height(prev_top, tops, [i for i, _r in layers])
    gap_problems(slab_gaps([i for i, _r in layers], tops, prev_top, [c.area for c in covers], s), rep, s)
    for k, (idx, _runs) in enumerate(layers):
        z = tops[k]
        h = max(z - prev_top, 1e-6)
        prev_top = z
        c = covers[k]
        sections[idx] = c.section
        area, unc = c.area, c.uncovered
        slab = covered_height(k, h, typical, s)
        # the mid-plane section stands for the slab, but no more than the part's volume in it: a
        # step inside the slab (a plate under the mid-plane, letters above) would count metal
        # covered that the part lacks there, and hide what other slabs miss
        # (1e-9: only where the part lacks volume, never by the sums' rounding)
        own = area * h
        if slab_volumes is not None and slab_volumes[k] < own * (1 - 1e-9):
            own = slab_volumes[k]
        frac = slab / h  # of the slab's height its bead covers (1.0 but in a skipped layer's)
        got = c.covered * slab
        covered_vol += got if got <= own * frac * (1 + 1e-9) else own * frac
        seen_vol += own * frac
        skipped_vol += own * (1.0 - frac)  # the layers a tall slab lacks (gaps.py)
        L = rep.layer(idx)
        L.update(
            z=_r(z, 3),
            height_mm=_r(h, 3),
            part_area_mm2=_r(area, 2),
            uncovered_mm2=_r(unc, 2),
            uncovered_share=_r(unc / area) if area > 0 else None,
            part_mm3=_r(area * h if slab_volumes is None else slab_volumes[k], 1),
        )
        if c.uncovered_point is not None:
            L["uncovered_point"] = [round(c.uncovered_point[0], 3), round(c.uncovered_point[1], 3), round(z - h / 2, 3)]
        if c.hole > 0 and c.hole_point is not None:
            L.update(hole_mm2=_r(c.hole, 2), hole_kind="slab")
            L["hole_point"] = [round(c.hole_point[0], 3), round(c.hole_point[1], 3), round(z - h / 2, 3)]
    share = max(0.0, 1.0 - covered_vol / part_volume) if part_volume > 0 else 0.0
    out: Coverage = {
        "part_volume_mm3": part_volume,
        "uncovered_share": share,
        "method": "planar slabs",
        "sections": sections,
        "seen_share": min(1.0, seen_vol / part_volume) if part_volume > 0 else 1.0,
        "skipped_share": min(1.0, skipped_vol / part_volume) if part_volume > 0 else 0.0,
    }
    if part.kind == "solid" and outside is not None:
        out["excursions"] = {idx: c.excursions for (idx, _runs), c in zip(layers, covers)}
    return out


def _slab_volumes(
    vertices: np.ndarray, faces: np.ndarray, bottom: float, tops: list[float]
) -> tuple[float, list[float]]:
    """The closed mesh's volume (mm³) and its volume between each layer's top and the one before (the
    first: the part's bottom), as coverage_planar's slabs run (geometry.topology.volume_below, a
    plane at +inf for the whole; a mesh wound inside out counts as its outward twin)."""
    from ..geometry.topology import volume_below

    below = volume_below(vertices, faces, [bottom, *tops, np.inf])
    if below[-1] < 0:
        below = -below
    return float(below[-1]), [max(0.0, float(b - a)) for a, b in zip(below[:-2], below[1:-1])]


# ---- the whole check -----------------------------------------------------------------------------
def check_program(
    part: Part | None,
    prog: ProgramRead,
    node: str,
    s: PreflightSettings,
    width: float,
    *,
    weld_expected: bool = True,
    stock_mm: float | None = None,
    pool: Workers | None = None,
    prefetch: Any = None,
    cell: str = "",
) -> dict:
    """stock_mm: machining stock allowed beyond the part at a run's ends (the recipe's longest
    extension + a bead width; `s.outside_stock_mm` overrides; None = one bead width). pool: the
    run's workers, for the planar coverage (coverage_planar); prefetch: the part's sections cut
    ahead (prefetch.SectionPrefetch); cell: the JSON of the cell the program was written for
    (Program.cell; "" = none), for its welding position (position.py)."""
    rep = Report(node, prog.format)
    layers = program_layers(prog)
    out: dict = {
        "node": node,
        "format": prog.format,
        "runs": len(prog.runs),
        "layers_deposited": len(layers),
        "notes": list(prog.notes) + list(part.notes if part is not None else ()),
    }
    if prog.unplaced and s.unreadable != "off":
        n = len(prog.unplaced)
        rep.problem(
            "unreadable",
            s.unreadable,
            f"{n} statement{'s' if n != 1 else ''} of program {node} the preflight cannot place (first: "
            f"{prog.unplaced[0]}): the program was not checked there, and what the controller does there is "
            "not what was planned; write absolute targets in one frame",
            value=n,
            limit=0,
        )
    if not prog.runs:
        rep.problem("program", "fail", f"program {node} has no arc-ON motion: nothing would be deposited")
        return _finish(out, rep, s)
    planar = _planar(layers)
    # top
    top_dep = max(float(r.points[:, 2].max()) for r in prog.runs)
    heights = [float(np.median(np.concatenate([r.points[:, 2] for r in runs]))) for _i, runs in layers]
    h_typ = float(np.median(np.diff([part.bottom if part else 0.0] + heights))) if planar and heights else None
    # coverage
    cov: Coverage | None = None
    top_gap: float | None
    if part is not None:
        if planar and part.kind in ("solid", "region"):
            cov = coverage_planar(
                part, layers, width, rep, pool, (outside_margin(s, width), outside_step(width)), prefetch, s
            )
            top_gap = part.top - max(heights)
        else:
            cov = coverage_3d(part, layers, width, rep, s, planar)
            top_gap = cov.get("top_gap_mm")
            h_typ = cov.get("layer_spacing_mm")
        out.update(
            part_top_mm=_r(part.top, 3),
            deposit_top_mm=_r(top_dep, 3),
            top_gap_mm=_r(top_gap, 3),
            uncovered_share=_r(cov["uncovered_share"]),
            part_volume_mm3=_r(cov["part_volume_mm3"], 1),
            coverage_method=cov["method"],
            **({"coverage_sample_mm": _r(cov["sample_mm"], 3)} if "sample_mm" in cov else {}),
            **({"coverage_sample_asked_mm": _r(cov["sample_asked_mm"], 3)} if "sample_asked_mm" in cov else {}),
            layer_height_mm=_r(h_typ, 3),
        )
        _coverage_problems(part, layers, cov, top_gap, h_typ, planar, width, rep, s)
        # metal outside the part (outside.py): arc-ON centre lines off the part, stock at run ends aside
        stock = s.outside_stock_mm if s.outside_stock_mm is not None else stock_mm if stock_mm is not None else width
        fig = check_outside(
            part,
            layers,
            width,
            s,
            rep,
            planar=planar,
            sections=cov.get("sections"),
            stock_mm=stock,
            precomputed=cov.get("excursions"),
        )
        out.update({k: _r(v) if isinstance(v, float) else v for k, v in fig.items()})
    _layer_problems(part, prog, layers, heights, h_typ, planar, width, cell, out, rep, s)
    dwells = dwell_metal(prog, layers, s)  # metal laid standing, arc on (dwell.py)
    _wire_balance(part, prog, layers, cov, weld_expected, out, rep, s, dwells)
    if out.get("wire_part_volume_ratio") is not None:  # every move's metal known: each layer's balance
        layer_balance(rep, width, s)
    _speedless(prog, rep, s)
    per, med = feed_per_mm(prog)  # each move's wire feed / speed and their median: the program's bead
    _local_deposit(per, med, width, rep, s)
    dwell_problems(prog, layers, dwells, med, width, out, rep, s)
    _starved(prog, rep, s)
    _arc_runs(prog, layers, width, out, rep, s)
    _ignitions(part, layers, cov, planar, width, out, rep, s)
    return _finish(out, rep, s)


def _layer_problems(
    part: Part | None,
    prog: ProgramRead,
    layers: list[tuple[int, list[Run]]],
    heights: list[float],
    h_typ: float | None,
    planar: bool,
    width: float,
    cell: str,
    out: dict,
    rep: Report,
    s: PreflightSettings,
) -> None:
    """The deposit's bottom against the part's and the plate's (bottom.py), the layers' order
    (order.py), travel moves into metal welded before (travel.py), moves off a layer's plane
    (plane.py), stretches welded twice (retrace.py), the torch against the way each layer grows
    (torch.py) and each layer's welding position in the program's cell (position.py), on the
    spacing between the deposited layers' heights."""
    levels = np.unique(np.round(heights, 6))  # heights met twice (towers built one after the other) count once
    spacing = float(np.median(np.diff(levels))) if len(levels) > 1 else None
    h_dep = spacing if planar and spacing is not None else h_typ
    directions = build_directions(layers, planar, spacing)  # the way each layer grows: travel, torch, position
    bottom_problems(part, prog, layers, h_dep, out, rep, s)
    if planar:
        layer_order_problems(layers, heights, h_dep, width, rep, s, footprint)
        travel_problems(layers, prog, h_dep, width, out, rep, s)
    else:  # a planar layer with a move off its plane made the program "not planar"
        z_jump_problems(layers, spacing, PLANAR_TOL_MM, rep, s)
        travel_problems(layers, prog, h_dep, width, out, rep, s, directions)
    retrace_problems(layers, width, out, rep, s)
    torch_axis_problems(layers, prog, directions, spacing, out, rep, s)
    weld_position_problems(layers, directions, spacing, cell, out, rep, s)


#: The top gap's advice when the deposit ends below the top everywhere (run_preflight replaces it
#: when the plan has layers up there that weld nothing: preflight._planned_top).
ADD_LAYERS = ": add layers (slice `top: ceil`) or check for skipped layers"


def _coverage_problems(
    part: Part,
    layers: list[tuple[int, list[Run]]],
    cov: Coverage,
    top_gap: float | None,
    h_typ: float | None,
    planar: bool,
    width: float,
    rep: Report,
    s: PreflightSettings,
) -> None:
    """The top gap (the deposit ends short of the part's top, or far above it), the uncovered
    share of the part and its layers' largest places with no bead (holes.py) as problems."""
    last_idx, last_runs = layers[-1]
    top_dep = max((float(r.points[:, 2].max()) for _i, runs in layers for r in runs), default=None)
    if top_gap is not None and h_typ and top_gap > s.top_gap_max_layers * h_typ + 1e-6:
        limit = s.top_gap_max_layers * h_typ
        if "top_gap_point" in cov and top_dep is not None and part.top - top_dep <= limit + 1e-6:
            # the deposit reaches the top; one place of the part stops short of it (a wall's last layers)
            pt, bead = cov["top_gap_point"], cov["top_gap_bead"]
            layer, section = cov.get("top_gap_layer", last_idx), cov.get("top_gap_section")
            rep.problem(
                "top_gap",
                "fail",
                f"at ({pt[0]:.1f}, {pt[1]:.1f}, {pt[2]:.1f}) the part goes on {top_gap:.2f} mm above its nearest "
                f"bead (layer {layer}{f', section {section}' if section else ''}, z {bead[2]:.2f} mm): the "
                f"layers above it are not built there, though the deposit reaches the part's top "
                f"({part.top:.2f} mm) elsewhere: check for sections skipped or ended early",
                layer=layer,
                section=section,
                value=top_gap,
                limit=limit,
                point=tuple(float(c) for c in pt),
            )
        else:
            p = cov.get("worst_point") if not planar else None
            rep.problem(
                "top_gap",
                "fail",
                f"the deposit ends {top_gap:.2f} mm short of the part's top ({part.top:.2f} mm); the last "
                f"deposited layer is {last_idx}{ADD_LAYERS}",
                layer=last_idx,
                value=top_gap,
                limit=limit,
                point=p,
            )
    elif top_gap is not None and h_typ and planar and -top_gap > s.overshoot_warn_layers * h_typ:
        rep.problem(
            "top_gap",
            "warn",
            f"the deposit ends {-top_gap:.2f} mm above the part's top ({part.top:.2f} mm) at layer {last_idx}",
            layer=last_idx,
            value=top_gap,
        )
    uncovered_problem(part, cov, top_gap, rep, s)
    hole_problems(layers, width, h_typ, rep, s)


def _finish(out: dict, rep: Report, s: PreflightSettings) -> dict:
    sev = {p["severity"] for p in rep.problems}
    out["verdict"] = "fail" if "fail" in sev else "warn" if "warn" in sev else "ok"
    out["problems"] = rep.problems
    out["layers"] = [rep.layers[k] for k in sorted(rep.layers)]
    return out


VERDICT_ORDER = {"ok": 0, "warn": 1, "fail": 2}
