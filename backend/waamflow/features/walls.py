"""Feature strategies for thin walls, one bead per wall (Venturini et al. 2018, §4).

Walls are split into entities at crossings; entities meeting end to end at corner/continuous
junctions are chained and deposited in one go. At every crossing (T, direct, odd, four) the
*cutting circle* (radius r_c) removes the wall inside it and, for each corner between two
neighbouring branches (CCW), one extra segment joins a branch's cutting-circle point c_k to the
*influence-circle* point P_k on the corner's bisector at radius r_i, filling the fillet corner
(four segments at a direct crossing, |P_k − c_k| = √(r_i² + r_c² − 2·r_i·r_c·cos(α_k/2)) for a
corner of angle α_k). A flat corner (a T's straight side, turning less than the corner angle)
has no fillet: there the branch bridges straight across the cutting circle from its neighbour's
cutting point instead. Study trials: r_i/r_c = 10.0/2.0 mm was best (7.0/2.5 left a void and thin
fillets). Free ends are extended by a length beyond the wall so arc ignition/extinction land in
stock that is machined off. Tubulars: see `tubular.py`.

Crossing-radius bounds (`crossing_bounds`, `crossing_window`) follow the paper's description,
and the radii its trials found defective are warned about by junction and radius (see there).
The user's wall widths (effective EWW after machining, total TWW as deposited = the bead width,
deposition efficiency DE = EWW/TWW) and the part's internal fillet radius R_f are used where the
study uses them: the bead width in the radius bounds; at corner junctions the path turns on the
midsurface of the filleted wall (radius R_f + EWW/2, uniform machining stock round the corner);
at crossings (T, X) the fillet corners are checked to get metal from the walls and fillet leads
(`fillets.fillet_uncovered`; corner paths: `fillets.round_corners`).

All coordinates are layer-local (x, y) mm. Passes come out in a greedy nearest-neighbour order
(each pass may be reversed: no branch needs a particular direction), igniting in machining stock
where a pass has it at one end only (seam "stock").
"""

from __future__ import annotations

import hashlib
import json
import math
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from shapely.geometry import LineString
from shapely.ops import substring

from .chain import chain_pieces
from .fillets import fillet_uncovered, round_corners
from .junctions import _unit, is_closed, passes_through
from .recognition import CROSSING_KINDS, JUNCTION_KINDS, chain_loop, curves_digest, join_collinear
from .tubular import aligned_loop, scattered_loop

TubularStrategy = Literal["helical", "aligned", "scattered"]


@dataclass(frozen=True)
class WallSpec:
    """cut_radius, influence_radius: crossing circles (mm; study best 2.0 / 10.0).
    free_end_extension: path extension beyond a free wall end (mm). tubular: strategy for isolated
    tubulars (non-isolated ones are always built layer by layer, scattered). overlap: O_l, the
    self-overlap at the stop of a start–stop tubular lap (mm, ≈ crater length).
    corner_angle_deg: corners turning less than this are flat (no fillet). bead_width: mm, the
    total wall width TWW as deposited, for the bounds on the crossing radii (`crossing_bounds`,
    `crossing_window`) and the fillet check; 0 = no check. eww: mm, effective wall width after
    machining (0 = the bead width). fillet_radius: mm, the part's internal fillet radius R_f
    (corners turn on radius R_f + EWW/2; crossings' fillet corners are checked); 0 = sharp.
    join_gap (mm), join_angle_deg: collinear curve ends this close are joined first
    (`recognition.join_collinear`, as the recognition does)."""

    cut_radius: float = 2.0
    influence_radius: float = 10.0
    free_end_extension: float = 5.0
    tubular: TubularStrategy = "helical"
    overlap: float = 5.0
    corner_angle_deg: float = 30.0
    tol: float = 1e-6
    bead_width: float = 0.0
    eww: float = 0.0
    fillet_radius: float = 0.0
    join_gap: float = 0.05
    join_angle_deg: float = 1.0

    @property
    def effective_width(self) -> float:
        """EWW (mm): the given one, else the bead width (no machining allowance)."""
        return self.eww if self.eww > 0 else self.bead_width


