"""Layer path: join section paths into one layer program (Michel et al. 2019, step 6).

Deposition is not continuous: at the end of a section the arc stops and the torch travels, arc OFF
and without wire, to the next section's start — retract along the build direction by
`retract_height`, travel at that clearance above the higher of the two points, plunge. Order matters:
a sorting algorithm cuts travel, but the user may impose an order (depositing across the waving
border of an earlier oscillated section closes voids; the sequence affects distortion).

Orders: `mask` (the mask's section order, i.e. the order of the input), `nearest` (nearest neighbour
from the previous layer's end, improved by 2-opt on the open, asymmetric tour, within the ranks of
the MPP order rule: sections listed in `precedence`, then oscillated sections, then the parallel
ones they feed), or an explicit list of section keys (keys missing from the list follow in mask
order). A mask or explicit order that breaks the rule is kept and reported.

Where each path ignites is chosen by a seam policy (`seams.py`: a path may be reversed, a
serpentine re-threaded, a loop rotated; start/end zones are re-measured at the new ends), and
arc-ON runs shorter than `min_run` are bridged or dropped (`arc_runs.py`). `alternate` also
reverses the *order of sections* on odd layers (within the rule's ranks for `nearest`).
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any, Callable, NamedTuple, Sequence

import numpy as np

from ..core.model import LayerPaths, SectionPath
from .arc_runs import enforce_min_run
from .seams import LayerSegments, SeamSpec, choose_entry, ignition_points

MAX_2OPT_ROUNDS = 50
EXACT_MAX = 6  # up to 6 sections (720 orders) every order is scored at once with numpy: exact


def travel_cost(ends: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """(n, n) straight-line distance (mm) from the end of section i to the start of section j."""
    return np.linalg.norm(ends[:, None, :] - starts[None, :, :], axis=2)


def tour_length(order: Sequence[int], cost: np.ndarray, start_cost: np.ndarray | None) -> float:
    """Travel (mm) of visiting sections in `order`: from the start point (start_cost[j]) then between sections."""
    total = 0.0 if start_cost is None or not len(order) else float(start_cost[order[0]])
    for a, b in zip(order[:-1], order[1:]):
        total += float(cost[a, b])
    return total


def nearest_order(cost: np.ndarray, start_cost: np.ndarray | None) -> list[int]:
    """Nearest neighbour from the start point (or from section 0 when None), improved by local search.

    cost: (n, n) end-of-i → start-of-j travel, mm. start_cost: (n,) start point → start of j, mm.
    The tour is open and asymmetric (a section is entered at its start and left at its end), so
    moves are scored by recomputing the tour length (n is a handful of sections per layer). Local
    search = 2-opt (reverse a run) + Or-opt (move a run of 1–3 sections elsewhere), run from the
    nearest-neighbour tour and from the mask order; the shorter result is kept, so the order is
    never longer than the mask's. Layers of up to EXACT_MAX sections are solved exactly instead.
    """
    n = len(cost)
    if n == 0:
        return []
    if n <= EXACT_MAX:
        return _exact_order(cost, start_cost)
    fixed_first = start_cost is None  # without a start point, section 0 (the mask's first) leads
    first = 0 if start_cost is None else int(np.argmin(start_cost))
    order, left = [first], set(range(n)) - {first}
    while left:
        last = order[-1]
        nxt = min(left, key=lambda j: (cost[last, j], j))
        order.append(nxt)
        left.remove(nxt)
    best = None
    for seed in (order, list(range(n))):
        cand = _local_search(seed, cost, start_cost, 1 if fixed_first else 0)
        length = tour_length(cand, cost, start_cost)
        if best is None or length < best[0] - 1e-9:
            best = (length, cand)
    assert best is not None  # two seeds tried
    return best[1]


def _exact_order(cost: np.ndarray, start_cost: np.ndarray | None) -> list[int]:
    """Shortest open tour by scoring every order (n ≤ EXACT_MAX); ties → the first in lexicographic order."""
    import itertools

    n = len(cost)
    perms = np.array(list(itertools.permutations(range(n))), dtype=np.int64).reshape(-1, n)
    if start_cost is None:
        perms = perms[perms[:, 0] == 0]
    total = cost[perms[:, :-1], perms[:, 1:]].sum(axis=1)
    if start_cost is not None:
        total = total + start_cost[perms[:, 0]]
    return perms[int(np.argmin(np.round(total, 9)))].tolist()


def _local_search(order: list[int], cost: np.ndarray, start_cost: np.ndarray | None, lo: int) -> list[int]:
    """2-opt, then Or-opt, first improvement in scan order, until a round improves nothing: each
    candidate move scored by its change of the tour's length, all of one scan at once (numpy), the
    first that shortens it by more than 1e-9 mm taken, then the scan goes on over the new order
    (the moves, order and outcome of scoring every candidate tour whole: 46 s for 5 layers of a
    DXF of ~200 walls a layer, O(n^4) a round). The order is kept as an array and the 2-opt's
    running sums of its edges are made once per order, not once per scan (ezdxf's recover01.dxf,
    ~3,000 walls a layer: the local search was 55 of its 118 s)."""
    n = len(order)
    o = np.asarray(order, dtype=np.int64)
    for _ in range(MAX_2OPT_ROUNDS):
        improved = False
        sums = _edge_sums(o, cost)
        for i in range(lo, n - 1):  # 2-opt: reverse o[i..k], k = i+1 .. n-1
            k0 = i + 1
            while k0 < n:
                delta = _reverse_deltas(o, cost, start_cost, i, k0, sums)
                hit = np.flatnonzero(delta < -1e-9)
                if not len(hit):
                    break
                k = k0 + int(hit[0])
                o = np.concatenate([o[:i], o[i : k + 1][::-1], o[k + 1 :]])
                sums = _edge_sums(o, cost)
                improved = True
                k0 = k + 1
        for run in (1, 2, 3):  # Or-opt: move o[i..i+run) to position j of the rest
            for i in range(lo, n - run + 1):
                delta = _move_deltas(o, cost, start_cost, i, run, lo)
                delta[i - lo] = np.inf  # j == i: where it is
                hit = np.flatnonzero(delta < -1e-9)
                if len(hit):
                    j = lo + int(hit[0])
                    piece, rest = o[i : i + run], np.concatenate([o[:i], o[i + run :]])
                    o = np.concatenate([rest[:j], piece, rest[j:]])
                    improved = True
        if not improved:
            break
    return o.tolist()


def _edge_sums(o: np.ndarray, cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(fwd, bwd): fwd[j] the tour's edges before position j, bwd[j] the same edges walked backwards."""
    fwd = np.concatenate([[0.0], np.cumsum(cost[o[:-1], o[1:]])])
    bwd = np.concatenate([[0.0], np.cumsum(cost[o[1:], o[:-1]])])
    return fwd, bwd


