"""Horizontal plane sections for the preflight's slab check, bit for bit what trimesh gives, without
importing trimesh (issue #30).

The slab check (slabs.py) cuts the part with trimesh's `intersections.mesh_plane` and merges the
segments' endpoints with `grouping.unique_rows`. Importing trimesh (scipy.spatial and the rest)
cost every layer worker 0.7-1.3 s of CPU before its first slab task, and `unique_rows` sorts 24-byte
`np.void` rows (3.7 ms a plane of the bench vase: half of the loop chaining). This module does the
same computations with the same numpy calls in the same order on the same arrays, so the segments,
the merged points and their numbering are identical (tests/preflight/test_planecut.py compares them
with trimesh's on meshes with vertices and edges on the plane):

- `plane_segments(vertices, faces, z)` = `mesh_plane(Trimesh(vertices, faces), [0, 0, 1], [0, 0, z])`
  for faces indexing the full vertex array directly (a slab mesh renumbered to its own vertices
  gives the same values: only the vertices the faces use are ever read, row by row).
- `unique_rows(points, digits)` = `grouping.unique_rows(points, digits)`: the first occurrence of
  each row rounded to `digits` decimals and each row's rank, in the order of numpy's sort of the
  rows' bytes (what `np.unique` does to `np.void` rows), found with one SIMD `np.sort` of a packed
  key and a lexicographic re-sort of the few runs the key cannot tell apart.

The code mirrors trimesh 4.x/5.x (MIT licence, Michael Dawson-Haggerty): `mesh_plane`,
`plane_lines`, `util.unitize`, `grouping.unique_value_in_row`, `grouping.float_to_int`,
`grouping.hashable_rows`.
"""

from __future__ import annotations

import sys

import numpy as np

TOL_MERGE = 1e-8  # trimesh.constants.tol.merge: a vertex this close to the plane is on it
TOL_ZERO = np.finfo(np.float64).resolution * 100  # trimesh.constants.tol.zero
MERGE_DIGITS = 5  # trimesh.constants.tol_path.merge_digits (tol_path.merge 1e-5)
_CASE_BASIC = np.zeros(29, dtype=bool)
_CASE_BASIC[[4, 12]] = True  # one vertex on one side, two on the other
_CASE_VERTEX = np.zeros(29, dtype=bool)
_CASE_VERTEX[8] = True  # one vertex on the plane, the other two on either side
_CASE_EDGE = np.zeros(29, dtype=bool)
_CASE_EDGE[16] = True  # one edge on the plane, the third vertex above


def _unitize(vectors: np.ndarray) -> np.ndarray:
    norm = np.sqrt(np.dot(vectors * vectors, [1.0] * vectors.shape[1]))
    valid = norm > TOL_ZERO
    norm[valid] **= -1
    return vectors * norm.reshape((-1, 1))


