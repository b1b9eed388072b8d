"""Mass balance by design (issue #22 item 5): the wire fed against the metal a layer needs.

Wire fed per mm of path (mm³/mm) that ends in the part: η · WFS · π d²/4 / TS, with WFS in m/min
(× 1000/60 → mm/s), TS in mm/s, d the wire diameter (mm) and η the deposition efficiency
(constants and sources in `core.process`). What a layer of height h needs per mm of path:

- overlapping (or touching) passes at centre distance `step`: step · h — the strip one pass
  stands for, filled to the layer height;
- a single bead of width w (no neighbouring pass): its cross-section k · w · h, k the bead shape
  factor (k = 2/3 parabolic cap, π/4 elliptic; WAAM beads 0.70–0.80).

`path_step` finds which of the two a section path is, from its own geometry: the passes'
centre distance where the path has neighbouring passes, or None for a single bead.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.pairs import close_pair_batches
from ..core.memo import Memo, digest
from ..core.process import BEAD_SHAPE_FACTOR, DEPOSITION_EFFICIENCY, WIRE_DIAMETER_MM, deposit_rate_mm3_s

#: A pass counts as having a neighbour where another part of the path (more than 2 bead widths
#: away along the path) lies within this many bead widths: 1.02 takes in touching passes
#: (step = width) with 2 % slack for rounding of the strategy's spacing.
NEIGHBOUR_REACH = 1.02
#: Share of the arc-ON path that must have a neighbour for the section to count as overlapping
#: passes (below: a single bead whose ends or corners come close to itself).
NEIGHBOUR_SHARE = 0.2


def wire_per_mm(
    wfs_m_min: float, ts_mm_s: float, diameter_mm: float = WIRE_DIAMETER_MM, efficiency: float = DEPOSITION_EFFICIENCY
) -> float:
    """Metal deposited per mm of path (mm³/mm): η · WFS · A_wire / TS."""
    if ts_mm_s <= 0:
        raise ValueError(f"travel speed must be positive, got {ts_mm_s} mm/s")
    return deposit_rate_mm3_s(wfs_m_min, diameter_mm, efficiency) / ts_mm_s


def wfs_for(
    deposit_mm3_per_mm: float,
    ts_mm_s: float,
    diameter_mm: float = WIRE_DIAMETER_MM,
    efficiency: float = DEPOSITION_EFFICIENCY,
) -> float:
    """Wire feed (m/min) depositing `deposit_mm3_per_mm` at travel speed `ts_mm_s` (inverse of wire_per_mm)."""
    return deposit_mm3_per_mm * ts_mm_s / deposit_rate_mm3_s(1.0, diameter_mm, efficiency)


def bead_area(width_mm: float, height_mm: float, shape_factor: float = BEAD_SHAPE_FACTOR) -> float:
    """Single-bead cross-section k · w · h (mm²)."""
    return shape_factor * width_mm * height_mm


def layer_deposit_per_mm(
    height_mm: float, width_mm: float, step_mm: float | None = None, shape_factor: float = BEAD_SHAPE_FACTOR
) -> float:
    """Metal a layer needs per mm of path (mm³/mm): step · h for overlapping passes, k · w · h
    for a single bead (`step_mm` None)."""
    if step_mm is None:
        return bead_area(width_mm, height_mm, shape_factor)
    return step_mm * height_mm


def feed_ratio(
    wfs_m_min: float,
    ts_mm_s: float,
    deposit_mm3_per_mm: float,
    diameter_mm: float = WIRE_DIAMETER_MM,
    efficiency: float = DEPOSITION_EFFICIENCY,
) -> float:
    """Wire that ends in the part over what the layer needs (1 = balanced, > 1 over-feed)."""
    return wire_per_mm(wfs_m_min, ts_mm_s, diameter_mm, efficiency) / deposit_mm3_per_mm


#: Section paths whose step is remembered per process (`core.memo`): a part's layers repeat them.
_STEPS: Memo[float | None] = Memo(1024)


def path_step(points: np.ndarray, arc: np.ndarray, width_mm: float) -> float | None:
    """Centre distance of a section path's neighbouring passes (mm), or None for a single bead.

    points: (n, 2) or (n, 3) mm (x, y used: one layer), arc: (n - 1,) bool. The path is sampled
    every w/4 along its arc-ON segments; a sample has a neighbour when another sample more than
    2 w away along the path lies within NEIGHBOUR_REACH · w. With neighbours on at least
    NEIGHBOUR_SHARE of the path, the step is the area the passes cover (the union of the arc-ON
    runs widened to w: flat ends, round corners) over the arc-ON length — the spacing for parallel passes,
    area per length for an oscillation — at most w. Otherwise None (a single bead).
    The same path (x, y and arc bytes for bytes) and width are measured once per process.
    """
    pts = np.ascontiguousarray(np.asarray(points, dtype=float)[:, :2])
    on = np.ascontiguousarray(np.asarray(arc, dtype=bool))
    if len(pts) < 2 or not on.any() or width_mm <= 0:
        return None
    key = digest(pts.tobytes(), on.tobytes(), float(width_mm))
    return _STEPS.get(key, lambda: _path_step(pts, on, float(width_mm)))


def has_far_neighbour(
    P: np.ndarray, S: np.ndarray, reach: float, gap: float, enough: float | None = None
) -> np.ndarray:
    """(n,) bool: sample i of a path has another sample within `reach` (mm; dx² + dy² <= reach²,
    the test scipy's cKDTree.query_pairs makes) that lies more than `gap` (mm) away from it along
    the path. P: (n, 2) samples, S: (n,) their path lengths, mm. With `enough`, the search stops
    once that share of the samples is marked (the rest may then be False).

    The pairs come from core.pairs (a grid of cells and numpy: the same pairs as a k-d tree
    without importing scipy.spatial, ~0.1 s of CPU on every CLI run that writes a parameter file)."""
    has = np.zeros(len(P), dtype=bool)
    for i, j in close_pair_batches(P, reach):
        hit = np.abs(S[i] - S[j]) > gap
        has[i[hit]] = True
        has[j[hit]] = True
        if enough is not None and np.count_nonzero(has) / len(P) >= enough:
            break
    return has


def _path_step(pts: np.ndarray, on: np.ndarray, width_mm: float) -> float | None:
    from shapely.geometry import LineString
    from shapely.ops import unary_union

    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    total = float(seg[on].sum())
    if total <= 0:
        return None
    h = width_mm / 4.0
    # every arc-ON segment sampled at the centres of n = ceil(length / h) equal parts
    s0 = np.concatenate([[0.0], np.cumsum(seg)[:-1]])  # path length at each segment's start
    idx = np.flatnonzero(on & (seg > 0))
    n = np.maximum(1, np.ceil(seg[idx] / h).astype(np.int64))
    at = np.repeat(idx, n)  # the segment of each sample
    t = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n) + 0.5) / np.repeat(n, n)
    P = pts[at] + t[:, None] * (pts[at + 1] - pts[at])
    S = s0[at] + t * seg[at]
    has = has_far_neighbour(P, S, NEIGHBOUR_REACH * width_mm, 2.0 * width_mm, enough=NEIGHBOUR_SHARE)
    if has.mean() < NEIGHBOUR_SHARE:
        return None
    runs: list[Any] = []
    cur: list[Any] = []
    for j in range(len(seg)):
        if on[j]:
            cur = cur or [pts[j]]
            cur.append(pts[j + 1])
        elif cur:
            runs.append(cur)
            cur = []
    if cur:
        runs.append(cur)
    strips = [LineString(r).buffer(width_mm / 2.0, cap_style="flat", join_style="round") for r in runs if len(r) > 1]
    return min(width_mm, float(unary_union(strips).area) / total)


def layer_local(layer, points: np.ndarray) -> np.ndarray:
    """World (n, 3) points of a layer → layer-local (n, 2) mm (the layer's frame, if any)."""
    pts = np.asarray(points, dtype=float)
    if getattr(layer, "frame", None) is None:
        return pts[:, :2]
    homo = np.column_stack([pts[:, :3], np.ones(len(pts))])
    return (homo @ np.linalg.inv(layer.frame).T)[:, :2]


def section_deposit_per_mm(
    sp,
    layer,
    width_mm: float,
    step_mm: float | None = None,
    shape_factor: float = BEAD_SHAPE_FACTOR,
    height_mm: float | None = None,
) -> tuple[float, float | None]:
    """(metal the section path needs per mm of path, mm³/mm; the pass step used, mm, or None for
    a single bead) for a layer of height `height_mm` (default `layer.thickness`): the given step,
    else the path's own (`path_step`)."""
    step = step_mm if step_mm is not None else path_step(layer_local(layer, sp.points), sp.arc, width_mm)
    h = float(layer.thickness) if height_mm is None else height_mm
    return layer_deposit_per_mm(h, width_mm, step, shape_factor), step
