"""Tubular strategies (Venturini et al. 2018, §4.4): helical, aligned start–stop, scattered start–stop.

A tubular is a closed loop given as a (k, 2) float polyline in mm, first point repeated at the end.
"""

from __future__ import annotations

import math

import numpy as np

# Start points of the scattered strategy advance by the golden-ratio fraction of the loop each
# layer: the low-discrepancy sequence frac(i·φ) spreads any number of layers' starts evenly.
GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def _cumlen(ring: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(ring, axis=0).T))])


def loop_walk(ring: np.ndarray, s0: float, total: float) -> np.ndarray:
    """(m, 2) points walking the closed `ring` from arc length s0 (mm) for `total` mm (may exceed
    one lap: the walk wraps), keeping every ring vertex passed."""
    s = _cumlen(ring)
    L = float(s[-1])
    if L <= 0:
        raise ValueError("degenerate loop")
    s0 = float(s0) % L
    laps = int(math.ceil((s0 + total) / L)) + 1
    verts = np.concatenate([s[:-1] + k * L for k in range(laps)] + [[laps * L]])
    inner = verts[(verts > s0) & (verts < s0 + total)]
    t = np.concatenate([[s0], inner, [s0 + total]])
    u = t % L
    # exact end of a lap maps to the ring's closing point, not back to 0 (keeps the last vertex)
    u[(u == 0) & (t > 0)] = L
    x = np.interp(u, s, ring[:, 0])
    y = np.interp(u, s, ring[:, 1])
    pts = np.column_stack([x, y])
    keep = np.concatenate([[True], np.hypot(*np.diff(pts, axis=0).T) > 1e-9])
    return pts[keep]


def aligned_loop(ring: np.ndarray, overlap: float) -> np.ndarray:
    """Aligned start–stop: one lap from the ring's first point plus a self-overlap O_l (mm) past
    the start, compensating the thin extinction region (overlap angle = O_l / R on a circle)."""
    return loop_walk(ring, 0.0, _cumlen(ring)[-1] + overlap)


def scattered_loop(ring: np.ndarray, layer_index: int, overlap: float) -> np.ndarray:
    """Scattered start–stop: the lap starts at arc length frac(i·φ)·L on layer i."""
    L = float(_cumlen(ring)[-1])
    return loop_walk(ring, (layer_index * GOLDEN % 1.0) * L, L + overlap)


def helix(ring: np.ndarray, zs) -> np.ndarray:
    """(m, 3) continuous helical path over all layers, no per-layer ignition.

    zs: (n,) float layer deposition heights (mm), bottom to top. The first lap is flat at zs[0]
    (it lays layer 0 on the flat substrate); lap k = 1..n−1 rises linearly with arc length from
    zs[k−1] to zs[k], so the pitch of each lap equals that layer's height.
    """
    zs = np.asarray(zs, float)
    s = _cumlen(ring)
    L = float(s[-1])
    laps = [np.column_stack([ring, np.full(len(ring), zs[0])])]
    for k in range(1, len(zs)):
        z = zs[k - 1] + (zs[k] - zs[k - 1]) * s / L
        laps.append(np.column_stack([ring, z])[1:])
    return np.vstack(laps)