@dataclass(frozen=True, eq=False)
class WallPass:
    """One bead pass: xy (k, 2) float mm; inside (k−1,) bool per segment (False on extensions and
    fillet leads that start in machined-off stock); strategy: wall | aligned | scattered."""

    key: str
    strategy: str
    xy: np.ndarray
    inside: np.ndarray

    @property
    def length(self) -> float:
        return float(np.hypot(*np.diff(self.xy, axis=0).T).sum())

    def reversed(self) -> "WallPass":
        return WallPass(self.key, self.strategy, self.xy[::-1].copy(), self.inside[::-1].copy())


@dataclass(frozen=True, eq=False)
class LayerWalls:
    """passes: in deposition order. helical: (key, ring (k, 2)) isolated tubulars to build
    helically over all layers (the caller owns the heights). warnings: human-readable notes."""

    passes: tuple[WallPass, ...]
    helical: tuple[tuple[str, np.ndarray], ...] = ()
    warnings: tuple[str, ...] = ()


@dataclass
class _Chain:
    xy: np.ndarray
    head: list = field(default_factory=list)  # points before xy[0], in path order
    head_inside: list = field(default_factory=list)
    tail: list = field(default_factory=list)  # points after xy[-1]
    tail_inside: list = field(default_factory=list)
    dropped: bool = False

    def path(self) -> tuple[np.ndarray, np.ndarray]:
        pts = [np.asarray(p, float) for p in self.head] + list(self.xy) + [np.asarray(p, float) for p in self.tail]
        inside = list(self.head_inside) + [True] * (len(self.xy) - 1) + list(self.tail_inside)
        return np.asarray(pts, float), np.asarray(inside, bool)


def _coords(line) -> np.ndarray:
    return np.asarray(line.coords, float)[:, :2]


# ------------------------------------------------------------------------------------------
# Splitting and chaining
# ------------------------------------------------------------------------------------------
def split_curves(curves: list[np.ndarray], crossings: list[dict], skip: set[int], tol: float) -> list[np.ndarray]:
    """Pieces of every curve (except `skip`) cut at the crossing points it passes through."""
    pieces: list[np.ndarray] = []
    through: dict[int, list[dict]] = defaultdict(list)  # curve → the crossings naming it, in order
    for f in crossings:
        for ci in set(f["entities"]):
            through[ci].append(f)
    for ci, c in enumerate(curves):
        if ci in skip:
            continue
        line = LineString(c)
        L = line.length
        closed = is_closed(c, tol)
        cuts = []
        for f in through.get(ci, ()):
            for s_ in passes_through(c, f["point"], tol, closed):
                if closed or tol < s_ < L - tol:
                    cuts.append(s_)
        cuts = sorted(set(round(s, 9) for s in cuts))
        if closed and cuts:
            bounds = cuts + [cuts[0] + L]
            for a, b in zip(bounds[:-1], bounds[1:]):
                if b <= L:
                    pieces.append(_coords(substring(line, a, b)))
                else:
                    first = _coords(substring(line, a, L))
                    second = _coords(substring(line, 0.0, b - L))
                    pieces.append(np.vstack([first, second[1:]]))
        else:
            bounds = [0.0] + cuts + [L]
            for a, b in zip(bounds[:-1], bounds[1:]):
                if b - a > tol:
                    pieces.append(_coords(substring(line, a, b)))
    return pieces


# ------------------------------------------------------------------------------------------
# Crossing construction
# ------------------------------------------------------------------------------------------
def trim_from_start(xy: np.ndarray, center: np.ndarray, r: float) -> np.ndarray | None:
    """Drop the part of polyline `xy` from its start until it leaves the circle (center, r).
    Returns None when the whole polyline lies inside the circle."""
    d = np.hypot(*(xy - center).T)
    out = np.flatnonzero(d >= r)
    if not len(out):
        return None
    k = int(out[0])
    if k == 0:
        return xy
    a, b = xy[k - 1], xy[k]
    # solve |a + t(b − a) − center| = r for t in [0, 1]
    u, w = b - a, a - center
    A, B, C = u @ u, 2 * u @ w, w @ w - r * r
    t = (-B + math.sqrt(max(B * B - 4 * A * C, 0.0))) / (2 * A)
    p = a + t * u
    return np.vstack([p, xy[k:]]) if np.hypot(*(p - xy[k])) > 1e-9 else xy[k:]