def _entry(o: np.ndarray, cost: np.ndarray, start_cost: np.ndarray | None, pos: int, to: np.ndarray) -> np.ndarray:
    """Cost of arriving at sections `to` in position `pos` of tour `o` (from the start point at 0)."""
    if pos > 0:
        return cost[o[pos - 1], to]
    return np.zeros(len(to)) if start_cost is None else start_cost[to]


def _reverse_deltas(
    order: list[int] | np.ndarray,
    cost: np.ndarray,
    start_cost: np.ndarray | None,
    i: int,
    k0: int,
    sums: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Change of the tour's length when order[i..k] is reversed, for k = k0 .. n-1 (`sums`: the
    order's `_edge_sums`, when made already)."""
    o = np.asarray(order)
    n = len(o)
    ks = np.arange(k0, n)
    fwd, bwd = sums if sums is not None else _edge_sums(o, cost)
    inner = (bwd[ks] - bwd[i]) - (fwd[ks] - fwd[i])
    entry = _entry(o, cost, start_cost, i, o[ks]) - _entry(o, cost, start_cost, i, o[i : i + 1])
    last = ks < n - 1
    nxt = o[np.minimum(ks + 1, n - 1)]
    exit_ = np.where(last, cost[o[i], nxt] - cost[o[ks], nxt], 0.0)
    return inner + entry + exit_


def _move_deltas(
    order: list[int] | np.ndarray, cost: np.ndarray, start_cost: np.ndarray | None, i: int, run: int, lo: int
) -> np.ndarray:
    """Change of the tour's length when order[i..i+run) moves to position j of the rest (the
    tour without it), for j = lo .. len(rest)."""
    o = np.asarray(order)
    n = len(o)
    a, b = o[i], o[i + run - 1]
    rest = np.concatenate([o[:i], o[i + run :]])
    # taken out: its entry and exit, the neighbours joined
    out = -_entry(o, cost, start_cost, i, o[i : i + 1])[0]
    if i + run < n:
        out += -cost[b, o[i + run]] + _entry(o, cost, start_cost, i, o[i + run : i + run + 1])[0]
    js = np.arange(lo, len(rest) + 1)
    prev = rest[np.maximum(js - 1, 0)] if len(rest) else np.zeros(len(js), dtype=int)  # at j > 0
    inside = js < len(rest)
    nxt = rest[np.minimum(js, len(rest) - 1)] if len(rest) else np.zeros(len(js), dtype=int)
    first = js == 0  # arriving from the start point
    prev_in = np.where(first, 0.0 if start_cost is None else start_cost[a], cost[prev, a])
    join = np.where(inside, np.where(first, 0.0 if start_cost is None else start_cost[nxt], cost[prev, nxt]), 0.0)
    into = prev_in + np.where(inside, cost[b, nxt], 0.0) - join
    return out + into


def explicit_order(keys: Sequence[str], wanted: Sequence[str]) -> list[int]:
    """Indices of `keys` in the order of `wanted`; keys not listed follow in their own order."""
    pos = {k: i for i, k in enumerate(keys)}
    order = [pos[k] for k in wanted if k in pos]
    seen = set(order)
    return order + [i for i in range(len(keys)) if i not in seen]


def approach_points(prev_end: np.ndarray | None, start: np.ndarray, up: np.ndarray, retract: float) -> np.ndarray:
    """Arc-OFF travel points flown before `start` (k, 3), mm.

    From prev_end: retract along `up` to `retract` mm above the higher of the two points, travel,
    and stop above `start` (the plunge to `start` is the move to points[0]). Without prev_end (first
    section of the part) the torch comes down from `retract` above the start.
    """
    up = up / np.linalg.norm(up)
    if prev_end is None:
        return (start + retract * up)[None, :]
    h = max(float(prev_end @ up), float(start @ up)) + retract
    a = prev_end + (h - float(prev_end @ up)) * up
    b = start + (h - float(start @ up)) * up
    if np.linalg.norm(a - b) <= 1e-9:
        return a[None, :]
    return np.vstack([a, b])


def travel_length(prev_end: np.ndarray | None, sp: SectionPath) -> float:
    """Length (mm) of the arc-OFF move into `sp`: prev_end → approach points → points[0]."""
    if prev_end is None or sp.approach is None:
        return 0.0
    poly = np.vstack([prev_end[None, :], sp.approach, sp.points[:1]])
    return float(np.linalg.norm(np.diff(poly, axis=0), axis=1).sum())


OSCILLATED = frozenset({"oscillate"})  # MPP: the oscillated section first, then the parallel ones it feeds


def section_rank(sp: SectionPath, precedence: Sequence[str] = ()) -> int:
    """Order rule rank (lower goes first): the keys listed in `precedence` by their position, then
    oscillated sections, then the rest (Michel et al. 2019: deposit across the waving border of an
    earlier oscillated section to close voids)."""
    if sp.key in precedence:
        return list(precedence).index(sp.key)
    return len(precedence) + (0 if sp.strategy in OSCILLATED else 1)


def ranked_nearest_order(
    paths: Sequence[SectionPath], prev_end: np.ndarray | None, precedence: Sequence[str] = ()
) -> list[int]:
    """`nearest_order` within each rank of the order rule, ranks in turn: travel is shortened
    without ever depositing a later rank before an earlier one."""
    ranks = [section_rank(sp, precedence) for sp in paths]
    out: list[int] = []
    here = prev_end
    for r in sorted(set(ranks)):
        idx = [i for i, k in enumerate(ranks) if k == r]
        starts = np.array([paths[i].points[0] for i in idx], dtype=float)
        ends = np.array([paths[i].points[-1] for i in idx], dtype=float)
        start_cost = None if here is None else np.linalg.norm(starts - np.asarray(here)[None, :], axis=1)
        sub = nearest_order(travel_cost(ends, starts), start_cost)
        out += [idx[j] for j in sub]
        here = np.asarray(paths[out[-1]].points[-1], dtype=float)
    return out


def rule_breaks(order_keys: Sequence[SectionPath], precedence: Sequence[str] = ()) -> list[tuple[str, str]]:
    """(earlier, later) key pairs where a section of a later rank is deposited before one of an earlier rank."""
    out = []
    for i, a in enumerate(order_keys):
        for b in order_keys[i + 1 :]:
            if section_rank(b, precedence) < section_rank(a, precedence):
                out.append((a.key, b.key))
    return out


def sequence_layer(
    lp: LayerPaths,
    *,
    order: str | Sequence[str] = "mask",
    prev_end: np.ndarray | None = None,
    retract_height: float = 10.0,
    alternate: bool = False,
    dwell_after_s: float = 0.0,
    seam: SeamSpec | None = None,
    below: np.ndarray | None = None,
    min_run: float = 0.0,
    precedence: Sequence[str] = (),
    notes: list[dict] | None = None,
) -> tuple[LayerPaths, float]:
    """Order the section paths of one layer, choose where each ignites and set their approach travel.

    order: "mask" | "nearest" (shortest travel within the order rule's ranks, see `section_rank`)
    | explicit list of section keys. prev_end: (3,) world mm where the torch is before this layer
    (the previous layer's last point), or None. seam: where each path ignites (`seams.choose_entry`;
    None: as planned). below: (k, 3) ignition points of the layer below. min_run: shortest arc-ON
    run, mm (`arc_runs.enforce_min_run`; 0: off). notes: receives one dict per event (kind
    "junction" | "bridged" | "dropped" | "order-rule", layer, section, ...). Returns the new layer
    program and its travel length in mm (including the move in from prev_end).
    """
    paths = [sp for sp in lp.sections if len(sp.points) >= 2]
    if not paths:
        return dataclasses.replace(lp, sections=tuple(lp.sections), dwell_after_s=dwell_after_s), 0.0
    notes = [] if notes is None else notes
    below = np.zeros((0, 3)) if below is None else np.asarray(below, dtype=float).reshape(-1, 3)
    if seam is not None:
        if not isinstance(seam.policy, str) and len(seam.policy) == 2:  # layer-local (x, y) → world
            seam = dataclasses.replace(seam, policy=tuple(lp.layer.to_world(np.asarray([seam.policy], float))[0]))
        chosen = []
        segs = LayerSegments(paths)
        for i, sp in enumerate(paths):
            entry, ok = choose_entry(
                sp, lp.index, seam, paths[:i] + paths[i + 1 :], below, functools.partial(segs.others, i)
            )
            if not ok:
                notes.append(
                    {
                        "kind": "junction",
                        "layer": lp.index,
                        "section": sp.key,
                        "at": np.round(entry.ignition, 3).tolist(),
                    }
                )
            chosen.append(entry.path)
        paths = chosen
    if min_run > 0:
        fixed = []
        for sp in paths:
            new, fixes = enforce_min_run(sp, min_run)
            for f in fixes:
                notes.append(
                    {"kind": f.action, "layer": lp.index, "section": sp.key, "length": f.length, "at": list(f.at)}
                )
            fixed.append(new)
        paths = fixed
    if isinstance(order, str) and order == "nearest":
        idx = ranked_nearest_order(paths, prev_end, precedence)
    elif isinstance(order, str):
        if order != "mask":
            raise ValueError(f"unknown order {order!r}")
        idx = list(range(len(paths)))
    else:
        idx = explicit_order([sp.key for sp in paths], order)
    if alternate and lp.index % 2 == 1:
        idx = idx[::-1]
        if isinstance(order, str) and order == "nearest":
            idx = sorted(idx, key=lambda i: section_rank(paths[i], precedence))
    for a, b in rule_breaks([paths[i] for i in idx], precedence):
        notes.append({"kind": "order-rule", "layer": lp.index, "section": b, "before": a})
    up = lp.layer.normal
    out: list[SectionPath] = []
    total = 0.0
    here = None if prev_end is None else np.asarray(prev_end, dtype=float)
    for i in idx:
        sp = paths[i]
        start = np.asarray(sp.points[0], dtype=float)
        sp = dataclasses.replace(sp, approach=approach_points(here, start, up, retract_height))
        total += travel_length(here, sp)
        out.append(sp)
        here = np.asarray(sp.points[-1], dtype=float)
    return dataclasses.replace(lp, sections=tuple(out), dwell_after_s=dwell_after_s), total


def last_point(lp: LayerPaths | None) -> np.ndarray | None:
    """(3,) world mm: where the torch is after this layer (end of its last section path)."""
    if lp is None:
        return None
    for sp in reversed(lp.sections):
        if len(sp.points):
            return np.asarray(sp.points[-1], dtype=float)
    return None


def sequence_part(
    layers: Sequence[LayerPaths | None],
    *,
    map_chunks: ChunkMap | None = None,
    on_layer: Callable[[int, int], None] | None = None,
    **kw: Any,
) -> tuple[list[LayerPaths | None], list[float]]:
    """Sequence every layer, each starting where the previous one ended (and, with a seam policy,
    igniting away from the layer below's ignitions). Returns layers and travel (mm) per layer.

    None layers (partial runs) stay None and break the chain (the next layer starts fresh).

    `map_chunks`: fn over items in other processes, results in order, or None when it would run
    here (the engine's `Context.map_in_workers`). With it, runs of consecutive layers are
    sequenced at once, speculatively (`_sequence_chunk`: each starts `WARMUP_LAYERS` early, from
    nothing), and a layer's result is taken only when the torch position and the ignitions below it
    were exactly the ones this chain reaches; any other layer is sequenced again here. The result is
    the serial one, whatever the speculation gave. `on_layer(k, n)`: called after each layer (the
    node's progress and cancel)."""
    notes = kw.pop("notes", None)
    notes = [] if notes is None else notes
    spec: list[_Sequenced | None] = [None] * len(layers)
    if map_chunks is not None and len(layers) >= 2 * SPECULATE_CHUNKS:
        spans = _layer_spans(len(layers), SPECULATE_CHUNKS)
        items = [(list(layers[max(0, a - WARMUP_LAYERS) : b]), a - max(0, a - WARMUP_LAYERS), kw) for a, b in spans]
        got = map_chunks(_sequence_chunk, items)
        if got is not None:
            for (a, _b), chunk in zip(spans, got):
                spec[a : a + len(chunk)] = chunk
    out: list[LayerPaths | None] = []
    travel: list[float] = []
    prev: np.ndarray | None = None
    below: np.ndarray | None = None
    for lp, guess in zip(layers, spec):
        if lp is None:
            out.append(None)
            travel.append(0.0)
            prev = below = None
            continue
        if guess is not None and _same(guess.prev_end, prev) and _same(guess.below, below):
            new, t = guess.layer, guess.travel
            notes += guess.notes
        else:
            new, t = sequence_layer(lp, prev_end=prev, below=below, notes=notes, **kw)
        out.append(new)
        travel.append(t)
        prev = last_point(new)
        below = ignition_points(new.sections)
        if on_layer is not None:
            on_layer(len(out), len(layers))
    return out, travel


SPECULATE_CHUNKS = 8  # runs of layers sequenced at once in the workers (4 per worker of 2)
WARMUP_LAYERS = 2  # a run starts this many layers early: the seams it reaches by then are the chain's
ChunkMap = Callable[[Callable[[Any], Any], Sequence[Any]], "list[Any] | None"]


class _Sequenced(NamedTuple):
    """A layer sequenced in a run of layers: what it was given (the torch position and the
    ignitions below, None when the chain starts there) and what it gave."""

    prev_end: np.ndarray | None
    below: np.ndarray | None
    layer: LayerPaths
    travel: float
    notes: list[dict]


def _same(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return a.shape == b.shape and bool(np.array_equal(a, b))


def _layer_spans(n: int, parts: int) -> list[tuple[int, int]]:
    edges = [round(k * n / parts) for k in range(parts + 1)]
    return [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]


def _sequence_chunk(item: tuple[list[LayerPaths | None], int, dict[str, Any]]) -> list[_Sequenced | None]:
    """Worker side: the layers of a run in order from nothing, as `sequence_part` does; those
    from index `skip` on (the first `skip` only warm the chain up) with what each was given."""
    layers, skip, kw = item
    out: list[_Sequenced | None] = []
    prev: np.ndarray | None = None
    below: np.ndarray | None = None
    for k, lp in enumerate(layers):
        if lp is None:
            prev = below = None
            if k >= skip:
                out.append(None)
            continue
        notes: list[dict] = []
        new, t = sequence_layer(lp, prev_end=prev, below=below, notes=notes, **kw)
        if k >= skip:
            out.append(_Sequenced(prev, below, new, t, notes))
        prev = last_point(new)
        below = ignition_points(new.sections)
    return out


def part_travel(layers: Sequence[LayerPaths | None]) -> list[float]:
    """Arc-OFF travel (mm) per layer of a sequenced part, counting the move in from the previous layer."""
    out: list[float] = []
    prev = None
    for lp in layers:
        total = 0.0
        if lp is not None:
            for sp in lp.sections:
                total += travel_length(prev, sp)
                prev = np.asarray(sp.points[-1], dtype=float)
        else:
            prev = None
        out.append(total)
    return out


__all__ = [
    "OSCILLATED",
    "approach_points",
    "explicit_order",
    "ranked_nearest_order",
    "rule_breaks",
    "section_rank",
    "last_point",
    "nearest_order",
    "part_travel",
    "sequence_layer",
    "sequence_part",
    "tour_length",
    "travel_cost",
    "travel_length",
]
