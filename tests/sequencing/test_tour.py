"""The section order's second seed in a worker (`tour.nearest_order`'s `submit`): a floor plan's
layer of hundreds of walls searches from its two seeds at once, with the same order as one
after the other."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from waamflow.sequencing import tour


def _layer(n: int, seed: int):
    rng = np.random.default_rng(seed)
    ends = rng.uniform(0, 1000, (n, 2))
    starts = ends + rng.normal(0, 20, (n, 2))
    return tour.travel_cost(ends, starts), rng.uniform(0, 500, n)


def test_second_seed_searched_in_a_worker_gives_the_same_order():
    cost, start = _layer(tour.SEED_IN_WORKER_MIN + 10, 1)
    calls = []
    with ThreadPoolExecutor(1) as pool:

        def submit(fn, item):
            calls.append(len(item[0]))
            return pool.submit(fn, item)

        got = tour.nearest_order(cost, start, submit)
    assert calls == [tour.SEED_IN_WORKER_MIN + 10]  # the mask seed, once
    assert got == tour.nearest_order(cost, start)
    assert sorted(got) == list(range(len(cost)))
    # no worker free (submit gives None): both seeds here, the same order
    assert tour.nearest_order(cost, start, lambda fn, item: None) == got
    # without a start point the mask's first section leads, in the worker's search too
    calls.clear()
    with ThreadPoolExecutor(1) as pool:
        lead = tour.nearest_order(cost, None, lambda fn, item: calls.append(1) or pool.submit(fn, item))
    assert lead[0] == 0 and lead == tour.nearest_order(cost, None) and calls == [1]


def test_small_layers_keep_both_seeds_here():
    cost, start = _layer(tour.SEED_IN_WORKER_MIN - 1, 2)
    calls = []
    got = tour.nearest_order(cost, start, lambda fn, item: calls.append(1))
    assert calls == [] and got == tour.nearest_order(cost, start)
    assert tour.search_seconds(tour.EXACT_MAX) == 0.0  # solved exactly: no search
    assert tour.search_seconds(1546) == tour.SEARCH_S_PER_SECTION2 * 1546**2
    # what goes to a worker, and so may start the workers: large layers only
    assert tour.submitted_seconds(tour.SEED_IN_WORKER_MIN - 1) == 0.0
    assert tour.submitted_seconds(1546) == tour.search_seconds(1546)
