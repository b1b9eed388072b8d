"""Seams: where each section path ignites, layer after layer (issue #22).

Stacked arc starts are the classic WAAM defect: the ignition hump and the extinction crater of one
layer sit on those of the layer below. A zoned section path can be entered in a few ways without
re-planning it:

- `planned`: as the strategy laid it;
- `reversed`: run backwards;
- `rethreaded` / `rethreaded-reversed` (a serpentine of ≥ 2 parallel passes joined by straight links
  whose other ends line up — see `_passes`; a rounded corner is not a link): every pass run the
  other way and the links moved to the other side, so the path starts and ends at the other end
  of the passes (a 2-pass serpentine that starts and ends at a junction then starts and ends at
  the section's free end);
- `rotated` (a closed loop): started at another point of the loop.

Zones follow the path: the ignition zone `start` is re-measured as the first start-zone length of
the new path, `end` as the last end-zone length, middle zones keep their geometry and ids, and
arc-ON speeds are re-applied from the zone parameters.

An entry is *allowed* unless it ignites on the finished part at a junction: within the clearance
(one bead width) of another section's deposition in the same layer. An entry whose first segment
lies outside the section (`inside` False: machining stock, thin-wall extensions and fillet leads)
is preferred over every entry that ignites on the part (Venturini et al. 2018: start and stop in
stock that is machined off).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence, cast

import numpy as np

from ..core.model import SectionPath
from ..core.tolerances import TOL
from ..zoning.zones import cumulative_length, insert_points, path_axis, zone_color
from .arc_runs import arc_runs

GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
DEFAULT_CLEARANCE = 6.0  # mm: one bead width of the shipped MPP recipes, used when none is given
PASS_COS = math.cos(math.radians(30.0))  # a segment within 30° of the path's axis belongs to a pass


class Entry:
    """One way into a section path: `name` and the path as it would be deposited. The path can be
    given built, or as `build` (called once, on first use) with its first point and whether its
    first segment lies inside the section (`head`): the choice reads only those, so the entries it
    passes over are never built (re-zoning three of four candidates was most of the sequence
    node's time: bench_replan's 500-layer cross, 1500 paths)."""

    __slots__ = ("name", "_path", "_build", "_head")

    def __init__(
        self,
        name: str,
        path: SectionPath | None = None,
        *,
        build: Callable[[], SectionPath] | None = None,
        head: tuple[np.ndarray, bool] | None = None,
    ) -> None:
        if path is None and (build is None or head is None):
            raise ValueError("an Entry needs its path, or a build and its head")
        self.name = name
        self._path = path
        self._build = build
        self._head = head

    @property
    def path(self) -> SectionPath:
        if self._path is None:
            self._path = cast(Callable[[], SectionPath], self._build)()
            self._build = None
        return self._path

    @property
    def ignition(self) -> np.ndarray:
        if self._head is not None:
            return np.asarray(self._head[0], dtype=float)
        return np.asarray(self.path.points[0], dtype=float)

    @property
    def in_stock(self) -> bool:
        if self._head is not None:
            return not self._head[1]
        return bool(len(self.path.inside)) and not bool(self.path.inside[0])

    def __repr__(self) -> str:
        return f"Entry({self.name!r})"


# ------------------------------------------------------------------------------------------------
# zones of a re-threaded path
# ------------------------------------------------------------------------------------------------
def _rezone(
    new: SectionPath, start_len: float, end_len: float, speeds_by_zone: dict[str, float], plain_speed: float | None
) -> SectionPath:
    """Relabel `new` (segments carry the zone ids they had in the original path): `start` = the first
    start_len mm, `end` = the last end_len mm, former start/end segments elsewhere take the id of
    the nearest middle zone. Arc-ON speeds from `speeds_by_zone` (zone → travel_speed), else
    `plain_speed` for segments whose old zone had a travel speed and whose new one has none."""
    if not new.zone:
        return new
    pts = np.asarray(new.points, dtype=float)
    L = float(cumulative_length(pts)[-1])
    cuts = [c for c in (start_len, L - end_len) if 0.0 < c < L]
    out = insert_points(new, cuts)
    s = cumulative_length(np.asarray(out.points, dtype=float))
    mid = 0.5 * (s[:-1] + s[1:])
    old = list(out.zone)
    middle = [i for i, z in enumerate(old) if z not in ("start", "end")]
    zones: list[str] = []
    for i, m in enumerate(mid):
        if start_len > 0 and m < start_len:
            zones.append("start")
        elif end_len > 0 and m > L - end_len:
            zones.append("end")
        elif old[i] not in ("start", "end"):
            zones.append(old[i])
        elif middle:
            zones.append(old[min(middle, key=lambda j: abs(mid[j] - m))])
        else:
            zones.append("z1")
    speed = np.asarray(out.speed, dtype=float).copy()
    arc = np.asarray(out.arc, dtype=bool)
    for i, (zo, zn) in enumerate(zip(old, zones)):
        if not arc[i] or zo == zn:
            continue
        if zn in speeds_by_zone:
            speed[i] = speeds_by_zone[zn]
        elif zo in speeds_by_zone and plain_speed is not None:
            speed[i] = plain_speed
    colors = {z: new.zone_colors.get(z, zone_color(z)) for z in dict.fromkeys(zones)}
    return dataclasses.replace(out, zone=tuple(zones), zone_colors=colors, speed=speed)


def _zone_context(sp: SectionPath) -> tuple[float, float, dict[str, float], float | None]:
    lengths = sp.segment_lengths
    start_len = float(sum(l for z, l in zip(sp.zone, lengths) if z == "start"))
    end_len = float(sum(l for z, l in zip(sp.zone, lengths) if z == "end"))
    speeds = {z: float(v["travel_speed"]) for z, v in sp.zone_params.items() if v.get("travel_speed") is not None}
    arc = np.asarray(sp.arc, dtype=bool)
    plain = [float(v) for v, z, a in zip(sp.speed, sp.zone or [""] * len(arc), arc) if a and z not in speeds]
    return start_len, end_len, speeds, (float(np.median(plain)) if plain else None)


def _with(sp: SectionPath, pts, arc, inside, speed, zone, axis) -> SectionPath:
    return dataclasses.replace(
        sp,
        points=np.asarray(pts, float),
        arc=np.asarray(arc, bool),
        inside=np.asarray(inside, bool),
        speed=np.asarray(speed, float),
        zone=tuple(zone),
        tool_axis=None if axis is None else np.asarray(axis, float),
        approach=None,
    )


def reverse_path(sp: SectionPath) -> SectionPath:
    """The path run backwards, its start and end zones re-measured at the new ends."""
    ax = None if sp.tool_axis is None else np.asarray(sp.tool_axis)[::-1]
    rev = _with(
        sp,
        np.asarray(sp.points)[::-1],
        np.asarray(sp.arc)[::-1],
        np.asarray(sp.inside)[::-1],
        np.asarray(sp.speed)[::-1],
        tuple(reversed(sp.zone)),
        ax,
    )
    return _rezone(rev, *_zone_context(sp))


def _passes(sp: SectionPath) -> list[tuple[int, int]] | None:
    """Vertex ranges [a, b] of the passes of a serpentine (runs of segments along the path's axis),
    or None when the path is not pass, link, pass, … (≥ 2 passes, starting and ending on a pass).

    Re-threading replaces each link by one straight segment between the other ends of its passes,
    so a serpentine here is one whose every link *is* one straight segment, between passes that run
    opposite ways, and whose other ends are as far apart as the link (`TOL.merge`): the deposit
    keeps its length. A corner turned over several segments (a fillet, a semicircular or triangular
    link) is path, not link: the segments of a rounded L wall whose axis runs diagonally fall on
    both sides of the 30° test, and reading them as two passes dropped the corner (thin-wall-panel,
    fillet_radius 3: 1459.479 mm welded on odd layers instead of 1412.334)."""
    pts = np.asarray(sp.points, dtype=float)
    d = np.diff(pts, axis=0)
    n = np.linalg.norm(d, axis=1)
    axis = path_axis(pts)
    along = np.abs(d @ axis) >= PASS_COS * np.maximum(n, 1e-12)
    runs = arc_runs(along)  # [start, stop) ranges of segments along the axis
    if len(runs) < 2 or runs[0][0] != 0 or runs[-1][1] != len(along):
        return None
    for (a0, a1), (b0, b1) in zip(runs[:-1], runs[1:]):
        if b0 - a1 != 1:  # the link is one segment
            return None
        if float((pts[a1] - pts[a0]) @ (pts[b1] - pts[b0])) >= 0:  # passes alternate direction
            return None
        if abs(float(np.linalg.norm(pts[b1] - pts[a0])) - float(n[a1])) > TOL.merge:  # ends line up
            return None
    return runs


def rethread_path(sp: SectionPath) -> SectionPath | None:
    """A serpentine of parallel passes threaded from the other end (each pass reversed, links on
    the other side, attributes of the original links), or None when `sp` is not a serpentine."""
    runs = _passes(sp)
    if runs is None:
        return None
    return _rethread(sp, runs)


def _rethread(sp: SectionPath, runs: list[tuple[int, int]]) -> SectionPath:
    """`rethread_path` on the passes `_passes` found."""
    pts, arc, ins, spd = (np.asarray(x) for x in (sp.points, sp.arc, sp.inside, sp.speed))
    zone = list(sp.zone) if sp.zone else [""] * len(arc)
    ax = None if sp.tool_axis is None else np.asarray(sp.tool_axis)
    P: list[Any] = []
    A: list[Any] = []
    I: list[Any] = []
    S: list[Any] = []
    Z: list[Any] = []
    X: list[Any] = []
    for r, (a, b) in enumerate(runs):
        if r:  # link from the end of the previous reversed pass (its vertex a_prev) to this one's end b
            link = runs[r - 1][1]  # first segment of the original link
            A.append(arc[link])
            I.append(ins[link])
            S.append(spd[link])
            Z.append(zone[link])
        P.extend(pts[a : b + 1][::-1])
        if ax is not None:
            X.extend(ax[a : b + 1][::-1])
        A.extend(arc[a:b][::-1])
        I.extend(ins[a:b][::-1])
        S.extend(spd[a:b][::-1])
        Z.extend(zone[a:b][::-1])
    new = _with(sp, P, A, I, S, tuple(Z) if sp.zone else (), X if ax is not None else None)
    return _rezone(new, *_zone_context(sp))


def rotate_loop(sp: SectionPath, s0: float) -> SectionPath:
    """A closed loop (first point = last) started at arc length s0 (mm) along it."""
    pts = np.asarray(sp.points, dtype=float)
    L = float(cumulative_length(pts)[-1])
    s0 = float(s0) % L if L > 0 else 0.0
    cut = insert_points(sp, [s0])
    cp = np.asarray(cut.points, dtype=float)
    s = cumulative_length(cp)
    k = int(np.argmin(np.abs(s - s0)))
    if k in (0, len(cp) - 1):
        return _rezone(dataclasses.replace(sp, approach=None), *_zone_context(sp))
    order = list(range(k, len(cp) - 1)) + list(range(0, k))  # segment indices from the seam
    P = np.vstack([cp[k:], cp[1 : k + 1]])
    X = None
    if cut.tool_axis is not None:
        ta = np.asarray(cut.tool_axis)
        X = np.vstack([ta[k:], ta[1 : k + 1]])
    z = tuple(cut.zone[i] for i in order) if cut.zone else ()
    new = _with(cut, P, np.asarray(cut.arc)[order], np.asarray(cut.inside)[order], np.asarray(cut.speed)[order], z, X)
    return _rezone(new, *_zone_context(sp))


def is_closed(sp: SectionPath, tol: float = 1e-6) -> bool:
    pts = np.asarray(sp.points, dtype=float)
    return len(pts) > 3 and float(np.linalg.norm(pts[0] - pts[-1])) <= tol and bool(np.all(sp.arc))


# strategies that place their own seams (thin-wall tubulars and ring laps): entered as planned
OWN_SEAM = frozenset({"helical", "aligned", "scattered", "perimeter"})
# a thin wall's path is the wall: entered either way round, never re-threaded. A U-shaped wall
# (two sides and the top between them) reads as a serpentine of two passes and a link; re-threaded,
# its top edge was replaced by a bead across the open bottom (ezdxf's recover01.dxf, every other
# layer: 16.9 % of the part without metal)
WALL_PATH = frozenset({"wall"})


def entries(sp: SectionPath) -> list[Entry]:
    """The open-path entries of `sp` (closed loops: see `rotate_loop`). Each but `planned` is built
    on first use of its path; its ignition and stock test are read off `sp` (the first point and
    the first segment's `inside` of the path it builds: re-zoning only adds vertices inside
    segments, so neither moves)."""
    out = [Entry("planned", dataclasses.replace(sp, approach=None))]
    if sp.strategy in OWN_SEAM or sp.tool or len(sp.points) < 2:
        return out
    pts, ins = np.asarray(sp.points), np.asarray(sp.inside, dtype=bool)
    out.append(Entry("reversed", build=lambda: reverse_path(sp), head=(pts[-1], bool(ins[-1]))))
    runs = None if sp.strategy in WALL_PATH else _passes(sp)
    if runs is not None:
        built: list[SectionPath] = []

        def re() -> SectionPath:
            if not built:
                built.append(_rethread(sp, runs))
            return built[0]

        # the re-threaded path starts at the far end of the first pass (its last segment, run
        # backwards) and ends at the near end of the last pass (its first segment)
        (_, b0), (a1, _) = runs[0], runs[-1]
        out += [
            Entry("rethreaded", build=re, head=(pts[b0], bool(ins[b0 - 1]))),
            Entry("rethreaded-reversed", build=lambda: reverse_path(re()), head=(pts[a1], bool(ins[a1]))),
        ]
    return out


# ------------------------------------------------------------------------------------------------
# the choice
# ------------------------------------------------------------------------------------------------
def _deposit_segments(paths: Sequence[SectionPath]) -> tuple[np.ndarray, np.ndarray]:
    a, b = [], []
    for sp in paths:
        pts = np.asarray(sp.points, dtype=float)
        on = np.asarray(sp.arc, dtype=bool) & np.asarray(sp.inside, dtype=bool)
        a.append(pts[:-1][on])
        b.append(pts[1:][on])
    if not a:
        return np.zeros((0, 3)), np.zeros((0, 3))
    return np.vstack(a), np.vstack(b)


class LayerSegments:
    """The deposit segments of a layer's section paths, stacked once with the path each belongs
    to: `others(i)` are those of every path but i. A layer of n paths gathered the others' anew
    for each path, O(n²) in Python (ezdxf's recover01.dxf, ~3,000 walls a layer: 35 of a 240 s run)."""

    def __init__(self, paths: Sequence[SectionPath]) -> None:
        parts = [_deposit_segments([sp]) for sp in paths]
        self.a = np.vstack([p[0] for p in parts]) if parts else np.zeros((0, 3))
        self.b = np.vstack([p[1] for p in parts]) if parts else np.zeros((0, 3))
        self.owner = np.repeat(np.arange(len(parts)), [len(p[0]) for p in parts])

    def others(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        keep = self.owner != i
        return self.a[keep], self.b[keep]


def distances_to_segments(ps: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(k,) distances (mm) in the layer plane (x, y) from each of ps (k, ≥2) to the nearest segment
    a→b; inf where there is none. One call for a path's candidate ignitions (the same figures, bit
    for bit, as one call per point: the 500-layer cross asked 6,000 times)."""
    ps = np.asarray(ps, dtype=float)
    if not len(a):
        return np.full(len(ps), math.inf)
    p2, a2 = ps[:, None, :2], a[None, :, :2]
    d = b[:, :2] - a[:, :2]
    dd = np.einsum("ij,ij->i", d, d)
    t = np.clip(np.einsum("kij,ij->ki", p2 - a2, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    foot = a2 + t[:, :, None] * d[None]
    return np.asarray(np.min(np.linalg.norm(foot - p2, axis=2), axis=1))


def nearest_distances(ps: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(k,) distances (mm) in the layer plane from each of ps to the nearest of `points` (m, 3); inf if none."""
    ps = np.asarray(ps, dtype=float)
    if not len(points):
        return np.full(len(ps), math.inf)
    return np.asarray(np.min(np.linalg.norm(np.asarray(points, float)[None, :, :2] - ps[:, None, :2], axis=2), axis=1))


def nearest_distance(p: np.ndarray, points: np.ndarray) -> float:
    """Distance (mm) in the layer plane from p to the nearest of `points` (k, 3); inf if none."""
    return float(nearest_distances(np.asarray(p, dtype=float)[None], points)[0])


@dataclass(frozen=True)
class SeamSpec:
    """policy: auto | alternate | aligned | stagger | scattered, or an (x, y, z) world point.
    clearance: mm, one bead width (junction test; the distance auto/stagger keep from the layer
    below). shift: mm the seam of a closed loop moves per layer (stagger). at_junctions: allow
    ignition at a junction."""

    policy: str | tuple[float, float, float] = "auto"
    clearance: float = DEFAULT_CLEARANCE
    shift: float = 2 * DEFAULT_CLEARANCE
    at_junctions: bool = False


_PREF = {
    0: ("planned", "rethreaded", "reversed", "rethreaded-reversed"),
    1: ("reversed", "rethreaded-reversed", "planned", "rethreaded"),
}


def _loop_entry(sp: SectionPath, index: int, spec: SeamSpec, below: np.ndarray) -> Entry:
    pts = np.asarray(sp.points, dtype=float)
    L = float(cumulative_length(pts)[-1])
    pol = spec.policy
    if not isinstance(pol, str):
        from ..zoning.zones import project_onto_path

        s0 = float(project_onto_path(pts, np.asarray(pol, float)[None, :])[0])
    elif pol == "aligned":
        s0 = 0.0
    elif pol == "scattered":
        s0 = (index * GOLDEN % 1.0) * L
    elif pol == "alternate":
        path = reverse_path(sp) if index % 2 else dataclasses.replace(sp, approach=None)
        return Entry("reversed" if index % 2 else "planned", path)
    else:  # stagger / auto: the seam moves on by `shift` mm per layer
        s0 = (index * spec.shift) % L if L > 0 else 0.0
    return Entry("rotated", rotate_loop(sp, s0))


def choose_entry(
    sp: SectionPath,
    index: int,
    spec: SeamSpec,
    others: Sequence[SectionPath],
    below: np.ndarray,
    segments: Callable[[], tuple[np.ndarray, np.ndarray]] | None = None,
) -> tuple[Entry, bool]:
    """The entry of `sp` on layer `index`. others: the layer's other section paths (junction test);
    below: (k, 3) ignition points of the layer below. segments: the deposit segments of `others`
    (`layer_segments`), made when needed, instead of from `others`. Returns (entry, ok) with ok
    False when every entry ignites at a junction (the caller warns)."""
    if sp.strategy not in OWN_SEAM and not sp.tool and is_closed(sp):
        return _loop_entry(sp, index, spec, below), True
    cands = entries(sp)
    a, b = segments() if segments is not None else _deposit_segments(others)

    ok = cands if spec.at_junctions else _away_from_junctions(cands, a, b, spec.clearance)
    fine = bool(ok)
    if not ok:
        ok = cands
    stock = [e for e in ok if e.in_stock]
    if stock:
        ok = stock
    pref = _PREF[index % 2 if spec.policy in ("alternate", "auto", "stagger", "scattered") else 0]
    ok = sorted(ok, key=lambda e: pref.index(e.name) if e.name in pref else len(pref))
    pol = spec.policy
    if not isinstance(pol, str):
        p = np.asarray(pol, float)
        return min(ok, key=lambda e: nearest_distance(e.ignition, p[None, :])), fine
    if pol in ("aligned", "alternate") or not len(below):
        return ok[0], fine
    # auto / stagger / scattered on an open path: the allowed entry farthest from the starts below
    # (ties: the alternate preference), so consecutive layers never share an ignition point
    gaps = nearest_distances(np.array([e.ignition for e in ok]), below).tolist()
    best = max(range(len(ok)), key=lambda i: (round(min(gaps[i], 1e6), 6), -i))
    return ok[best], fine


def _away_from_junctions(cands: list[Entry], a: np.ndarray, b: np.ndarray, clearance: float) -> list[Entry]:
    """The entries that do not ignite at a junction: in stock, or farther than `clearance` from
    the other paths' deposit segments a→b (one distance call for them all)."""
    test = [i for i, e in enumerate(cands) if not e.in_stock]
    if not test:
        return list(cands)
    d = distances_to_segments(np.array([cands[i].ignition for i in test]), a, b).tolist()
    near = {i for i, x in zip(test, d) if x < clearance - 1e-9}
    return [e for i, e in enumerate(cands) if i not in near]


def ignition_points(paths: Sequence[SectionPath]) -> np.ndarray:
    """(k, 3) world mm: the first point of every arc-ON run of the paths."""
    out = []
    for sp in paths:
        arc = np.asarray(sp.arc, dtype=bool)
        pts = np.asarray(sp.points, dtype=float)
        prev = False
        for i, on in enumerate(arc):
            if on and not prev:
                out.append(pts[i])
            prev = bool(on)
    return np.asarray(out, dtype=float).reshape(-1, 3)


__all__ = [
    "DEFAULT_CLEARANCE",
    "Entry",
    "SeamSpec",
    "choose_entry",
    "distances_to_segments",
    "entries",
    "ignition_points",
    "is_closed",
    "nearest_distance",
    "nearest_distances",
    "rethread_path",
    "reverse_path",
    "rotate_loop",
]
