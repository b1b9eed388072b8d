"""core.graphs against scipy.sparse.csgraph: the same labels, cycles and walk orders."""

import numpy as np
import pytest
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import connected_components as sp_components
from scipy.sparse.csgraph import depth_first_order

from waamflow.core.graphs import SMALL_WALK, connected_components, cycle_walks, permutation_cycles


@pytest.mark.parametrize("seed", range(6))
def test_components_are_scipys(seed):
    """Random sparse graphs (isolated vertices, repeated edges, self loops, chains whose labels
    fall towards the root) and a mesh-like ring: the count and every label as scipy's."""
    rng = np.random.default_rng(seed)
    for n in (1, 2, 7, 50, 400, 3000):
        m = int(rng.integers(0, 2 * n))
        a, b = rng.integers(0, n, m), rng.integers(0, n, m)
        if seed % 2:
            a, b = np.concatenate([a, np.arange(1, n)]), np.concatenate([b, np.arange(n - 1)])  # one chain
        graph = csr_matrix((np.ones(len(a), dtype=np.int8), (a, b)), shape=(n, n))
        want = sp_components(graph, directed=False)
        got = connected_components(n, a, b)
        assert got[0] == want[0]
        np.testing.assert_array_equal(got[1], want[1])
    assert connected_components(0, np.zeros(0), np.zeros(0))[0] == 0


@pytest.mark.parametrize("seed", range(4))
def test_permutation_cycles_are_scipys_weak_components(seed):
    rng = np.random.default_rng(seed)
    for n in (1, 5, 64, 1000, 5000):
        nxt = rng.permutation(n) if seed % 2 else np.roll(np.arange(n), -1)[rng.permutation(n)]
        graph = csr_matrix((np.ones(n, dtype=np.int8), (np.arange(n), nxt)), shape=(n, n))
        want = sp_components(graph, directed=True, connection="weak")
        got = permutation_cycles(nxt)
        assert got[0] == want[0]
        np.testing.assert_array_equal(got[1], want[1])


@pytest.mark.parametrize("seed", range(10))
def test_cycle_walks_are_scipys_depth_first_orders(seed):
    """Disjoint cycles of 3 to 2,000 vertices under random labels, in all below and above
    SMALL_WALK vertices (walked one vertex at a time, or by list ranking): each walk equals
    depth_first_order from the cycle's lowest vertex on the (low, high) CSR graph."""
    rng = np.random.default_rng(seed)
    many = 12 if seed % 2 else 3  # ~250 vertices, or ~60
    sizes = rng.integers(3, 40, many).tolist() + ([2000] if seed == 0 else [])
    n = int(sum(sizes))
    perm = rng.permutation(n)
    pairs, at = [], 0
    for k in sizes:
        ring = perm[at : at + k]
        pairs += [(ring[i], ring[(i + 1) % k]) for i in range(k)]
        at += k
    e = np.array(pairs)
    edges = np.unique(np.stack([e.min(axis=1), e.max(axis=1)], axis=1), axis=0)
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n)).tocsr()
    count, label = sp_components(graph, directed=False)
    starts = np.unique(label, return_index=True)[1]
    want = [depth_first_order(graph, int(s), directed=False, return_predecessors=False) for s in starts]
    got = cycle_walks(n, edges)
    assert len(got) == count == len(sizes)
    assert (n <= SMALL_WALK) == (seed % 2 == 0 and seed != 0)
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


def test_cycle_walks_refuses_a_vertex_without_two_edges():
    with pytest.raises(ValueError, match="degree 2"):
        cycle_walks(4, np.array([[0, 1], [1, 2], [2, 3]]))
