"""preflight.kd.query: a large query on every core answers each point as one thread does."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from waamflow.preflight.kd import PARALLEL_MIN, query


def test_a_large_query_on_every_core_is_the_single_threaded_one():
    rng = np.random.default_rng(3)
    tree = cKDTree(rng.uniform(0, 1000, (20_000, 3)))
    pts = rng.uniform(-50, 1050, (PARALLEL_MIN + 7, 3))
    d1, i1 = tree.query(pts, workers=1)
    d, i = query(tree, pts)
    assert np.array_equal(d, d1) and np.array_equal(i, i1)
    b1 = tree.query(pts[:1000], distance_upper_bound=5.0, workers=1)[0]
    b = query(tree, pts[:1000], distance_upper_bound=5.0)[0]
    assert np.array_equal(b, b1) and np.isinf(b).sum() > 100  # beyond the bound: inf, as scipy says
