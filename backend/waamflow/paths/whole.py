"""The whole section gets a path: plan a section and check what its path leaves without a bead.

`plan_whole(region, guide, spec, adapt=...)` plans the section with its spec and measures the area
its beads do not reach (`deposit.uncovered`), its largest such place, and the arc-ON centre line
it welds off the region beyond the pattern's run-ups (`outside_length`). With `adapt` (a section the user did not
draw: a connected region of a layer with no mask, whose outside is off the part) a path leaving more than
`max_uncovered` of the area, leaving one place larger than HOLE_MAX_WIDTHS bead widths of bead
with no bead (the preflight's `hole`), or welding off the region (a parallel fill of a cross's
whole layer crossed the notches between its arms, arc ON, up to 26 mm off the part), is replaced,
in this order, by

1. **split**: the region cut at its reflex corners (`sections.corners.corner_division`, the MPP
   corner division), each piece filled with the same spec along its own long axis, pieces visited
   nearest first (each from the end nearer the torch) and joined by arc-OFF links;
2. **contour**: the region filled with contour-parallel rings (covers any region, holes included).

The first that leaves at most `max_uncovered` and welds nowhere off the region wins; when none
does, the one leaving the least of those that weld nowhere off it (else of all).
An L of a 120 × 16 mm and a 64 × 16 mm arm: the default weave along the long axis of its
rectangle covers 39.6 % of it; split in two it covers 99.8 %.

A part's layers repeat their sections: `plan_whole` remembers what it planned for the exact same
region, guide and spec (`core.memo`, keyed by a digest of their WKB bytes and the spec's JSON)
and hands out a copy (graphs/bracket.json: 420 sections, 123 distinct; its strategy node 3x
faster).

Pure: shapely + numpy, layer-local mm.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Literal

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon

from ..core.geom import opened_hole
from ..core.memo import Memo, digest
from ..sections.corners import corner_division
from .deposit import WEAVES, uncovered
from .flags import finish
from .frame import guide_or_default
from .registry import plan_section
from .spec import Path2D, StrategySpec

#: Largest share of a section's area a path may leave without a bead before the section is
#: re-planned (adapt) or reported: 2 % (issue #22).
MAX_UNCOVERED = 0.02
#: The pattern that fills any region.
FILLER = "contour"
#: Arc-ON centre line (mm) a whole region's path may run off the region beyond its stock (run-ups
#: and half a bead width): none, up to the shapely buffer's facet error.
OUTSIDE_TOL = 0.01
#: A candidate with a run welded on earlier beads over more than this share of its length is taken
#: only when no other is left: the preflight's `retrace_max_share` default (it would fail it).
RETRACE_MAX = 0.5
#: A candidate leaving one place with no bead larger than this many bead widths of bead (its area
#: over a bead width squared) is taken only when no other is left: the preflight's
#: `hole_fail_widths` default (it would fail it). compas_slicer's bunny_closed_low_res, layer 29 at
#: 2 mm: a spiral left 263 mm² of a lobe's centre (10.5 widths of a 5 mm bead), 1.7 % of the
#: section, under max_uncovered.
HOLE_MAX_WIDTHS = 6.0
#: A candidate whose arc-ON runs shorter than two bead widths (the sequence's default
#: min_arc_run_mm: it drops or bridges them) hold more than this share of its weld is taken only
#: when no other is left.
SHORT_MAX = 0.1

How = Literal["as planned", "split", "contour"]
#: Sections remembered per process (a few hundred points each).
MEMO_SIZE = 512


@dataclass(frozen=True, eq=False)
class WholePath:
    """A section's path and what it covers.

    path: the planned path. pattern: the pattern its beads follow (the spec's, or "contour").
    how: "as planned" (the spec as given), "split" (corner division into `pieces` pieces, each
    with the spec) or "contour" (the filler). uncovered: area left without a bead, mm²; area: the
    section's area, mm²; outside: arc-ON centre line off the region beyond the stock, mm
    (`outside_length`; measured for a whole region only, else 0); retraced: the largest share of
    one arc-ON run welded on the bead of an earlier run (`retraced_share`; measured for a split
    region only, else 0); short_share: the share of its arc-ON length in runs shorter than two bead
    widths (`short_share`); hole_widths: its largest place with no bead at least half a bead wide, in
    bead widths of bead (`_measure`)."""

    path: Path2D
    pattern: str
    how: How
    pieces: int
    uncovered: float
    area: float
    outside: float = 0.0
    retraced: float = 0.0
    short_share: float = 0.0
    hole_widths: float = 0.0

    @property
    def uncovered_share(self) -> float:
        return self.uncovered / self.area if self.area > 0 else 0.0


def _measure(region: Polygon, path: Path2D, spec: StrategySpec) -> tuple[float, float]:
    """(area mm² of `region` no bead reaches, its largest place at least half a bead wide in bead
    widths of bead: `core.geom.opened_hole`'s area / width², as the preflight's `hole` check)."""
    unc = uncovered(region, path.points, path.arc, spec.bead_width, weave=spec.pattern in WEAVES)
    w = spec.bead_width
    hole, _at = opened_hole(unc, w)
    return float(unc.area), hole / (w * w)


def outside_length(region: Polygon, path: Path2D, spec: StrategySpec) -> float:
    """Arc-ON centre line (mm) that welds off `region` beyond the pattern's run-ups (its longer
    run-up or run-out, `stock`): wherever it is more than a bead width beyond them, and in stretches
    longer than a bead width where it is more than half a bead width beyond them (the bead wholly
    off the section: angle_block's layer 45, a parallel pass across a notch 161 mm long, 5.86 mm off
    the part). A triangle's apex a few mm past a rectangle's edge (the robot study's overshoot) is
    neither."""
    # `finish` split the path at the region's boundary and flagged each piece: only arc-ON pieces
    # flagged outside can lie off it
    on = np.flatnonzero(path.arc & ~path.inside)
    if not len(on):
        return 0.0
    stock = max(spec.extension_before, spec.extension_after)
    w = spec.bead_width
    segs = shapely.linestrings(np.stack([path.points[on], path.points[on + 1]], axis=1))
    half, full = np.zeros(len(on)), np.zeros(len(on))
    candidates = np.arange(len(on))
    for got, reach in ((half, stock + w / 2.0), (full, stock + w)):
        near = region.buffer(reach, quad_segs=8)
        shapely.prepare(near)
        off = candidates[~shapely.within(segs[candidates], near)]
        if len(off):
            got[off] = shapely.length(shapely.difference(segs[off], near))
        candidates = off  # a piece within the nearer reach is within the farther one
    total = float(full.sum())
    run = run_full = 0.0  # the stretch of consecutive arc-ON segments with the bead off, so far
    for k in range(len(on)):
        if half[k] > 0 and run > 0 and on[k] == on[k - 1] + 1:
            run, run_full = run + half[k], run_full + full[k]
            continue
        if run > w:
            total += run - run_full  # beyond a bead width it is counted already
        run, run_full = (half[k], full[k]) if half[k] > 0 else (0.0, 0.0)
    if run > w:
        total += run - run_full
    return total


def retraced_share(path: Path2D, width: float) -> float:
    """The largest share of one arc-ON run of the path that lies on the bead of an earlier run,
    by the preflight's own rule (preflight.retrace: centre lines within 3/8 of a bead width,
    running the same way or back), the path run forwards or backwards, whichever is worse.
    compas_slicer's distorted_a, layer 57: the pieces of a split raster laid their passes along the
    cut 1.7 mm apart, one 55.9 mm run wholly on another."""
    from ..preflight.read.core import Run
    from ..preflight.retrace import _layer_retrace
    from ..process.coverage import arc_runs

    runs = []
    for r in arc_runs(path.points, path.arc):
        if len(r) > 1:
            n = len(r) - 1
            p = np.column_stack([r, np.zeros(len(r))])
            runs.append(Run(p, np.zeros(n), np.zeros(n), np.ones(n, bool), None, None, 0))
    if len(runs) < 2:
        return 0.0
    # the sequence may run the section either way (ros-industrial/abb's IRB 4400 link_6.stl, layer
    # 46: 0.47 as planned, 1.0 run backwards): the worse direction counts
    backwards = [dataclasses.replace(r, points=r.points[::-1]) for r in reversed(runs)]
    shares = [found[0] for found in (_layer_retrace(runs, width), _layer_retrace(backwards, width)) if found]
    return max(shares, default=0.0)


def short_share(path: Path2D, width: float) -> float:
    """The share of the path's arc-ON length in runs shorter than two bead widths, which the
    sequence's default min_arc_run_mm drops or bridges (compas_slicer's branches_16, layer 71: a
    scalloped ring split at every scallop, each piece spiralled on its own, 26 runs of 0-17 mm)."""
    from ..process.coverage import arc_runs

    lengths = np.array([float(np.hypot(*np.diff(r, axis=0).T).sum()) for r in arc_runs(path.points, path.arc)])
    total = float(lengths.sum())
    return float(lengths[lengths < 2.0 * width].sum()) / total if total > 0 else 0.0


def _candidate(region: Polygon, path: Path2D, spec: StrategySpec, pattern: str, how: How, pieces: int) -> WholePath:
    """A whole region's path and its measures."""
    area = float(region.area)
    unc, hole = _measure(region, path, spec)
    return WholePath(
        path,
        pattern,
        how,
        pieces,
        unc,
        area,
        outside_length(region, path, spec),
        # pieces planned each on its own may lay passes on each other along their cuts; one kernel's
        # plan does not (tested pattern by pattern), and measuring it cost 10 % of a strategy's time
        retraced_share(path, spec.bead_width) if how == "split" else 0.0,
        short_share(path, spec.bead_width),
        hole,
    )


