"""Section order on a layer of many sections (`sequence` order `nearest`): nearest neighbour, then
2-opt and Or-opt on the open, asymmetric tour (waamflow.sequencing.tour).

Entry:
- `sequence_nearest_order_100_ms`: `nearest_order` of a layer of 100 walls (seeded: random ends
  over 300 × 300 mm, each start within ~10 mm of its end, a start point), median of 3 runs, ms.
  peer = `reference_local_search` in place of the local search: the same moves found by scoring
  every candidate tour whole, as waamflow did until 2026-11-26 (a DXF of ~200 walls a layer took
  46 s for 5 layers); the orders must be identical.
- `sequence_nearest_order_1500_s`: the same on a floor plan's layer of 1,500 walls, and how much
  shorter than the nearest-neighbour tour the local search makes it (no peer).
"""

from __future__ import annotations

import numpy as np

N = 100
N_LARGE = 1500
REPEATS = 3


def reference_local_search(order, cost, start_cost, lo):
    """2-opt then Or-opt, first improvement in scan order, every candidate tour's length summed
    anew (O(n^4) a round): the moves waamflow's delta-scored local search must make."""
    from waamflow.sequencing.tour import MAX_2OPT_ROUNDS, tour_length

    n = len(order)
    best = tour_length(order, cost, start_cost)
    for _ in range(MAX_2OPT_ROUNDS):
        improved = False
        for i in range(lo, n - 1):
            for k in range(i + 1, n):
                cand = order[:i] + order[i : k + 1][::-1] + order[k + 1 :]
                length = tour_length(cand, cost, start_cost)
                if length < best - 1e-9:
                    order, best, improved = cand, length, True
        for run in (1, 2, 3):
            for i in range(lo, n - run + 1):
                piece, rest = order[i : i + run], order[:i] + order[i + run :]
                for j in range(lo, len(rest) + 1):
                    if j == i:
                        continue
                    cand = rest[:j] + piece + rest[j:]
                    length = tour_length(cand, cost, start_cost)
                    if length < best - 1e-9:
                        order, best, improved = cand, length, True
                        break
        if not improved:
            break
    return order


def run() -> list[dict]:
    from bench_slice import _median  # the benches' one timer: (median s of REPEATS calls, last result)

    from waamflow.sequencing import tour

    rng = np.random.default_rng(1)
    ends = rng.uniform(0, 300, (N, 2))
    starts = ends + rng.normal(0, 10, (N, 2))
    cost = tour.travel_cost(ends, starts)
    start = rng.uniform(0, 100, N)
    tour.nearest_order(cost[:8, :8], start[:8])  # warm-up
    ours_s, ours = _median(lambda: tour.nearest_order(cost, start), REPEATS)
    real = tour._local_search
    tour._local_search = reference_local_search
    try:
        peer_s, theirs = _median(lambda: tour.nearest_order(cost, start), REPEATS)
    finally:
        tour._local_search = real
    assert ours == theirs, "sequence: the delta-scored local search chose another order than the reference"
    return [
        {
            "name": "sequence_nearest_order_100_ms",
            "value": round(ours_s * 1e3, 1),
            "unit": "ms",
            "peer": round(peer_s * 1e3, 1),
            "ratio": round(ours_s / peer_s, 4),
            "notes": f"nearest_order of {N} sections (seeded random walls, a start point), median of {REPEATS}; "
            f"peer = every candidate tour scored whole (the moves of before 2026-11-26), {peer_s:.2f} s; "
            f"orders identical; tour {tour.tour_length(ours, cost, start):.1f} mm",
        },
        _large_layer(),
    ]


def _large_layer() -> dict:
    """A floor plan's layer: 1,500 walls (bjnortier's Ceco.NET sketch has 1,546 a layer)."""
    from bench_slice import _median

    from waamflow.sequencing import tour

    rng = np.random.default_rng(2)
    ends = rng.uniform(0, 3000, (N_LARGE, 2))
    starts = ends + rng.normal(0, 30, (N_LARGE, 2))
    cost = tour.travel_cost(ends, starts)
    start = rng.uniform(0, 1000, N_LARGE)
    secs, order = _median(lambda: tour.nearest_order(cost, start), REPEATS)
    first = [int(np.argmin(start))]  # the nearest-neighbour tour the local search starts from
    left = np.ones(N_LARGE, bool)
    left[first[0]] = False
    for _ in range(N_LARGE - 1):
        first.append(int(np.argmin(np.where(left, cost[first[-1]], np.inf))))
        left[first[-1]] = False
    nn, got = tour.tour_length(first, cost, start), tour.tour_length(order, cost, start)
    return {
        "name": "sequence_nearest_order_1500_s",
        "value": round(secs, 3),
        "unit": "s",
        "notes": f"nearest_order of {N_LARGE} sections (seeded random walls over 3 × 3 m, a start point), "
        f"median of {REPEATS}: tour {got:.0f} mm, {100 * (1 - got / nn):.1f} % shorter than the nearest-neighbour "
        f"tour it starts from ({nn:.0f} mm); a layer of the Ceco.NET floor plan (1,546 walls): 9.9 s before 2026-11-26, 2.0 s after, "
        "same order (measured side by side that day)",
    }