def _plane_lines(z: float, endpoints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """trimesh's `plane_lines` for the plane at height z, lines from endpoints[0] to endpoints[1]
    ((2, n, 3)), whose first ends all lie off the plane. Its `np.dot`s with the normal (0, 0, 1)
    are z components exactly: the x and y terms are products with 0 (±0), and ±0 added to a
    non-zero number in any order leaves it unchanged; t is never 0 as the first ends are off the
    plane (by more than TOL_MERGE)."""
    line_dir = _unitize(endpoints[1] - endpoints[0])
    t = z - endpoints[0][:, 2]
    b = line_dir[:, 2]
    valid = np.abs(b) > TOL_ZERO
    d = np.divide(t[valid], b[valid])
    intersection = endpoints[0][valid]
    intersection = intersection + np.reshape(d, (-1, 1)) * line_dir[valid]
    return intersection, valid


def plane_segments(vertices: np.ndarray, faces: np.ndarray, z: float) -> np.ndarray:
    """(n, 2, 3) section segments of the triangles `faces` (into `vertices`, float64) by the plane
    at height z: trimesh's `mesh_plane` of the mesh of those faces, the same values in the same
    order (basic crossings, then a vertex on the plane, then an edge on it)."""
    z = float(z)
    faces = np.asarray(faces)
    # the dot product of each corner with the normal: (0, 0, 1) · (v - o) is v_z - z exactly
    dots = vertices[:, 2][faces] - z
    signs = np.zeros(faces.shape, dtype=np.int8)
    signs[dots < -TOL_MERGE] = -1
    signs[dots > TOL_MERGE] = 1
    signs_sorted = np.sort(signs, axis=1)
    coded = np.zeros(len(signs_sorted), dtype=np.int8) + 14
    for i in range(3):
        coded += signs_sorted[:, i] << 3 - i
    basic, one_vertex, one_edge = _CASE_BASIC[coded], _CASE_VERTEX[coded], _CASE_EDGE[coded]
    parts = []
    # basic: the corner alone on its side (sorted signs -1 -1 1: the 1, -1 1 1: the -1), then the
    # corners after it: trimesh's unique_value_in_row and np.roll of that mask by 1 and 2
    s, f = signs[basic], faces[basic]
    alone = np.where(coded[basic] == 4, 1, -1).astype(np.int8)
    u = np.argmax(s == alone[:, None], axis=1)
    fu = np.take_along_axis(f, u[:, None], axis=1)[:, 0]
    f1 = np.take_along_axis(f, ((u + 1) % 3)[:, None], axis=1)[:, 0]
    f2 = np.take_along_axis(f, ((u + 2) % 3)[:, None], axis=1)[:, 0]
    edges = np.stack((fu, f1, fu, f2), axis=1).reshape((-1, 2))
    points, valid = _plane_lines(z, np.take(vertices, edges.T, axis=0))
    if not valid.all():
        raise AssertionError("plane section: a basic crossing edge lies in the plane")
    parts.append(points.reshape((-1, 2, 3)))
    s, f = signs[one_vertex], faces[one_vertex]
    vertex_plane = f[s == 0]
    edge_thru = f[s != 0].reshape((-1, 2))
    points, valid = _plane_lines(z, vertices[edge_thru.T])
    parts.append(np.column_stack((vertices[vertex_plane[valid]], points)).reshape((-1, 2, 3)))
    s, f = signs[one_edge], faces[one_edge]
    parts.append(vertices[f[s == 0].reshape((-1, 2))])
    return np.vstack(parts)


def _float_to_int(data: np.ndarray, digits: int) -> np.ndarray:
    return np.round((data * 10**digits) - 1e-6).astype(np.int64)


def _row_keys(as_int: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Keys of the rows of `as_int` (n, k) int64 in the order numpy sorts them as trimesh's
    `hashable_rows` gives them: (full (n, c) uint64 keys, compared lexicographically; one uint64
    per row that orders the rows like the full keys, ties aside). When the rounded values fit
    64 bits the row is one packed uint64 (numeric order); else the rows are `np.void` bytes,
    sorted by their bytes (memcmp: each little-endian int64, byte-swapped, is an unsigned number
    of that order), and the lead key packs the first 8 bytes that can tell rows apart (bytes
    equal in every row, or in every row equal to the byte before, never decide)."""
    precision = int(np.floor(64 / as_int.shape[1]))
    d_min, d_max = as_int.min(), as_int.max()
    threshold = (2 ** (precision - 1)) - 1
    if as_int.shape[1] <= 4 and d_max < threshold and d_min > -threshold:
        hashable = np.zeros(len(as_int), dtype=np.uint64)
        bitbang = (as_int.T + (threshold + 1)).astype(np.uint64)
        for offset, column in enumerate(bitbang):
            np.bitwise_xor(hashable, column << (offset * precision), out=hashable)
        return hashable.reshape(-1, 1), hashable
    raw = np.ascontiguousarray(as_int)
    keys = raw.view(np.uint64)
    if sys.byteorder == "little":
        keys = keys.byteswap()
    data = np.ascontiguousarray(raw.view(np.uint8).reshape(len(raw), -1).T)  # byte j of every row
    tells = ~(data == data[:, :1]).all(axis=1)
    tells[1:] &= ~(data[1:] == data[:-1]).all(axis=1)
    lead = np.zeros(len(raw), dtype=np.uint64)
    for j, col in enumerate(np.flatnonzero(tells)[:8]):
        lead |= data[col].astype(np.uint64) << np.uint64(56 - 8 * j)
    return keys, lead


def _lex_order(keys: np.ndarray, lead: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The stable lexicographic order of the rows of `keys` (n, k) uint64 (`np.lexsort` on the
    columns, the first most significant) and the rows in that order. One `np.sort` of (the top
    bits of `lead` | row index), then a lexsort of just the runs that key cannot tell apart."""
    n = len(keys)
    bits = max(int(n - 1).bit_length(), 1)
    shift = np.uint64(bits)
    packed = ((lead >> shift) << shift) | np.arange(n, dtype=np.uint64)
    packed.sort()
    order = (packed & np.uint64((1 << bits) - 1)).astype(np.int64)
    ks = np.take(keys, order, axis=0)
    tie = (packed[1:] >> shift) == (packed[:-1] >> shift)
    differ = np.zeros(n - 1, dtype=bool)
    for c in range(keys.shape[1]):
        differ |= ks[1:, c] != ks[:-1, c]
    differ &= tie
    if differ.any():
        run = np.cumsum(np.concatenate([[True], ~tie]))
        mixed = np.zeros(int(run[-1]) + 1, dtype=bool)
        mixed[run[1:][differ]] = True
        sub = np.flatnonzero(mixed[run])
        sk = ks[sub]
        cols = tuple(sk[:, c] for c in range(keys.shape[1] - 1, -1, -1)) + (run[sub],)
        resort = np.lexsort(cols)
        order[sub] = order[sub][resort]
        ks[sub] = sk[resort]
    return order, ks


def unique_rows(points: np.ndarray, digits: int = MERGE_DIGITS) -> tuple[np.ndarray, np.ndarray]:
    """(index, inverse) of trimesh's `grouping.unique_rows(points, digits)` for (n, 2..4) floats:
    index[j] is the first row of the j-th distinct rounded row in numpy's sort order of trimesh's
    row hashes, inverse[i] the j of row i."""
    n = len(points)
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    order, ks = _lex_order(*_row_keys(_float_to_int(np.asarray(points, dtype=np.float64), digits)))
    new = np.zeros(n, dtype=bool)
    new[0] = True
    for c in range(ks.shape[1]):
        new[1:] |= ks[1:, c] != ks[:-1, c]
    inverse = np.empty(n, dtype=np.int64)
    inverse[order] = np.cumsum(new) - 1
    return order[new], inverse
