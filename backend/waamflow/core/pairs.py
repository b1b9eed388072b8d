"""The pairs of points within a distance of each other, as scipy's `cKDTree.query_pairs` finds
them, without importing scipy.spatial.

Importing scipy.spatial costs ~0.15 s of a CLI run (scipy.sparse and scipy.special come with it):
more than the preflight's retrace check spends searching graphs/bracket.json's 300 layers. A grid
of cells a little wider than the reach does the same search with numpy: two points within reach
of each other lie in the same cell or in neighbouring ones, so each point is compared with the
points of its own cell and of half of its neighbours (the other half finds the pair from the other
side), after one sort of the cells' keys. A pair is kept when dx² + dy² (+ dz²) <= reach², the
test the k-d tree makes; `groups` keeps apart points of different groups (the layers of a
program) as a far 4th coordinate would.
"""

from __future__ import annotations

from itertools import product
from typing import Iterator

import numpy as np

_KEY_LIMIT = 2**62  # the cells' keys are int64: the grid (groups × cells) must number fewer


def _half_offsets(dim: int) -> list[tuple[int, ...]]:
    """The cell itself and the neighbours that come after it in lexicographic order: each pair of
    neighbouring cells once."""
    return [o for o in product((-1, 0, 1), repeat=dim) if o > (0,) * dim or not any(o)]


def close_pair_batches(
    points: np.ndarray, reach: float, groups: np.ndarray | None = None
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """(i, j) row numbers of `points` ((n, d), d = 1, 2 or 3) within `reach` of each other (and of
    the same group), i != j, each unordered pair once, in batches (one per neighbour offset: a caller
    may stop early). Raises ValueError if the grid of cells cannot be keyed in 64 bits (a part
    kilometres wide at a micrometre's reach)."""
    P = np.asarray(points, dtype=float)
    n = len(P)
    if n < 2:
        return
    if P.ndim != 2 or P.shape[1] not in (1, 2, 3):
        raise ValueError(f"points must be (n, 1), (n, 2) or (n, 3), got {P.shape}")
    if not reach > 0 or not np.isfinite(reach):
        raise ValueError(f"reach must be a positive number of mm, got {reach!r}")
    cell = np.floor((P - P.min(axis=0)) / (reach * (1.0 + 1e-9))).astype(np.int64)
    # a cell's key: its coordinates with a margin of one cell on both sides, the group outermost
    dims = cell.max(axis=0) + 3
    g = np.zeros(n, np.int64) if groups is None else np.unique(np.asarray(groups), return_inverse=True)[1]
    size = float(np.prod(dims.astype(float))) * (float(g.max()) + 1.0)
    if size >= _KEY_LIMIT:
        raise ValueError(f"a grid of {size:.3g} cells cannot be keyed in 64 bits")
    stride = np.ones(P.shape[1], np.int64)
    for k in range(P.shape[1] - 2, -1, -1):
        stride[k] = stride[k + 1] * dims[k + 1]
    key = (cell + 1) @ stride + g * int(np.prod(dims))
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    r2 = reach * reach
    for offset in _half_offsets(P.shape[1]):
        target = key + int(np.dot(offset, stride))
        lo = np.searchsorted(sorted_key, target, side="left")
        count = np.searchsorted(sorted_key, target, side="right") - lo
        total = int(count.sum())
        if total == 0:
            continue
        i = np.repeat(np.arange(n), count)
        j = order[np.repeat(lo, count) + np.arange(total) - np.repeat(np.cumsum(count) - count, count)]
        if not any(offset):  # its own cell: each pair once, never a point with itself
            keep = i < j
            i, j = i[keep], j[keep]
        d = P[i] - P[j]
        d2 = d[:, 0] * d[:, 0]
        for k in range(1, P.shape[1]):  # summed in the axes' order, as the k-d tree sums
            d2 += d[:, k] * d[:, k]
        hit = d2 <= r2
        yield i[hit], j[hit]


def close_pairs(points: np.ndarray, reach: float, groups: np.ndarray | None = None) -> np.ndarray:
    """(m, 2) int: every pair (i < j) of rows of `points` within `reach` of each other (and of the
    same group), in no particular order: the set `cKDTree(points).query_pairs(reach)` returns."""
    found = [
        np.column_stack([np.minimum(i, j), np.maximum(i, j)]) for i, j in close_pair_batches(points, reach, groups)
    ]
    return np.vstack(found) if found else np.zeros((0, 2), np.int64)