@dataclass(frozen=True)
class CrossingGeometry:
    """Construction at one crossing: cut points c_k (n, 2), influence points P_k (n, 2; NaN where
    the corner is flat), corner angles (n,) deg CCW from branch k to k+1, fillet segment
    lengths |P_k − c_k| (n,; NaN on flat corners)."""

    cut_points: np.ndarray
    influence_points: np.ndarray
    corner_angles_deg: np.ndarray
    fillet_lengths: np.ndarray


def crossing_geometry(
    center, directions, cut_radius: float, influence_radius: float, corner_angle_deg: float
) -> CrossingGeometry:
    """Cutting/influence construction for branches leaving `center` along unit `directions`
    (sorted CCW). Corner k spans branch k → k+1; it is a fillet when it turns by at least
    `corner_angle_deg` from straight (α_k ≤ 180° − corner_angle_deg)."""
    center = np.asarray(center, float)
    dirs = np.asarray(directions, float)
    ang = np.degrees(np.arctan2(dirs[:, 1], dirs[:, 0]))
    alpha = (np.roll(ang, -1) - ang) % 360.0
    alpha[alpha == 0] = 360.0
    cuts = center + cut_radius * dirs
    infl = np.full_like(cuts, np.nan)
    lengths = np.full(len(dirs), np.nan)
    for k in range(len(dirs)):
        if alpha[k] <= 180.0 - corner_angle_deg:
            mid = math.radians(ang[k] + alpha[k] / 2.0)
            infl[k] = center + influence_radius * np.array([math.cos(mid), math.sin(mid)])
            lengths[k] = float(np.hypot(*(infl[k] - cuts[k])))
    return CrossingGeometry(cuts, infl, alpha, lengths)


# The study's trials (Venturini et al. 2018, §4.2; 80 A, 18 V, 300 mm/min, WFS 4.6 m/min, a bead
# of ~5 mm): the theoretical radii (Test 1, 7.0/2.5 mm) left a central void and thin fillets, 8.0/2.0
# (Test 2) still thin fillets, 10.0/2.0 (Test 3) was sound. Scaled by the theoretical bounds at
# w = 5 mm (2.5 / 7.07 mm): a sound cut radius is at most 0.8 of its bound, a sound influence
# radius at least √2 times its bound. Scaling them with the bead width and corner angle is ours.
TRIAL_CUT_SHARE = 0.8
TRIAL_INFLUENCE_FACTOR = math.sqrt(2.0)


def crossing_bounds(bead_width: float, corner_angle_deg: float = 90.0) -> tuple[float, float]:
    """The study's theoretical bounds on the crossing radii for bead width w (mm) and the narrowest
    fillet corner α (deg). Returns (largest cut radius, smallest influence radius), mm.

    Paper: the cutting circle's maximum "should intersect the centers" of "the four circles (one
    for each branch of the crossing) with diameter equal to the bead width, centered on the branches
    and tangent between each other"; the minimum influence circle "should be tangent to the four
    segments (one per each of the crossing branches) perpendicular to the skeleton line and having a
    length equal to the bead width".

    Our reading:
    - cut: the bead-width circles are the rounded ends of the cut walls. Tangent across the
      crossing (each opposite pair touching at the crossing point), their centres lie w/2 from it:
      r_c ≤ w/2 — the wall ends then still reach the crossing point, a larger circle leaves a void
      there (the study's failure mode). Reading "tangent" between neighbouring circles instead,
      r_c = (w/2)/sin(α/2) = w/√2, puts a void at the centre by construction, and with any one w
      no influence reading then meets Test 1's 7.0 mm as well as 2.5 mm.
    - influence: each segment stands on its branch, perpendicular to it, one bead width long; its
      far end, on the corner bisector, is one bead width from both neighbouring branches, so an
      arc started there lays its bead (w/2 each side) outside both walls' beads, in stock that is
      machined off: r_i ≥ w / sin(α/2) (√2·w at a right angle).
    At a right-angled crossing one bead width, 4.95 mm, gives (2.475, 7.000) mm: Test 1's
    (2.5, 7.0) to the paper's 0.1 mm (any w in [6.95/√2, 7.05/√2) = [4.914, 4.985) mm does); w = 5 mm gives 2.5/7.07.
    No reading gives both exactly: constructions from bead-width circles and segments at a right
    angle give ratios r_i/r_c that are multiples of √2 (here 2√2 = 2.83), Test 1's is 2.8.
    """
    half = math.radians(corner_angle_deg) / 2.0
    return bead_width / 2.0, bead_width / math.sin(half)


