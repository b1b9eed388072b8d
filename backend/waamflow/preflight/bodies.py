"""A part of several closed bodies, united in 3D for the preflight.

The preflight cuts the part's sections even-odd (nested loops are holes) and tells inside from
outside by ray parity. Both read a mesh of overlapping shells wrongly: where two outward shells
overlap the section has a hole and the ray crosses twice. ros-industrial/abb's IRB 4400
link_1.stl (six overlapping shells) failed its programs with 300 stretches of weld "outside the
part" that lay in the overlaps (4,612 mm² of layer 208). The slicer unites the bodies plane by
plane (slicing/rings.py); here the bodies are united once in 3D by manifold3d (Manifold's
boolean union, float64), an independent route to the same solid, and every check reads that:
solid bodies united, voids (bodies facing inwards, kept by the mesh read) subtracted.
"""

from __future__ import annotations

import numpy as np

from ..core.graphs import connected_components
from ..geometry.topology import signed_volume


def body_labels(faces: np.ndarray, n_vertices: int) -> tuple[int, np.ndarray]:
    """(count, (m,) label per face): faces joined through shared vertices (a closed mesh's bodies;
    bodies touching only at a vertex count as one, which the even-odd sections read right)."""
    f = np.asarray(faces, dtype=np.int64)
    n, vlabel = connected_components(n_vertices, np.concatenate([f[:, 0], f[:, 1]]), np.concatenate([f[:, 1], f[:, 2]]))
    return n, vlabel[f[:, 0]]


def united(vertices: np.ndarray, faces: np.ndarray, bodies: int = 0) -> tuple[np.ndarray, np.ndarray, int, str | None]:
    """(vertices, faces, body count, note) of the solid the bodies make: unchanged for one body
    (`bodies` == 1 skips the count: what the mesh read measured), else the union of the bodies of
    positive volume less those of negative volume (manifold3d). A union manifold3d cannot make (a
    body it does not take as a closed manifold) leaves the mesh as it is, and the note says so."""
    if bodies == 1 or not len(faces):
        return vertices, faces, 1, None
    n, label = body_labels(faces, len(vertices))
    if n == 1:
        return vertices, faces, 1, None
    import manifold3d

    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    solid: list = []
    void: list = []
    order = np.argsort(label, kind="stable")  # the faces body by body, one sort for all bodies
    bounds = np.concatenate([[0], np.cumsum(np.bincount(label, minlength=n))])
    for b in range(n):
        fb = f[order[bounds[b] : bounds[b + 1]]]
        used, local = np.unique(fb, return_inverse=True)
        local = local.reshape(-1, 3)
        d = v[used]
        vol = signed_volume(d, local)
        tri = local if vol > 0 else local[:, ::-1]
        m = manifold3d.Manifold(
            manifold3d.Mesh64(vert_properties=d, tri_verts=np.ascontiguousarray(tri, dtype=np.uint64))
        )
        if m.status() != manifold3d.Error.NoError:
            note = (
                f"the part's {n} bodies are checked as they are, not united: body {b} is not a closed "
                f"manifold to manifold3d ({m.status().name}); where bodies overlap, sections read the "
                "overlap as a hole"
            )
            return vertices, faces, n, note
        (solid if vol > 0 else void).append(m)
    if not solid:
        return vertices, faces, n, None
    out = manifold3d.Manifold.batch_boolean(solid, manifold3d.OpType.Add)
    if void:
        out = out - manifold3d.Manifold.batch_boolean(void, manifold3d.OpType.Add)
    mesh = out.to_mesh64()
    v_out = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    return v_out, np.asarray(mesh.tri_verts, dtype=np.int64), n, None
