"""Parametric curved test parts (mm): the bent hollow duct of the curved-parts recipe."""

from __future__ import annotations

import numpy as np

from ..core.model import MeshData


def bent_tube(
    bend: float = 100.0, mid: float = 15.0, wall: float = 3.0, sweep_deg: float = 90.0, n_phi: int = 72, n_psi: int = 40
) -> MeshData:
    """Closed mesh of a tube section of a torus: a hollow wall of thickness `wall` about a tube
    centre line of radius `mid`, bent by `sweep_deg` about the axis through (−bend, 0, 0) along −y.

    The first cross-section (φ = 0) is the ring centred on the origin in the plane z = 0 (the
    substrate); the duct rises in +z while bending towards −x. Radial extent about the bend axis:
    bend ± (mid + wall/2). n_phi sweep steps, n_psi steps around the tube.
    """
    phi = np.radians(np.linspace(0.0, sweep_deg, n_phi + 1))
    psi = np.linspace(0.0, 2 * np.pi, n_psi, endpoint=False)
    centre = np.array([-bend, 0.0, 0.0])
    P, S = np.meshgrid(phi, psi, indexing="ij")
    er = np.stack([np.cos(P), np.zeros_like(P), np.sin(P)], axis=-1)

    def surface(rho: float) -> np.ndarray:
        pts = centre + (bend + rho * np.cos(S))[..., None] * er + (rho * np.sin(S))[..., None] * np.array([0, 1.0, 0])
        return pts.reshape(-1, 3)

    outer, inner = surface(mid + wall / 2), surface(mid - wall / 2)
    off = len(outer)
    i = np.arange(n_phi)[:, None]
    j = np.arange(n_psi)[None, :]
    a, b = i * n_psi + j, (i + 1) * n_psi + j
    c, d = (i + 1) * n_psi + (j + 1) % n_psi, i * n_psi + (j + 1) % n_psi
    quads = np.stack([a, b, c, d], axis=-1).reshape(-1, 4)
    # (φ step) × (ψ step) points into the tube: the outer skin takes the reversed winding
    tri_out = np.concatenate([quads[:, [0, 2, 1]], quads[:, [0, 3, 2]]])
    tri_in = off + np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    caps = []
    for row, flip in ((0, True), (n_phi, False)):
        o0 = row * n_psi + np.arange(n_psi)
        o1 = row * n_psi + (np.arange(n_psi) + 1) % n_psi
        t = np.concatenate([np.stack([o0, o1, off + o1], 1), np.stack([o0, off + o1, off + o0], 1)])
        caps.append(t[:, ::-1] if flip else t)
    faces = np.concatenate([tri_out, tri_in] + caps).astype(np.int64)
    return MeshData(np.vstack([outer, inner]), faces, name="bent-tube")
