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


class _CountingNumpy:
    """numpy for core.graphs with its calls of `names` counted (and `unique` refused)."""

    def __init__(self, *names: str) -> None:
        self.calls = dict.fromkeys(names, 0)

    def __getattr__(self, name):
        fn = getattr(np, name)
        if name == "unique":
            raise AssertionError("np.unique called")
        if name not in self.calls:
            return fn

        def counted(*a, **k):
            self.calls[name] += 1
            return fn(*a, **k)

        return counted


@pytest.mark.parametrize("cycle,n", [(4, 4096), (3, 3000), (1, 50), (700, 2800), (5000, 5000)])
def test_cycle_minimum_stops_at_the_first_round_that_changes_nothing(monkeypatch, cycle, n):
    """Pointer jumping needs ⌈log₂ L⌉ rounds for cycles of at most L elements, plus one that
    finds nothing lower: 3 for 4,096 elements in cycles of 4, not ⌈log₂ 4096⌉ = 12 (the bench
    vase's ~1 M segments in loops of ~4,000: 13 rounds, not 20). The lowest element of each
    cycle, checked against a walk round every cycle."""
    from waamflow.core import graphs

    rng = np.random.default_rng(cycle)
    perm = rng.permutation(n)
    nxt = np.empty(n, dtype=np.int64)
    for s in range(0, n, cycle):
        c = perm[s : s + cycle]
        nxt[c] = np.roll(c, -1)
    want = np.empty(n, dtype=np.int64)
    for s in range(0, n, cycle):
        c = perm[s : s + cycle]
        want[c] = c.min()
    fake = _CountingNumpy("minimum")
    monkeypatch.setattr(graphs, "np", fake)
    np.testing.assert_array_equal(graphs._cycle_min(nxt), want)
    rounds = int(np.ceil(np.log2(cycle))) + 1 if cycle > 1 else 1  # a fixed point needs no second look
    assert fake.calls["minimum"] <= rounds


def test_components_are_labelled_without_a_sort(monkeypatch):
    """The roots are their components' lowest vertices: labels by counting roots in order, as
    np.unique's inverse (a sort of every vertex, ~15 ms on the vase's 1 M faces) gave them."""
    from waamflow.core import graphs

    rng = np.random.default_rng(7)
    n = 2000
    a, b = rng.integers(0, n, 1500), rng.integers(0, n, 1500)
    graph = csr_matrix((np.ones(len(a), dtype=np.int8), (a, b)), shape=(n, n))
    want = sp_components(graph, directed=False)
    monkeypatch.setattr(graphs, "np", _CountingNumpy())
    got = graphs.connected_components(n, a, b)
    assert got[0] == want[0] and 1 < got[0] < n
    np.testing.assert_array_equal(got[1], want[1])
    assert graphs.connected_components(0, np.zeros(0), np.zeros(0))[0] == 0