def _good(w: WholePath, max_uncovered: float) -> bool:
    return (
        w.uncovered_share <= max_uncovered
        and w.outside <= OUTSIDE_TOL
        and w.retraced <= RETRACE_MAX
        and w.short_share <= SHORT_MAX
        and w.hole_widths <= HOLE_MAX_WIDTHS
    )


def plan_pieces(region: Polygon, pieces: list[Polygon], start: np.ndarray, spec: StrategySpec) -> Path2D:
    """Each piece filled with `spec` along its own long axis, nearest piece first from `start`
    (mm), each from its end nearer the torch (when its run-ups are equal), joined by straight
    arc-OFF links. The arc follows each piece's own plan (with arc_outside "off", a run-up into a
    neighbouring piece stays OFF); `inside` is flagged against the whole `region`."""
    drafts = []
    for p in pieces:
        planned = plan_section(p, None, spec)
        drafts.append((planned.points, planned.arc))
    reversible = spec.extension_before == spec.extension_after
    here = np.asarray(start, dtype=float)
    pts: list[np.ndarray] = []
    ok: list[np.ndarray] = []
    todo = list(range(len(drafts)))
    while todo:
        best = None
        for i in todo:
            p, a = drafts[i]
            options = [(float(np.hypot(*(p[0] - here))), i, False)]
            if reversible:
                options.append((float(np.hypot(*(p[-1] - here))), i, True))
            cand = min(options)
            if best is None or cand < best:
                best = cand
        assert best is not None  # todo is not empty
        _, i, flip = best
        todo.remove(i)
        p, a = drafts[i]
        if flip:
            p, a = p[::-1], a[::-1]
        if pts:
            ok.append(np.array([False]))  # link from the previous piece: arc OFF
        pts.append(p)
        ok.append(a)
        here = p[-1]
    return finish(np.vstack(pts), np.concatenate(ok), region, spec.arc_outside)


