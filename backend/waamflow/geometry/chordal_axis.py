"""The centre line of a thin polygon: the longest path of its chordal axis.

Triangulate the polygon (constrained Delaunay, GEOS through shapely, boundary segmentized first so
the triangles span it from side to side); each triangle edge shared by two triangles is a chord
across the polygon, and joining the midpoints of a triangle's chords gives the chordal axis (Prasad,
"Morphological analysis of shapes", CNLS Newsletter 139, 1997), a tree for a polygon without holes.
A terminal triangle (one chord) reaches on to its third vertex, the end of the strip. The longest
path through the tree is the polygon's centre line: one pass along a strip, the main branch of a
forked one. Its two ends run on along their last direction to the polygon's boundary (a terminal
triangle's third vertex is a corner of the strip's end, not its middle), and it is simplified within
2 % of the polygon's thickness. Units are the polygon's (mm
in waamflow)."""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import shapely
from shapely.geometry import Polygon


#: The centre line is simplified (Douglas-Peucker) within this share of the polygon's thickness.
SIMPLIFY = 0.02
#: A polygon filling this share of its minimum rotated rectangle is taken as that rectangle.
RECTANGULAR = 0.995


def chordal_axis(polygon: Polygon, step: float | None = None) -> np.ndarray:
    """(n, 2) points of the longest path of the polygon's chordal axis, from one end to the other.
    `step`: the boundary's segment length before triangulating, at least the polygon's thickness
    2·area/perimeter and 1/2000 of its size (the default). Holes are ignored (filled)."""
    poly = Polygon(polygon.exterior)
    size = max(poly.bounds[2] - poly.bounds[0], poly.bounds[3] - poly.bounds[1])
    # corners a hair apart (an offset's 1e-16 mm, a mesh's 4e-12 mm) made degenerate triangles whose
    # two chords were one: a node paired with itself, and an axis of one point
    poly = shapely.remove_repeated_points(poly, 1e-9 * max(size, 1.0))
    thickness = 2.0 * poly.area / max(poly.length, 1e-12)
    rect = _rectangle_axis(poly)
    if rect is not None:
        return rect
    step = max(step or 0.0, thickness, size / 2000.0)
    tris = _triangles(poly, step)
    if tris is None:  # GEOS triangulates it at no subdivision: the long middle line of its rectangle
        return _middle_line(poly)
    tris = tris[shapely.area(tris) > 0]
    if not len(tris):
        return np.asarray(poly.exterior.coords)[:2]
    pts = np.round(shapely.get_coordinates(tris).reshape(-1, 4, 2)[:, :3].reshape(-1, 2), 9)
    keys, index = np.unique(pts, axis=0, return_inverse=True)
    tri = index.reshape(-1, 3)
    edges = np.sort(np.vstack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    uniq, inv, count = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
    chords = np.flatnonzero(count == 2)
    if not len(chords):  # a single triangle: from its longest edge's midpoint to the opposite vertex
        e = max(((0, 1, 2), (1, 2, 0), (2, 0, 1)), key=lambda k: np.hypot(*(keys[tri[0, k[0]]] - keys[tri[0, k[1]]])))
        return np.vstack([0.5 * (keys[tri[0, e[0]]] + keys[tri[0, e[1]]]), keys[tri[0, e[2]]]])
    node = np.full(len(uniq), -1)
    node[chords] = np.arange(len(chords))
    mine = node[inv.ravel()].reshape(3, -1).T  # per triangle: the node of each edge's chord, -1 on the boundary
    mine = -np.sort(-mine, axis=1)  # chords first
    k = (mine >= 0).sum(axis=1)
    xy = 0.5 * (keys[uniq[chords, 0]] + keys[uniq[chords, 1]])
    pairs = [mine[k == 2][:, :2]]
    junction = np.flatnonzero(k == 3)  # a junction triangle: its chords meet at its centroid
    if len(junction):
        centre = len(xy) + np.arange(len(junction))
        xy = np.vstack([xy, keys[tri[junction]].mean(axis=1)])
        pairs += [np.column_stack([mine[junction, j], centre]) for j in range(3)]
    pair = np.vstack(pairs)
    pair = pair[pair[:, 0] != pair[:, 1]]  # a degenerate triangle's two chords are one: no edge
    if not len(pair):  # one chord: across the strip's middle
        a, b = keys[uniq[chords[0], 0]], keys[uniq[chords[0], 1]]
        n = np.array([b[1] - a[1], a[0] - b[0]])
        return _extend(poly, np.vstack([xy[0] - 1e-9 * n, xy[0] + 1e-9 * n]), size)
    graph: dict[int, list[int]] = defaultdict(list)
    length: dict[tuple[int, int], float] = {}
    for (a, b), d in zip(pair.tolist(), np.hypot(*(xy[pair[:, 0]] - xy[pair[:, 1]]).T).tolist()):
        graph[a].append(b)
        graph[b].append(a)
        length[a, b] = length[b, a] = d
    path = _longest_path(_pruned(graph, length, step), length)
    if len(path) < 2:  # every branch was a spur, the pruned tree has no edge left: the whole tree
        path = _longest_path(graph, length)
    axis = _extend(poly, xy[path], size)
    # one point per chord is far more than a bead path needs: straight stretches to their ends
    return np.asarray(shapely.simplify(shapely.LineString(axis), SIMPLIFY * thickness).coords)


def _pruned(graph: dict[int, list[int]], length: dict[tuple[int, int], float], shorter: float) -> dict[int, list[int]]:
    """The tree without its spurs: branches from a leaf to a junction shorter than `shorter` (the
    corner triangles of a strip's end fork off its axis by less than its thickness)."""
    drop: set[int] = set()
    for leaf in [v for v in graph if len(graph[v]) == 1]:
        branch, prev, u, run = [leaf], -1, leaf, 0.0
        while True:
            nxt = [v for v in graph[u] if v != prev]
            if not nxt:
                break  # the whole tree is this branch
            prev, u = u, nxt[0]
            run += length[prev, u]
            if len(graph[u]) >= 3:
                if run < shorter:
                    drop.update(branch)
                break
            branch.append(u)
    if len(graph) - len(drop) < 2:
        return graph
    return {u: [v for v in vs if v not in drop] for u, vs in graph.items() if u not in drop}


def _triangles(poly: Polygon, step: float) -> np.ndarray | None:
    """The constrained Delaunay triangles of the polygon, its boundary subdivided at `step`; GEOS
    stops at some subdivisions of a sliver ("Unable to find a convex corner": fuzzed contour pieces)
    and not at others: a golden-ratio longer and shorter step, then the boundary as it is; None when
    every one fails."""
    for s in (step, step * 1.618, step * 0.618, None):
        try:
            return shapely.get_parts(shapely.constrained_delaunay_triangles(shapely.segmentize(poly, s) if s else poly))
        except shapely.errors.GEOSException:
            continue
    return None


def _middle_line(poly: Polygon) -> np.ndarray:
    """The long middle line of the polygon's minimum rotated rectangle."""
    c = np.asarray(shapely.minimum_rotated_rectangle(poly).exterior.coords)[:4]
    e1, e2 = c[1] - c[0], c[2] - c[1]
    if np.hypot(*e1) < np.hypot(*e2):
        return np.vstack([0.5 * (c[0] + c[1]), 0.5 * (c[2] + c[3])])
    return np.vstack([0.5 * (c[1] + c[2]), 0.5 * (c[3] + c[0])])


def _rectangle_axis(poly: Polygon) -> np.ndarray | None:
    """A polygon that fills its minimum rotated rectangle to `RECTANGULAR`: the rectangle's long
    middle line (a rectangular part's innermost sliver), without triangulating; else None."""
    box = shapely.minimum_rotated_rectangle(poly)
    if not isinstance(box, Polygon) or poly.area < RECTANGULAR * box.area:
        return None
    return _middle_line(poly)


def _extend(poly: Polygon, path: np.ndarray, size: float) -> np.ndarray:
    """The path with both ends run on along their last segment's direction to the boundary."""
    ends = []
    for tip, prev in ((path[0], path[1]), (path[-1], path[-2])):
        u = tip - prev
        n = float(np.hypot(*u))
        if n <= 0:
            ends.append(tip)
            continue
        ray = shapely.LineString([tip, tip + u / n * 2.0 * size])
        hit = shapely.get_parts(shapely.intersection(ray, poly.exterior))
        pts = [np.asarray(g.coords[0]) for g in hit if not g.is_empty]
        ends.append(min(pts, key=lambda q: float(np.hypot(*(q - tip)))) if pts else tip)
    return np.vstack([ends[0], path, ends[1]])


def _longest_path(graph: dict[int, list[int]], length: dict[tuple[int, int], float]) -> list[int]:
    """The longest path of a forest (two farthest-first sweeps per tree, edge length = distance): a
    sliver's degenerate triangles, dropped, can leave its axis in pieces (a fuzzed contour piece: the
    sweep began in a 3-node piece and the axis was 1.7 mm of a 15 mm sliver)."""

    def farthest(src: int) -> tuple[int, dict[int, int], dict[int, float]]:
        dist, parent, stack = {src: 0.0}, {src: -1}, [src]
        while stack:
            u = stack.pop()
            for v in graph[u]:
                if v not in dist:
                    dist[v] = dist[u] + length[u, v]
                    parent[v] = u
                    stack.append(v)
        return max(dist, key=dist.__getitem__), parent, dist

    best: list[int] = []
    best_len = -1.0
    seen: set[int] = set()
    for src in graph:
        if src in seen:
            continue
        a, _, tree = farthest(src)
        seen.update(tree)
        b, parent, dist = farthest(a)
        if dist[b] > best_len:
            best_len = dist[b]
            best = [b]
            while parent[best[-1]] != -1:
                best.append(parent[best[-1]])
    return best
