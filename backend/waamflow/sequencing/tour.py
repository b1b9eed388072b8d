"""The order of a layer's sections (`sequence` order `nearest`): an open, asymmetric travelling
salesman tour (a section is entered at its start and left at its end; travel in mm).

Nearest neighbour from the start point, then local search: 2-opt (reverse a run) and Or-opt (move
a run of 1–3 sections elsewhere), first improvement in scan order until a round improves nothing;
run from the nearest-neighbour tour and from the mask order, the shorter kept. Layers of up to
EXACT_MAX sections are solved exactly.

Each candidate move is scored by its change of the tour's length, not by summing the tour anew
(the same moves, order and outcome: `bench/bench_sequence.py`'s reference scores whole tours),
one piece's moves at once (numpy), reading rows of the cost matrix and the order's own edges
rather than gathering 2-D (bjnortier's Ceco.NET floor plan, 1,546 walls a layer: 16 s → 3.8 s a
layer). Scoring a block of pieces at once as a 2-D array was tried and was 2× slower there: a
piece's scan is long enough that numpy's per-call cost is not what it spends.
"""

from __future__ import annotations

import itertools
from concurrent.futures import Future
from typing import Any, Callable, Sequence

import numpy as np

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


SEED_IN_WORKER_MIN = 250  # sections: a seed's search this large goes to a worker beside the other
SEARCH_S_PER_SECTION2 = 1e-6  # CPU s of one seed's local search per section² (1,546: 2.0-2.7 s)
Submit = Callable[[Callable[[Any], Any], Any], "Future[Any] | None"]


def search_seconds(sections: int) -> float:
    """Expected CPU seconds of one seed's local search on a layer (rank) of this many sections."""
    return SEARCH_S_PER_SECTION2 * sections**2 if sections > EXACT_MAX else 0.0


def submitted_seconds(sections: int) -> float:
    """Expected CPU seconds `nearest_order` hands to a worker on a layer (rank) of this many
    sections: one seed's search from SEED_IN_WORKER_MIN sections on, none below (what a node
    tells `Context.start_workers`: layers searched here alone must not start the workers)."""
    return search_seconds(sections) if sections >= SEED_IN_WORKER_MIN else 0.0


def nearest_order(cost: np.ndarray, start_cost: np.ndarray | None, submit: Submit | None = None) -> list[int]:
    """Nearest neighbour from the start point (or from section 0 when None), improved by local search.

    cost: (n, n) end-of-i → start-of-j travel, mm. start_cost: (n,) start point → start of j, mm.
    Local search from the nearest-neighbour tour and from the mask order; the shorter result is
    kept, so the order is never longer than the mask's. Layers of up to EXACT_MAX sections are
    solved exactly instead. `submit(fn, item)` (a node's `Context.submit`): the mask seed's search
    of a layer of SEED_IN_WORKER_MIN sections or more goes to a worker while this process
    searches from the other seed (None from it: both here); the same order either way.
    """
    n = len(cost)
    if n == 0:
        return []
    if n <= EXACT_MAX:
        return _exact_order(cost, start_cost)
    fixed_first = start_cost is None  # without a start point, section 0 (the mask's first) leads
    first = 0 if start_cost is None else int(np.argmin(start_cost))
    order, left = [first], np.ones(n, dtype=bool)
    left[first] = False
    for _ in range(n - 1):  # the nearest left; of equals, the first (argmin's own tie rule)
        nxt = int(np.argmin(np.where(left, cost[order[-1]], np.inf)))
        order.append(nxt)
        left[nxt] = False
    best = None
    # a mask order that is the nearest-neighbour one already (wall-path orders its passes so) is
    # searched once: the same seed gives the same result
    seeds = [order] if order == list(range(n)) else [order, list(range(n))]
    lo = 1 if fixed_first else 0
    away = None
    if submit is not None and len(seeds) == 2 and n >= SEED_IN_WORKER_MIN:
        away = submit(_seed_search, (seeds[1], cost, start_cost, lo))
    for k, seed in enumerate(seeds):
        cand = away.result() if k == 1 and away is not None else _local_search(seed, cost, start_cost, lo)
        length = tour_length(cand, cost, start_cost)
        if best is None or length < best[0] - 1e-9:
            best = (length, cand)
    assert best is not None  # a seed tried
    return best[1]


def _exact_order(cost: np.ndarray, start_cost: np.ndarray | None) -> list[int]:
    """Shortest open tour by scoring every order (n ≤ EXACT_MAX); ties → the first in lexicographic order."""
    n = len(cost)
    perms = np.array(list(itertools.permutations(range(n))), dtype=np.int64).reshape(-1, n)
    if start_cost is None:
        perms = perms[perms[:, 0] == 0]
    total = cost[perms[:, :-1], perms[:, 1:]].sum(axis=1)
    if start_cost is not None:
        total = total + start_cost[perms[:, 0]]
    return perms[int(np.argmin(np.round(total, 9)))].tolist()


