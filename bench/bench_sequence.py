"""Section order on a layer of many sections (`sequence` order `nearest`): nearest neighbour, then
2-opt and Or-opt on the open, asymmetric tour (waamflow.sequencing.layer_path).

Entry:
- `sequence_nearest_order_100_ms`: `nearest_order` of a layer of 100 walls (seeded: random ends
  over 300 × 300 mm, each start within ~10 mm of its end, a start point), median of 3 runs, ms.
  peer = `reference_local_search` in place of the local search: the same moves found by scoring
  every candidate tour whole, as waamflow did until 2026-11-26 (a DXF of ~200 walls a layer took
  46 s for 5 layers); the orders must be identical.
"""

from __future__ import annotations

import numpy as np

N = 100
REPEATS = 3


def reference_local_search(order, cost, start_cost, lo):
    """2-opt then Or-opt, first improvement in scan order, every candidate tour's length summed
    anew (O(n^4) a round): the moves waamflow's delta-scored local search must make."""
    from waamflow.sequencing.layer_path import MAX_2OPT_ROUNDS, tour_length

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

    from waamflow.sequencing import layer_path

    rng = np.random.default_rng(1)
    ends = rng.uniform(0, 300, (N, 2))
    starts = ends + rng.normal(0, 10, (N, 2))
    cost = layer_path.travel_cost(ends, starts)
    start = rng.uniform(0, 100, N)
    layer_path.nearest_order(cost[:8, :8], start[:8])  # warm-up
    ours_s, ours = _median(lambda: layer_path.nearest_order(cost, start), REPEATS)
    real = layer_path._local_search
    layer_path._local_search = reference_local_search
    try:
        peer_s, theirs = _median(lambda: layer_path.nearest_order(cost, start), REPEATS)
    finally:
        layer_path._local_search = real
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
            f"orders identical; tour {layer_path.tour_length(ours, cost, start):.1f} mm",
        }
    ]
