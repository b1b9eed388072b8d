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
from .tour import Submit, nearest_order, search_seconds, tour_length, travel_cost

__all__ = ["nearest_order", "tour_length", "travel_cost"]  # the order's kernels, at their old address


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
    paths: Sequence[SectionPath],
    prev_end: np.ndarray | None,
    precedence: Sequence[str] = (),
    submit: Submit | None = None,
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
        sub = nearest_order(travel_cost(ends, starts), start_cost, submit)
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
    submit: Submit | None = None,
) -> tuple[LayerPaths, float]:
    """Order the section paths of one layer, choose where each ignites and set their approach travel.

    order: "mask" | "nearest" (shortest travel within the order rule's ranks, see `section_rank`)
    | explicit list of section keys. prev_end: (3,) world mm where the torch is before this layer
    (the previous layer's last point), or None. seam: where each path ignites (`seams.choose_entry`;
    None: as planned). below: (k, 3) ignition points of the layer below. min_run: shortest arc-ON
    run, mm (`arc_runs.enforce_min_run`, bridging at most the seam's clearance, a bead width; 0: off). notes: receives one dict per event (kind
    "junction" | "bridged" | "dropped" | "order-rule", layer, section, ...). submit: a large
    layer's second local search to a worker (`tour.nearest_order`). Returns the new layer
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
                        "strategy": sp.strategy,
                        "at": np.round(entry.ignition, 3).tolist(),
                    }
                )
            chosen.append(entry.path)
        paths = chosen
    if min_run > 0:
        bridge = (seam or SeamSpec()).clearance  # a bridge at most a bead width long
        fixed = []
        for sp in paths:
            new, fixes = enforce_min_run(sp, min_run, bridge)
            for f in fixes:
                notes.append(
                    {"kind": f.action, "layer": lp.index, "section": sp.key, "length": f.length, "at": list(f.at)}
                )
            fixed.append(new)
        paths = fixed
    if isinstance(order, str) and order == "nearest":
        idx = ranked_nearest_order(paths, prev_end, precedence, submit)
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
    ahead: Sequence[Sequence[_Sequenced | None]] | None = None,
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
    the serial one, whatever the speculation gave. `ahead`: runs of layers sequenced the same
    way where they were made (`sequence_ahead`), each result taken only for the very layer object
    it was made from; the layers they do not cover go to `map_chunks`. `on_layer(k, n)`: called
    after each layer (the node's progress and cancel). `submit`: see `sequence_layer` (this
    process's layers only)."""
    notes = kw.pop("notes", None)
    notes = [] if notes is None else notes
    submit = kw.pop("submit", None)
    spec = _ahead_guesses(layers, ahead or ())
    todo = [k for k, lp in enumerate(layers) if lp is not None and spec[k] is None]
    if map_chunks is not None and len(todo) >= 2 * SPECULATE_CHUNKS:
        spans = _runs_of(todo, -(-len(todo) // SPECULATE_CHUNKS))
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
            new, t = sequence_layer(lp, prev_end=prev, below=below, notes=notes, submit=submit, **kw)
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
    ignitions below, None when the chain starts there) and what it gave; `source`: the layer it
    was made from, kept where the parent holds that very object (`sequence_ahead`)."""

    prev_end: np.ndarray | None
    below: np.ndarray | None
    layer: LayerPaths
    travel: float
    notes: list[dict]
    source: LayerPaths | None = None


def _ahead_guesses(
    layers: Sequence[LayerPaths | None], ahead: Sequence[Sequence[_Sequenced | None]]
) -> list[_Sequenced | None]:
    """Per layer, the result of `sequence_ahead` made from that very layer object, else None."""
    spec: list[_Sequenced | None] = [None] * len(layers)
    if ahead:
        at = {id(lp): k for k, lp in enumerate(layers) if lp is not None}
        for run in ahead:
            for guess in run:
                if guess is None or guess.source is None:
                    continue
                k = at.get(id(guess.source))
                if k is not None and layers[k] is guess.source:
                    spec[k] = guess
    return spec


def _runs_of(todo: list[int], size: int) -> list[tuple[int, int]]:
    """Spans [a, b) of at most `size` consecutive positions, covering the sorted `todo`."""
    spans: list[tuple[int, int]] = []
    for k in todo:
        if spans and spans[-1][1] == k and k - spans[-1][0] < size:
            spans[-1] = (spans[-1][0], k + 1)
        else:
            spans.append((k, k + 1))
    return spans


def _same(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return a.shape == b.shape and bool(np.array_equal(a, b))


def _sequence_chunk(item: tuple[list[LayerPaths | None], int, dict[str, Any]]) -> list[_Sequenced | None]:
    """Worker side: the layers of a run in order from nothing, as `sequence_part` does; those
    from index `skip` on (the first `skip` only warm the chain up) with what each was given."""
    layers, skip, kw = item
    return _sequence_run(layers, skip, kw, keep_source=False)


SEQUENCE_S_PER_SECTION = 4e-4  # CPU s to sequence one section path (seam, entry, zones), 2026-11-27:
# the shipped recipes' sequence nodes 0.22-0.43 ms a section, the 500-layer cross 0.37 ms


def chunk_seconds(items: Sequence[tuple[list[LayerPaths | None], int, dict[str, Any]]]) -> float:
    """Expected CPU seconds of `_sequence_chunk` over `items` (their warm-up layers included): the
    cost model's question whether the workers pay for them, in this kernel's own terms. The
    engine's generic model (5 ms a layer, 25 µs a path point: the preflight's and wall paths'
    work) put the 500-layer cross's 25 layers left over (37 sent, 0.04 s of work) at 0.24 s and
    sent them, and the run waited 0.17-0.23 s for them behind the artifacts the workers wrote."""
    total = 0.0
    for layers, _skip, kw in items:
        seeds = 2 if kw.get("order") == "nearest" else 0  # nearest_order searches from two seeds
        for lp in layers:
            if lp is not None:
                n = len(lp.sections)
                total += SEQUENCE_S_PER_SECTION * n + seeds * search_seconds(n)
    return total


def sequence_ahead(layers: list[LayerPaths | None], **kw: Any) -> list[_Sequenced | None]:
    """A run of consecutive layers sequenced in order from nothing, each result with the layer
    it was made from (`sequence_part`'s `ahead`: a chain task's zoned layers, where they were
    made; returned with them, they unpickle as the very objects the parent is given)."""
    return _sequence_run(layers, 0, kw, keep_source=True)


def _sequence_run(
    layers: list[LayerPaths | None], skip: int, kw: dict[str, Any], keep_source: bool
) -> list[_Sequenced | None]:
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
            out.append(_Sequenced(prev, below, new, t, notes, lp if keep_source else None))
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
    "sequence_ahead",
    "chunk_seconds",
    "sequence_part",
    "tour_length",
    "travel_cost",
    "travel_length",
]