def _seed_search(item: tuple[list[int], np.ndarray, np.ndarray | None, int]) -> list[int]:
    """Worker side of `nearest_order`'s `submit`: one seed's local search."""
    return _local_search(*item)


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
    cost_t = np.ascontiguousarray(cost.T)  # the costs into a section, one row: gathered at once
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
        edges = sums[2]  # the order's edges, kept up to date through the Or-opt's moves
        for run in (1, 2, 3):  # Or-opt: move o[i..i+run) to position j of the rest
            for i in range(lo, n - run + 1):
                delta = _move_deltas(o, cost, start_cost, i, run, lo, edges, cost_t)
                delta[i - lo] = np.inf  # j == i: where it is
                hit = np.flatnonzero(delta < -1e-9)
                if len(hit):
                    j = lo + int(hit[0])
                    piece, rest = o[i : i + run], np.concatenate([o[:i], o[i + run :]])
                    o = np.concatenate([rest[:j], piece, rest[j:]])
                    edges = cost[o[:-1], o[1:]]
                    improved = True
        if not improved:
            break
    return o.tolist()


def _edge_sums(o: np.ndarray, cost: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(fwd, bwd, edges): edges[t] = cost[o[t], o[t+1]], the tour's own; fwd[j] the sum of the
    edges before position j, bwd[j] the same edges walked backwards."""
    edges = cost[o[:-1], o[1:]]
    fwd = np.concatenate([[0.0], np.cumsum(edges)])
    bwd = np.concatenate([[0.0], np.cumsum(cost[o[1:], o[:-1]])])
    return fwd, bwd, edges


def _entry(o: np.ndarray, cost: np.ndarray, start_cost: np.ndarray | None, pos: int, to: np.ndarray) -> np.ndarray:
    """Cost of arriving at sections `to` in position `pos` of tour `o` (from the start point at 0)."""
    if pos > 0:
        return cost[o[pos - 1], to]
    return np.zeros(len(to)) if start_cost is None else start_cost[to]


def _reverse_deltas(
    o: np.ndarray,
    cost: np.ndarray,
    start_cost: np.ndarray | None,
    i: int,
    k0: int,
    sums: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> np.ndarray:
    """Change of the tour's length when o[i..k] is reversed, for k = k0 .. n-1 (`sums`: the
    order's `_edge_sums`). The new exits, from o[i], are one row of cost; the old ones the
    order's own edges."""
    n = len(o)
    ks = np.arange(k0, n)
    fwd, bwd, edges = sums
    inner = (bwd[ks] - bwd[i]) - (fwd[ks] - fwd[i])
    entry = _entry(o, cost, start_cost, i, o[ks]) - _entry(o, cost, start_cost, i, o[i : i + 1])
    exit_ = np.zeros(len(ks))
    exit_[:-1] = cost[o[i]][o[k0 + 1 :]] - edges[k0:]
    return inner + entry + exit_


def _move_deltas(
    o: np.ndarray,
    cost: np.ndarray,
    start_cost: np.ndarray | None,
    i: int,
    run: int,
    lo: int,
    edges: np.ndarray,
    cost_t: np.ndarray,
) -> np.ndarray:
    """Change of the tour's length when o[i..i+run) moves to position j of the rest (the tour
    without it), for j = lo .. len(rest). `edges`: the order's cost[o[t], o[t+1]], of which the
    rest's own edges are slices; `cost_t`: cost transposed, C-contiguous, so the costs into the
    piece are one contiguous row (an O(n) scan per piece either way, but ~3× faster so than 2-D
    gathers: bjnortier's Ceco.NET floor plan, 1,546 walls a layer)."""
    n = len(o)
    a, b = o[i], o[i + run - 1]
    rest = np.concatenate([o[:i], o[i + run :]])
    m = len(rest)
    # taken out: its entry and exit, the neighbours joined
    out = -_entry(o, cost, start_cost, i, o[i : i + 1])[0]
    if i + run < n:
        out += -cost[b, o[i + run]] + _entry(o, cost, start_cost, i, o[i + run : i + run + 1])[0]
    # put back at j = 0 .. m: arriving from rest[j-1] (the start point at 0), leaving to rest[j]
    # (none at m), in place of the edge rest[j-1] → rest[j]
    prev_in = np.empty(m + 1)
    prev_in[0] = 0.0 if start_cost is None else start_cost[a]
    prev_in[1:] = cost_t[a][rest]
    leave = np.zeros(m + 1)
    leave[:m] = cost[b][rest]
    join = np.zeros(m + 1)
    if m:
        join[0] = 0.0 if start_cost is None else start_cost[rest[0]]
        bridged = [cost[o[i - 1], o[i + run]]] if 0 < i and i + run < n else []
        join[1:m] = np.concatenate([edges[: max(i - 1, 0)], bridged, edges[i + run :]])
    into = prev_in + leave - join
    return (out + into)[lo:]
