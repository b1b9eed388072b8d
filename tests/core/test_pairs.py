"""core.pairs against scipy's cKDTree.query_pairs: the same pairs, in 1, 2 and 3 dimensions,
with groups kept apart as a far coordinate keeps them."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from waamflow.core.pairs import close_pair_batches, close_pairs, pairs_between


def _as_set(pairs: np.ndarray) -> set[tuple[int, int]]:
    return {(int(a), int(b)) for a, b in pairs}


def _sets(rng, k: int, dim: int):
    n = int(rng.integers(0, 400))
    reach = float(rng.uniform(0.5, 10))
    if k % 4 == 0:
        P = rng.uniform(-50, 50, (n, dim))
    elif k % 4 == 1:  # a lattice: many distances equal to the reach exactly
        P = np.round(rng.uniform(-20, 20, (n, dim)) / 1.5) * 1.5
        reach = 1.5 * int(rng.integers(1, 4))
    elif k % 4 == 2:  # points spaced exactly one reach apart, far from the origin
        reach = 6.12
        P = np.column_stack([np.arange(n) % 20 * reach] + [np.arange(n) // 20 * reach] * (dim - 1))[:, :dim] + 1e3
    else:  # six orders of magnitude
        P = rng.normal(0, 3, (n, dim)) * 10 ** rng.uniform(-3, 3)
    return P, reach


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_the_pairs_of_a_kd_tree(dim):
    rng = np.random.default_rng(dim)
    total = 0
    for k in range(300):
        P, reach = _sets(rng, k, dim)
        want = cKDTree(P).query_pairs(reach, output_type="ndarray") if len(P) else np.zeros((0, 2), int)
        got = close_pairs(P, reach)
        assert len(got) == len(_as_set(got)), "a pair found twice"
        assert _as_set(got) == _as_set(want), (k, len(P), reach)
        total += len(want)
    assert total > 10_000  # the sets do have pairs to find


def test_groups_apart_as_a_far_coordinate():
    """Layers stacked on one outline: pairs only within a layer, as the 4th coordinate (layer × 1e7
    mm) the preflight's retrace check gave scipy."""
    rng = np.random.default_rng(7)
    layer = rng.integers(0, 30, 5000)
    P = np.column_stack([rng.uniform(0, 60, 5000), rng.uniform(0, 60, 5000), 1.5 * layer + rng.normal(0, 0.01, 5000)])
    reach = 2.25
    want = cKDTree(np.column_stack([P[:, :2], layer * 1.0e7])).query_pairs(reach, output_type="ndarray")
    got = close_pairs(P[:, :2], reach, groups=layer)
    assert _as_set(got) == _as_set(want)
    assert (layer[got[:, 0]] == layer[got[:, 1]]).all() and len(got) > 1000
    # and in 3D: z 1.5 mm apart between layers, within reach, still kept apart
    got3 = close_pairs(P, reach, groups=layer)
    assert (layer[got3[:, 0]] == layer[got3[:, 1]]).all()
    assert len(got3) <= len(got)


def test_batches_each_pair_once_and_bad_input():
    P = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [0.0, 1.0]])
    found = [tuple(sorted(p)) for i, j in close_pair_batches(P, 1.0) for p in zip(i.tolist(), j.tolist())]
    assert sorted(found) == [(0, 1), (0, 3), (1, 2)]
    assert close_pairs(np.zeros((1, 3)), 1.0).shape == (0, 2)
    assert len(close_pairs(np.zeros((5, 3)), 1.0)) == 10  # coincident points: every pair
    with pytest.raises(ValueError, match="reach"):
        close_pairs(P, 0.0)
    with pytest.raises(ValueError, match="64 bits"):
        close_pairs(np.array([[0.0, 0.0, 0.0], [1e9, 1e9, 1e9]]), 1e-6)


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_pairs_between_two_sets_as_a_kd_tree(dim):
    """The pairs across two sets only, as cKDTree.query_ball_tree lists them: none within a set."""
    rng = np.random.default_rng(10 + dim)
    total = 0
    for k in range(200):
        A, reach = _sets(rng, k, dim)
        B, _r = _sets(rng, k, dim)
        got_i, got_j = pairs_between(A, B, reach)
        got = {(int(i), int(j)) for i, j in zip(got_i, got_j)}
        assert len(got) == len(got_i)
        want = set()
        if len(A) and len(B):
            for i, js in enumerate(cKDTree(A).query_ball_tree(cKDTree(B), reach)):
                want |= {(i, j) for j in js}
        assert got == want, (k, len(A), len(B), reach)
        total += len(want)
    assert total > 10_000