def crossing_window(bead_width: float, corner_angle_deg: float = 90.0) -> tuple[float, float]:
    """Radii the study's trials found sound, scaled to bead width w (mm) and narrowest fillet corner
    α (deg): (largest cut radius, smallest influence radius) = (0.8·w/2, √2·w/sin(α/2)); for
    w = 5 mm at a right angle (2.0, 10.0) mm — Test 3."""
    rc_max, ri_min = crossing_bounds(bead_width, corner_angle_deg)
    return TRIAL_CUT_SHARE * rc_max, TRIAL_INFLUENCE_FACTOR * ri_min


def _where(f: dict) -> str:
    return f"{f['kind']} at {[round(float(x), 3) + 0.0 for x in f['point']]}"


OVERLAP_DEG = 1.0  # a crossing's corner narrower than this: two walls on top of each other


def radius_warnings(f: dict, spec: "WallSpec", narrowest_deg: float) -> list[str]:
    """Warnings for crossing radii the study's trials found defective, naming junction and radius.
    Two branches leaving in one direction (a corner under `OVERLAP_DEG`) are overlapping walls, not
    a corner to fill: said so (the radius bound there was 1.5e15 mm: ezdxf's recover01.dxf)."""
    if narrowest_deg < OVERLAP_DEG:
        return [
            f"{_where(f)}: two of its walls leave it in the same direction (a corner of {narrowest_deg:.2g}°): "
            "they overlap — a duplicate or overlapping line in the sketch; delete one (both are deposited)"
        ]
    w = spec.bead_width
    rc_max, ri_min = crossing_bounds(w, narrowest_deg)
    rc_ok, ri_ok = crossing_window(w, narrowest_deg)
    # 1 µm: a sketch's right angle drawn as 89.9992° put the window at 8.00006 mm and warned
    # "influence_radius 8 mm is below 8.0 mm" (ezdxf's recover01.dxf, at every such crossing)
    eps = 1e-3
    out = []
    if spec.cut_radius > rc_ok + eps:
        beyond = " — beyond the bound itself" if spec.cut_radius > rc_max + eps else ""
        out.append(
            f"{_where(f)}: cut_radius {spec.cut_radius:g} mm exceeds {rc_ok:.1f} mm, 0.8 × the "
            f"theoretical maximum w/2 = {rc_max:.2f} mm for bead width {w:g} mm{beyond}: the study's "
            "Test 1 at the theoretical radius left a central void (Venturini et al. 2018); lower it"
        )
    if spec.influence_radius < ri_ok - eps:
        beyond = " — below the bound itself" if spec.influence_radius < ri_min - eps else ""
        out.append(
            f"{_where(f)}: influence_radius {spec.influence_radius:g} mm is below {ri_ok:.1f} mm, √2 × "
            f"the theoretical minimum w/sin(α/2) = {ri_min:.2f} mm (bead width {w:g} mm, fillet corner "
            f"{narrowest_deg:g}°){beyond}: the study's Tests 1-2 (7.0 and 8.0 mm with a 5 mm bead) left "
            "thin fillets; raise it"
        )
    return out