_MEMO: Memo[WholePath] = Memo(MEMO_SIZE)


def plan_whole(
    region: Polygon, guide: LineString | None, spec: StrategySpec, *, adapt: bool, max_uncovered: float = MAX_UNCOVERED
) -> WholePath:
    """Plan one section and measure its cover (see module doc). Raises like `plan_section`.

    A section planned before with the same region, guide, spec, `adapt` and `max_uncovered`
    (bytes for bytes) is not planned again: its result comes back as a copy."""
    key = digest(
        region.wkb,
        None if guide is None else guide.wkb,
        type(spec).__qualname__,
        spec.model_dump_json(),
        adapt,
        max_uncovered,
    )
    got = _MEMO.get(key, lambda: _plan_whole(region, guide, spec, adapt=adapt, max_uncovered=max_uncovered))
    path = Path2D(got.path.points.copy(), got.path.arc.copy(), got.path.inside.copy())
    return dataclasses.replace(got, path=path)


def _plan_whole(
    region: Polygon, guide: LineString | None, spec: StrategySpec, *, adapt: bool, max_uncovered: float
) -> WholePath:
    path = plan_section(region, guide, spec)
    if not adapt:
        unc, hole = _measure(region, path, spec)
        return WholePath(path, spec.pattern, "as planned", 1, unc, float(region.area), hole_widths=hole)
    first = _candidate(region, path, spec, spec.pattern, "as planned", 1)
    if _good(first, max_uncovered):
        return first
    tried = [first]
    pieces = corner_division(region)
    if len(pieces) > 1:
        start = np.asarray(guide_or_default(region, guide).coords[0], dtype=float)
        try:
            split = plan_pieces(region, pieces, start, spec)
        except ValueError:
            split = None
        if split is not None:
            got = _candidate(region, split, spec, spec.pattern, "split", len(pieces))
            if _good(got, max_uncovered):
                return got
            tried.append(got)
    if spec.pattern != FILLER:
        filler = spec.model_copy(update={"pattern": FILLER})
        filled: Path2D | None
        try:
            filled = plan_section(region, guide, filler)
        except ValueError:
            filled = None
        if filled is not None:
            got = _candidate(region, filled, filler, FILLER, "contour", 1)
            if _good(got, max_uncovered):
                return got
            tried.append(got)
    return min(
        tried,
        key=lambda w: (
            w.outside > OUTSIDE_TOL,
            w.retraced > RETRACE_MAX,
            w.short_share > SHORT_MAX,
            w.hole_widths > HOLE_MAX_WIDTHS,
            w.uncovered,
        ),
    )
