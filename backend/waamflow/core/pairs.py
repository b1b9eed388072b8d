"""The pairs of points within a distance of each other, as scipy's `cKDTree.query_pairs` finds
them, without importing scipy.spatial.

Importing scipy.spatial costs ~0.15 s of a CLI run (scipy.sparse and scipy.special come with it):
more than the preflight's retrace check spends searching graphs/bracket.json's 300 layers. A grid
of cells a little wider than the reach does the same search with numpy: two points within reach
of each other lie in the same cell or in neighbouring ones, so each point is compared with the
points of its own cell and of half of its neighbours (the other half finds the pair from the other
side), after one sort of the cells' keys. A pair is kept when dx² + dy² (+ dz²) <= reach², the
test the k-d tree makes; `groups` keeps apart points of different groups (the layers of a
program) as a far 4th coordinate would. `pairs_between` finds the pairs across two sets only (a
travel's samples against the beads': no pair within either set is formed and thrown away).
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


def _grid(P: np.ndarray, reach: float, lo: np.ndarray, groups: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(each row's cell key, the strides of the cell coordinates): cells of
    `reach` (a little more) from `lo`, with a margin of one cell on both sides, the group outermost."""
    cell = np.floor((P - lo) / (reach * (1.0 + 1e-9))).astype(np.int64)
    dims = cell.max(axis=0) + 3 if len(cell) else np.full(P.shape[1], 3, np.int64)
    g = np.zeros(len(P), np.int64) if groups is None else np.asarray(groups, np.int64)
    size = float(np.prod(dims.astype(float))) * (float(g.max(initial=0)) + 1.0)
    if size >= _KEY_LIMIT:
        raise ValueError(f"a grid of {size:.3g} cells cannot be keyed in 64 bits")
    stride = np.ones(P.shape[1], np.int64)
    for k in range(P.shape[1] - 2, -1, -1):
        stride[k] = stride[k + 1] * dims[k + 1]
    return (cell + 1) @ stride + g * int(np.prod(dims)), stride


def _check(P: np.ndarray, reach: float) -> None:
    if P.ndim != 2 or P.shape[1] not in (1, 2, 3):
        raise ValueError(f"points must be (n, 1), (n, 2) or (n, 3), got {P.shape}")
    if not reach > 0 or not np.isfinite(reach):
        raise ValueError(f"reach must be a positive number of mm, got {reach!r}")


def _expand(
    sorted_key: np.ndarray, order: np.ndarray, target: np.ndarray, target_order: np.ndarray
) -> tuple[np.ndarray, ...]:
    """(i, j): each row i (`target_order`, by position in `target`) with every row j (by `order`)
    whose key equals its target key. `target` ascends (the keys sorted, plus an offset): numpy's
    binary search starts each sorted needle where the last one ended, 7x faster than needles in
    row order on 200,000 keys (a 0.5 m bunny's retrace check spent 63 of its 225 s in them)."""
    lo = np.searchsorted(sorted_key, target, side="left")
    count = np.searchsorted(sorted_key, target, side="right") - lo
    total = int(count.sum())
    i = target_order[np.repeat(np.arange(len(target)), count)]
    j = order[np.repeat(lo, count) + np.arange(total) - np.repeat(np.cumsum(count) - count, count)]
    return i, j


def _within(A: np.ndarray, B: np.ndarray, i: np.ndarray, j: np.ndarray, r2: float) -> np.ndarray:
    """(k,) bool: rows A[i] and B[j] within √r2 of each other."""
    d = A[i] - B[j]
    d2 = d[:, 0] * d[:, 0]
    for k in range(1, A.shape[1]):  # summed in the axes' order, as the k-d tree sums
        d2 += d[:, k] * d[:, k]
    return np.asarray(d2 <= r2, dtype=bool)


def pairs_between(a: np.ndarray, b: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """(i, j): every row i of `a` and row j of `b` ((n, d) and (m, d), d = 1, 2 or 3) within `reach`
    of each other, in no particular order: the pairs `cKDTree(a).query_ball_tree(cKDTree(b), reach)`
    lists. Raises ValueError as `close_pair_batches`."""
    A, B = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    none = (np.zeros(0, np.int64), np.zeros(0, np.int64))
    if not len(A) or not len(B):
        return none
    _check(A, reach)
    _check(B, reach)
    lo = np.minimum(A.min(axis=0), B.min(axis=0))
    key_ab, stride = _grid(np.vstack([A, B]), reach, lo, None)
    key_a, key_b = key_ab[: len(A)], key_ab[len(A) :]
    order = np.argsort(key_b, kind="stable")
    sorted_key = key_b[order]
    order_a = np.argsort(key_a, kind="stable")
    sorted_a = key_a[order_a]
    found_i, found_j = [], []
    for offset in product((-1, 0, 1), repeat=A.shape[1]):
        i, j = _expand(sorted_key, order, sorted_a + int(np.dot(offset, stride)), order_a)
        hit = _within(A, B, i, j, reach * reach)
        found_i.append(i[hit])
        found_j.append(j[hit])
    return np.concatenate(found_i), np.concatenate(found_j)


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
    _check(P, reach)
    g = None if groups is None else np.unique(np.asarray(groups), return_inverse=True)[1]
    key, stride = _grid(P, reach, P.min(axis=0), g)
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    for offset in _half_offsets(P.shape[1]):
        i, j = _expand(sorted_key, order, sorted_key + int(np.dot(offset, stride)), order)
        if not len(i):
            continue
        if not any(offset):  # its own cell: each pair once, never a point with itself
            keep = i < j
            i, j = i[keep], j[keep]
        hit = _within(P, P, i, j, reach * reach)
        yield i[hit], j[hit]


def close_pairs(points: np.ndarray, reach: float, groups: np.ndarray | None = None) -> np.ndarray:
    """(m, 2) int: every pair (i < j) of rows of `points` within `reach` of each other (and of the
    same group), in no particular order: the set `cKDTree(points).query_pairs(reach)` returns."""
    found = [
        np.column_stack([np.minimum(i, j), np.maximum(i, j)]) for i, j in close_pair_batches(points, reach, groups)
    ]
    return np.vstack(found) if found else np.zeros((0, 2), np.int64)