class _ChainEnds:
    """The chains' current end points, for the junctions' searches: a hash grid of cells twice the
    tolerance wide, so a junction looks at the ends in its own and the 8 neighbouring cells, not at
    every chain (ezdxf's recover01.dxf, ~3,000 walls a layer: 21 s of its crossings as a loop over
    the chains; bjnortier's Ceco.NET floor plan: 45 s as one numpy test over them per junction).
    `at` gives what the loop gave: chain by chain, the start before the end, each within tol."""

    def __init__(self, chains: list[_Chain], tol: float) -> None:
        self.chains = chains
        self.tol = tol
        self.h = 2.0 * max(tol, 1e-9)  # a point within tol is at most one cell away, rounding or not
        self.index = {id(c): k for k, c in enumerate(chains)}
        self.ends: dict[tuple[int, int], tuple[float, float]] = {}
        self.cells: dict[tuple[int, int], set[tuple[int, int]]] = defaultdict(set)
        for k, c in enumerate(chains):
            self._put(k, c)

    def _cell(self, p) -> tuple[int, int]:
        return (math.floor(p[0] / self.h), math.floor(p[1] / self.h))

    def _put(self, k: int, ch: _Chain) -> None:
        if ch.dropped:
            return
        for e, p in ((0, ch.xy[0]), (1, ch.xy[-1])):
            self.ends[(k, e)] = (float(p[0]), float(p[1]))
            self.cells[self._cell(p)].add((k, e))

    def at(self, J: np.ndarray) -> list[tuple[_Chain, bool]]:
        cx, cy = self._cell(J)
        near = sorted(ke for dx in (-1, 0, 1) for dy in (-1, 0, 1) for ke in self.cells.get((cx + dx, cy + dy), ()))
        if not near:
            return []
        pts = np.array([self.ends[ke] for ke in near], dtype=float)
        hit = np.hypot(pts[:, 0] - J[0], pts[:, 1] - J[1]) <= self.tol
        return [(self.chains[k], e == 0) for (k, e), h in zip(near, hit) if h]

    def moved(self, ch: _Chain) -> None:
        k = self.index[id(ch)]
        for e in (0, 1):
            p = self.ends.pop((k, e), None)
            if p is not None:
                self.cells[self._cell(p)].discard((k, e))
        self._put(k, ch)


def _apply_crossing(f: dict, spec: WallSpec, notes: list[str], index: _ChainEnds) -> None:
    J = np.array(f["point"], float)
    ends = []  # (chain, at_start, outward direction)
    for ch, at_start in index.at(J):
        seq = ch.xy if at_start else ch.xy[::-1]
        nxt = next((q for q in seq[1:] if np.hypot(*(q - J)) > 1e-9), seq[-1])
        ends.append((ch, at_start, _unit(nxt - J)))
    if len(ends) < 3:
        return
    ends.sort(key=lambda e: math.atan2(e[2][1], e[2][0]))
    geo = crossing_geometry(J, [e[2] for e in ends], spec.cut_radius, spec.influence_radius, spec.corner_angle_deg)
    fillets = geo.corner_angles_deg[~np.isnan(geo.fillet_lengths)]
    if spec.bead_width > 0 and len(fillets):
        notes.extend(radius_warnings(f, spec, float(fillets.min())))
    trimmed_ok = []
    for k, (ch, at_start, _d) in enumerate(ends):
        seq = ch.xy if at_start else ch.xy[::-1]
        t = trim_from_start(seq, J, spec.cut_radius)
        if t is None or len(t) < 2:
            ch.dropped = True
            index.moved(ch)
            notes.append(f"wall piece at {J.round(3).tolist()} lies inside the cutting circle: dropped")
            trimmed_ok.append(False)
            continue
        ch.xy = t if at_start else t[::-1]
        index.moved(ch)
        trimmed_ok.append(True)
    n = len(ends)
    for k, (ch, at_start, _d) in enumerate(ends):
        if not trimmed_ok[k]:
            continue
        c_k = ch.xy[0] if at_start else ch.xy[-1]
        if not np.isnan(geo.influence_points[k][0]):
            extra, inside = geo.influence_points[k], False  # fillet lead from machined-off stock
        else:
            extra, inside = geo.cut_points[(k + 1) % n], True  # bridge across a flat corner
        if np.hypot(*(extra - c_k)) <= 1e-9:
            continue
        if at_start:
            ch.head, ch.head_inside = [extra], [inside]
        else:
            ch.tail, ch.tail_inside = [extra], [inside]


