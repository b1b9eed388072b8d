"""Wall pieces joined end to end at junction points (`chain_pieces`).

The rule (walls.py, unchanged): again and again, the first junction point, in the given order, at
which exactly two piece ends meet (within `tol`), of two different pieces, joins them: the lower
piece (in the list's order) runs into the joint, the other out of it; the joined piece goes to the
end of the list. Applied literally, every join re-scanned every joint against every piece end: O(joints²
× pieces) for a sketch (ezdxf's recover01.dxf, ~3,000 walls a layer: 50 of a 240 s run). Here each
joint's piece ends are found once (a k-d tree: piece ends never move, a join only retires two of
them and hands two to the joined piece), and after a join only the joints whose ends changed owner
are looked at again; the joints that qualify wait in a heap by their order. The same joins in the
same order, the same pieces in the same list order.
"""

from __future__ import annotations

import heapq

import numpy as np


def chain_pieces(pieces: list[np.ndarray], joints: list[np.ndarray], tol: float) -> list[np.ndarray]:
    """Join pieces end to end at corner/continuous junction points `joints` (see the module doc)."""
    if not pieces or not len(joints):
        return list(pieces)
    from scipy.spatial import cKDTree  # here: the layer workers' fork server preloads no scipy (engine/warm.py)

    arrays: list[np.ndarray] = list(pieces)
    ends = np.array([[p[0], p[-1]] for p in pieces], dtype=float).reshape(-1, 2)  # slot 2k: start, 2k+1: end
    owner = np.repeat(np.arange(len(pieces)), 2)  # slot → piece (−1: joined, gone)
    side = np.tile([0, 1], len(pieces))  # slot → 0 start / 1 end of its piece
    rank = list(range(len(pieces)))  # piece → its place in the list order
    slots = [[2 * k, 2 * k + 1] for k in range(len(pieces))]  # piece → its (start, end) slots
    jp = np.asarray(joints, dtype=float).reshape(-1, 2)
    near: list[list[int]] = []
    for j, cand in enumerate(cKDTree(ends).query_ball_point(jp, r=tol * (1 + 1e-9) + 1e-12)):
        near.append([s for s in sorted(cand) if np.hypot(*(ends[s] - jp[j])) <= tol])
    watch: dict[int, list[int]] = {}  # slot → joints that see it
    for j, seen in enumerate(near):
        for s in seen:
            watch.setdefault(s, []).append(j)

    def hits(j: int) -> list[tuple[int, int, int]]:
        return sorted((rank[owner[s]], side[s], s) for s in near[j] if owner[s] >= 0)

    def ready(j: int) -> bool:
        h = hits(j)
        return len(h) == 2 and owner[h[0][2]] != owner[h[1][2]]

    heap = [j for j in range(len(near)) if ready(j)]
    heapq.heapify(heap)
    while heap:
        j = heapq.heappop(heap)
        if not ready(j):
            continue
        (_ra, ea, sa), (_rb, eb, sb) = hits(j)
        a, b = int(owner[sa]), int(owner[sb])
        pa = arrays[a] if ea == 1 else arrays[a][::-1]
        pb = arrays[b] if eb == 0 else arrays[b][::-1]
        new = len(arrays)
        arrays.append(np.vstack([pa, pb[1:]]))
        rank.append(len(rank))
        out_a = slots[a][1 - ea]  # a's other end starts the joined piece, b's other end ends it
        out_b = slots[b][1 - eb]
        slots.append([out_a, out_b])
        owner[[sa, sb]] = -1
        owner[[out_a, out_b]] = new
        side[out_a], side[out_b] = 0, 1
        for s in (sa, sb, out_a, out_b):
            for k in watch.get(s, ()):
                if ready(k):
                    heapq.heappush(heap, k)
    alive = sorted({int(o) for o in owner if o >= 0}, key=lambda p: rank[p])  # a piece alive owns its ends
    return [arrays[p] for p in alive]
