"""Connected components and cycle walks of the small graphs a run meets, numbered as scipy does.

A CLI run used scipy.sparse.csgraph for three things: a mesh's bodies (faces joined across
edges), the loops of a slice (the cycles of a successor permutation) and the preflight's plane
sections (2-regular graphs walked depth first). Importing scipy.sparse costs ~0.25 s of CPU, more
than all that work on a part like graphs/bracket.json (56 triangles, 300 layers). These numpy
versions give the same numbers as scipy:

- `connected_components(n, a, b)`: components of the undirected graph with edges a[i]–b[i],
  labelled 0, 1, … in the order of each component's lowest vertex (scipy's numbering, directed
  or not, weak or strong alike for undirected graphs); union by the lower root and pointer
  jumping, so every root is its component's lowest vertex.
- `permutation_cycles(nxt)`: the cycles of a permutation, numbered the same way.
- `cycle_walks(n, edges)`: a graph whose every vertex has degree 2, as vertex orders, one per
  cycle in the order of its lowest vertex, each the order `scipy.sparse.csgraph.depth_first_order`
  gives from that vertex on the graph as a CSR matrix of the (low, high) edges: to its lower
  neighbour first, then around the cycle.
"""

from __future__ import annotations

import numpy as np


def connected_components(n: int, a: np.ndarray, b: np.ndarray) -> tuple[int, np.ndarray]:
    """(count, (n,) label) of the undirected graph on n vertices with edges a[i]–b[i]."""
    parent = np.arange(n, dtype=np.int64)
    a = np.asarray(a, dtype=np.int64)
    b = np.asarray(b, dtype=np.int64)
    fresh = True  # every vertex its own root yet: the edges' roots are their ends
    while len(a):
        pa, pb = (a, b) if fresh else (parent[a], parent[b])
        fresh = False
        cross = pa != pb
        if not cross.any():
            break
        if not cross.all():
            a, b, pa, pb = a[cross], b[cross], pa[cross], pb[cross]
        # hook each root met by an edge under the lowest root it meets (roots only get lower)
        np.minimum.at(parent, np.maximum(pa, pb), np.minimum(pa, pb))
        while True:  # every vertex straight to its root
            up = parent[parent]
            if np.array_equal(up, parent):
                break
            parent = up
    # every vertex points at its root, the lowest vertex of its component: label the roots in
    # order (what np.unique's inverse gives, without its sort)
    root = parent == np.arange(n)
    rank = np.cumsum(root) - 1
    return int(np.count_nonzero(root)), np.take(rank, parent)


def _cycle_min(nxt: np.ndarray) -> np.ndarray:
    """(n,) the lowest element of each element's cycle under the permutation `nxt`.

    Pointer jumping: before a round, low[i] is the lowest of the `reach` elements from i on and
    ptr[i] the element `reach` steps on. It stops at the first round that changes nothing, not
    after ⌈log₂ n⌉ rounds (20 for a million elements where the longest cycle needs 12): then
    low[i] <= low[ptr[i]] for every i, so going round a cycle in steps of `reach` low never
    decreases, hence is constant, and those windows cover the cycle: low[i] is the cycle's
    lowest element, exactly what the remaining rounds would leave."""
    low = np.arange(len(nxt), dtype=np.int64)
    ptr = np.asarray(nxt, dtype=np.int64)
    reach = 1
    while reach < len(nxt):  # after the round, low covers 2·reach elements of the cycle
        lower = np.minimum(low, np.take(low, ptr))
        if np.array_equal(lower, low):
            break
        low = lower
        ptr = np.take(ptr, ptr)
        reach *= 2
    return low


def permutation_cycles(nxt: np.ndarray) -> tuple[int, np.ndarray]:
    """(count, (n,) label) of the cycles of the permutation `nxt` (element i → nxt[i])."""
    roots, label = np.unique(_cycle_min(nxt), return_inverse=True)
    return len(roots), label.reshape(-1)


#: Up to this many vertices the cycles are walked one vertex at a time (a plane section of a
#: CAD part: a few dozen), above by list ranking (a vase's 4,000): ~20 numpy calls cost more than
#: a short loop.
SMALL_WALK = 128


def _walk_each(nb: np.ndarray) -> list[np.ndarray]:
    """`cycle_walks` vertex by vertex: nb (n, 2) each vertex's two neighbours."""
    pairs = nb.tolist()
    seen = [False] * len(pairs)
    out = []
    for start in range(len(pairs)):
        if seen[start]:
            continue
        seen[start] = True
        order = [start]
        prev, cur = start, min(pairs[start])
        while not seen[cur]:
            seen[cur] = True
            order.append(cur)
            a, b = pairs[cur]
            prev, cur = cur, (b if a == prev else a)
        out.append(np.array(order, dtype=np.int64))
    return out


def cycle_walks(n: int, edges: np.ndarray) -> list[np.ndarray]:
    """The cycles of a graph on n vertices whose every vertex has degree 2 (edges: (n, 2)
    distinct undirected pairs, low first), each as its vertex order from its lowest vertex
    towards that vertex's lower neighbour, cycles in the order of their lowest vertex."""
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    ends = np.concatenate([edges[:, 0], edges[:, 1]])
    if len(ends) != 2 * n or np.any(np.bincount(ends, minlength=n) != 2):
        raise ValueError("cycle_walks needs a graph whose every vertex has degree 2")
    other = np.concatenate([edges[:, 1], edges[:, 0]])
    # each vertex's two neighbours in the order its ends come (what a stable argsort of `ends`
    # gives): its first end and its last, by two scatters (the last write wins), no sort
    idx = np.arange(len(ends))
    first = np.empty(n, dtype=np.int64)
    first[ends[::-1]] = idx[::-1]
    last = np.empty(n, dtype=np.int64)
    last[ends] = idx
    nb = np.stack([other[first], other[last]], axis=1)
    if n <= SMALL_WALK:
        return _walk_each(nb)
    v = np.arange(n, dtype=np.int64)
    # directed edge 2v + k: v → nb[v, k]; the next one leaves nb[v, k] by its other neighbour
    head = nb.reshape(-1)
    back = (nb[head, 1] == np.repeat(v, 2)).astype(np.int64)  # head's slot that points back
    succ = 2 * head + (1 - back)
    low = _cycle_min(succ)  # two directed cycles per cycle: 2s and 2s + 1, s its lowest vertex
    first = (nb[:, 1] < nb[:, 0]).astype(np.int64)  # the slot of each vertex's lower neighbour
    keep = np.flatnonzero(low % 2 == first[low // 2])  # the walks that start to the lower side
    # position along the walk: list ranking with the edge into the start cut off
    m = 2 * n
    ptr = np.append(succ, m)
    ptr[:m][succ == low] = m
    rank = np.ones(m + 1, dtype=np.int64)
    rank[m] = 0
    reach = 1
    while reach < m:
        rank += rank[ptr]
        ptr = ptr[ptr]
        reach *= 2
    start = low[keep]
    pos = rank[start] - rank[keep]  # steps from the start
    # walks in the order of their start (each cycle's lowest vertex), each in step order: every
    # directed edge's place is its walk's offset plus its step (what a lexsort gives, no sort)
    starts, size = np.unique(start, return_counts=True)
    offset = np.concatenate([[0], np.cumsum(size)])
    place = offset[np.searchsorted(starts, start)] + pos
    verts = np.empty(len(keep), dtype=np.int64)
    verts[place] = keep // 2
    return np.split(verts, offset[1:-1])