def _apply_free_end(f: dict, spec: WallSpec, index: _ChainEnds) -> None:
    if spec.free_end_extension <= 0:
        return
    J = np.array(f["point"], float)
    for ch, at_start in index.at(J):
        seq = ch.xy if at_start else ch.xy[::-1]
        nxt = next((q for q in seq[1:] if np.hypot(*(q - J)) > 1e-9), None)
        if nxt is None:
            continue
        ext = J - spec.free_end_extension * _unit(nxt - J)
        if at_start:
            ch.head, ch.head_inside = [ext], [False]
        else:
            ch.tail, ch.tail_inside = [ext], [False]


# ------------------------------------------------------------------------------------------
# Ordering
# ------------------------------------------------------------------------------------------
def stock_ends(p: WallPass) -> tuple[bool, bool]:
    """(start, end): whether the pass's first/last segment lies in machining stock (inside False)."""
    if not len(p.inside):
        return False, False
    return not bool(p.inside[0]), not bool(p.inside[-1])


def order_passes(passes: list[WallPass], start=None, seam: str = "stock") -> list[WallPass]:
    """Greedy nearest neighbour from `start` (default: lower-left of all passes); closed laps are
    not rotated. seam "stock": a pass with machining stock at one end only (an extension or a
    fillet lead) ignites there (Venturini et al. 2018: start/stop in stock that is machined off),
    else either end may lead; "nearest": either end, whichever is nearer. Each step scores every
    (pass, way round) left at once; of them, in the order pass by pass, forwards before reversed,
    the first that is nearer by more than 1e-9 mm than the best so far wins (a loop over them in
    Python took 14 s of a 3,000-walls-a-layer sketch)."""
    if not passes:
        return []
    left = list(passes)
    pos = np.asarray(start, float) if start is not None else np.vstack([p.xy for p in left]).min(axis=0)
    heads = np.array([[p.xy[0], p.xy[-1]] for p in left], dtype=float)  # (n, 2 ways, 2): where each way ignites
    allowed = np.ones((len(left), 2), dtype=bool)
    if seam == "stock":
        for k, p in enumerate(left):
            s0, s1 = stock_ends(p)
            if s0 != s1:
                allowed[k] = (not s1, not s0)  # ignite in the stock end
    keep = np.arange(len(left))
    out: list[WallPass] = []
    while len(keep):
        d = np.hypot(*(heads[keep] - pos).transpose(2, 0, 1)).ravel()  # pass by pass, forwards then reversed
        d[~allowed[keep].ravel()] = np.inf
        best = int(np.flatnonzero(np.isfinite(d))[0])  # every pass can be laid at least one way round
        while True:  # the scan's next improvement comes after the best so far
            better = np.flatnonzero(d[best + 1 :] < d[best] - 1e-9)
            if not len(better):
                break
            best += 1 + int(better[0])
        k, rev = divmod(best, 2)
        p = left[int(keep[k])]
        keep = np.delete(keep, k)
        p = p.reversed() if rev else p
        out.append(p)
        pos = p.xy[-1]
    return out


def passes_without_stock(passes) -> list[str]:
    """Keys of wall passes that have no machining stock at either end (they ignite on the wall)."""
    return [p.key for p in passes if p.strategy == "wall" and not any(stock_ends(p))]


# ------------------------------------------------------------------------------------------
# Entry point
# ------------------------------------------------------------------------------------------
def _features_digest(features: list[dict]) -> str:
    """Digest of a layer's features without their layer and height (what the walls use)."""
    rows = [{k: v for k, v in f.items() if k not in ("layer", "z")} for f in features]
    return hashlib.sha1(json.dumps(rows, sort_keys=True, default=str).encode()).hexdigest()


def _wall_passes(
    curves: list[np.ndarray], features: list[dict], spec: WallSpec
) -> tuple[list[np.ndarray], tuple[WallPass, ...], tuple[str, ...]]:
    """(the curves joined, the wall passes in chain order, notes): what a layer's curves and
    features give whatever the layer's height, start point or tubes."""
    tol = spec.tol
    curves, _ = join_collinear(curves, spec.join_gap, spec.join_angle_deg, tol)
    notes: list[str] = []
    tubes = [f for f in features if f["kind"] == "tubular"]
    in_tubes = {e for f in tubes for e in f["entities"]}
    crossings = [f for f in features if f["kind"] in CROSSING_KINDS]
    joints = [np.array(f["point"], float) for f in features if f["kind"] in JUNCTION_KINDS]
    pieces = chain_pieces(split_curves(curves, crossings, in_tubes, tol), joints, tol)
    chains = [_Chain(p) for p in pieces]
    index = _ChainEnds(chains, tol)
    for f in crossings:
        _apply_crossing(f, spec, notes, index)
    for f in features:
        if f["kind"] == "free_end":
            _apply_free_end(f, spec, index)
    corners = [f for f in features if f["kind"] == "corner"]
    corner_r = spec.fillet_radius + spec.effective_width / 2.0 if spec.fillet_radius > 0 else 0.0
    for ch in chains:
        if not ch.dropped and corner_r > 0:
            ch.xy, more = round_corners(ch.xy, corners, corner_r, max(tol, 1e-6))
            notes.extend(more)
    passes: list[WallPass] = []
    for k, ch in enumerate(c for c in chains if not c.dropped):
        xy, inside = ch.path()
        passes.append(WallPass(f"wall{k}", "wall", xy, inside))
    if spec.fillet_radius > 0 and spec.bead_width > 0:
        for f in crossings:
            for a0, a1, empty in fillet_uncovered(f, passes, spec):
                notes.append(
                    f"{_where(f)}: fillet_radius {spec.fillet_radius:g} mm between the branches at "
                    f"{a0:.0f}° and {a1:.0f}° gets no metal on {empty:.1f} mm² (bead {spec.bead_width:g} "
                    f"mm, EWW {spec.effective_width:g} mm): raise influence_radius or the bead width, "
                    "or lower fillet_radius"
                )
    return curves, tuple(passes), tuple(notes)


def plan_layer_walls(
    curves,
    features: list[dict],
    spec: WallSpec = WallSpec(),
    *,
    layer_index: int = 0,
    start=None,
    seam: str = "stock",
    memo: dict | None = None,
) -> LayerWalls:
    """Passes of one layer from its curves ((k, 2) arrays or LineStrings, mm) and its features.
    `memo`: a dict kept over the layers of one plan; layers with the same curves and features
    (an extruded sketch's) share their wall passes, planned once (only tubes and order are the
    layer's own: bjnortier's Ceco.NET floor plan, 15 layers of 1,546 walls, with `_ChainEnds` and
    `split_curves`' index: the node 102 s → 7 s)."""
    curves = [np.asarray(c.coords if hasattr(c, "coords") else c, float)[:, :2] for c in curves]
    memo_key = (curves_digest(curves), _features_digest(features), spec) if memo is not None else None
    planned = memo.get(memo_key) if memo is not None else None
    if planned is None:
        planned = _wall_passes(curves, features, spec)
        if memo is not None:
            memo[memo_key] = planned
    curves, walls, wall_notes = planned
    passes, notes = list(walls), list(wall_notes)
    tol = spec.tol
    tubes = [f for f in features if f["kind"] == "tubular"]
    helical: list[tuple[str, np.ndarray]] = []
    for k, f in enumerate(tubes):
        ring = chain_loop(curves, f["entities"], tol)
        key = f"tube{k}"
        if f.get("isolated") and spec.tubular == "helical":
            helical.append((key, ring))
            continue
        mode = spec.tubular if f.get("isolated") else "scattered"
        if not f.get("isolated") and spec.tubular != "scattered":
            notes.append(f"{key} is not isolated (torch could collide): built layer by layer, scattered")
        xy = aligned_loop(ring, spec.overlap) if mode == "aligned" else scattered_loop(ring, layer_index, spec.overlap)
        passes.append(WallPass(key, mode, xy, np.ones(len(xy) - 1, bool)))
    if seam == "stock":
        for key in passes_without_stock(passes):
            notes.append(
                f"{key} has no machining stock at either end: it ignites on the finished wall "
                "(extend its ends or start it at a crossing)"
            )
    return LayerWalls(tuple(order_passes(passes, start, seam)), tuple(helical), tuple(notes))
