"""Torch orientation from the tool axis: rotation matrices, KUKA A/B/C angles, ABB quaternions.

The toolpath gives, per point, the tool axis t: a unit vector from the torch towards the part
((0, 0, -1) for a vertical torch). The torch is symmetric about t, so the rotation about t is free;
we fix it with a constant reference direction so the wrist does not spin along the path.

Tool frames (columns of R are the tool's x, y, z axes in world coordinates):

* ``"z"`` — tool z along t (ABB tooldata convention, ISO 9787). x = world −X projected onto the
  plane normal to t (world −Y when t is parallel to X). A vertical torch gives R = Ry(180°),
  quaternion [0, 0, 1, 0], the usual ABB "torch down" orientation.
* ``"x"`` — tool x along t (KUKA's default tool direction, `$TOOL_DIRECTION = #X`): the "z" frame
  turned −90° about its y axis (x_k = z, y_k = y, z_k = −x). A vertical torch gives A = 0,
  B = 90°, C = 0.
"""

from __future__ import annotations

import numpy as np

_REF = np.array([-1.0, 0.0, 0.0])
_REF_ALT = np.array([0.0, -1.0, 0.0])


def tool_frames(axes: np.ndarray, direction: str = "z") -> np.ndarray:
    """(n, 3) unit tool axes → (n, 3, 3) rotation matrices (world ← tool), see module doc."""
    t = np.asarray(axes, dtype=float).reshape(-1, 3)
    norm = np.linalg.norm(t, axis=1, keepdims=True)
    if np.any(norm < 1e-12):
        raise ValueError("tool axis of zero length")
    z = t / norm
    ref = np.tile(_REF, (len(z), 1))
    parallel = np.abs(z @ _REF) > 0.99
    ref[parallel] = _REF_ALT
    x = ref - (np.sum(ref * z, axis=1, keepdims=True)) * z
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(z, x)
    if direction == "z":
        cols = (x, y, z)
    elif direction == "x":
        cols = (z, y, -x)
    else:
        raise ValueError(f"tool direction must be 'x' or 'z', not {direction!r}")
    return np.stack(cols, axis=2)


def kuka_abc(frames: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations → (n, 3) KUKA angles A, B, C in degrees.

    KUKA convention: R = Rz(A) · Ry(B) · Rx(C) (intrinsic Z-Y'-X''), A, C in (−180, 180],
    B in [−90, 90]. At B = ±90° (gimbal lock) C is set to 0 and A takes the whole rotation.
    """
    R = np.asarray(frames, dtype=float).reshape(-1, 3, 3)
    sb = np.clip(-R[:, 2, 0], -1.0, 1.0)
    b = np.arcsin(sb)
    cb = np.sqrt(np.maximum(0.0, 1.0 - sb**2))
    lock = cb < 1e-9
    a = np.where(lock, np.arctan2(-R[:, 0, 1], R[:, 1, 1]), np.arctan2(R[:, 1, 0], R[:, 0, 0]))
    c = np.where(lock, 0.0, np.arctan2(R[:, 2, 1], R[:, 2, 2]))
    out = np.degrees(np.column_stack([a, b, c]))
    out[np.isclose(out, -180.0)] = 180.0
    return out + 0.0  # no negative zeros in the program text


def fixed_xyz_angles(axes: np.ndarray) -> np.ndarray:
    """(n, 3) unit tool axes → (n, 3) fixed-axis angles about x, y, z in degrees with R = Rz·Ry·Rx,
    tool z along the axis: Fanuc W, P, R and Yaskawa Rx, Ry, Rz (KUKA's C, B, A)."""
    if len(axes) == 0:
        return np.zeros((0, 3))
    return kuka_abc(tool_frames(axes, "z"))[:, ::-1]


def abc_matrix(abc_deg: np.ndarray) -> np.ndarray:
    """(n, 3) KUKA A, B, C in degrees → (n, 3, 3) rotations Rz(A)·Ry(B)·Rx(C) (inverse of kuka_abc)."""
    a, b, c = np.radians(np.asarray(abc_deg, dtype=float).reshape(-1, 3)).T
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    R = np.empty((len(a), 3, 3))
    R[:, 0] = np.column_stack([ca * cb, ca * sb * sc - sa * cc, ca * sb * cc + sa * sc])
    R[:, 1] = np.column_stack([sa * cb, sa * sb * sc + ca * cc, sa * sb * cc - ca * sc])
    R[:, 2] = np.column_stack([-sb, cb * sc, cb * cc])
    return R


def quaternions(frames: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations → (n, 4) unit quaternions [q1, q2, q3, q4] = [w, x, y, z] (ABB order),
    with w ≥ 0 (q and −q are the same orientation; a fixed sign keeps consecutive targets close)."""
    R = np.asarray(frames, dtype=float).reshape(-1, 3, 3)
    q = np.empty((len(R), 4))
    for i, m in enumerate(R):
        tr = m[0, 0] + m[1, 1] + m[2, 2]
        if tr > 0:
            s = 2.0 * np.sqrt(tr + 1.0)
            q[i] = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
        elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
            s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
            q[i] = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
        elif m[1, 1] > m[2, 2]:
            s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
            q[i] = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
        else:
            s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
            q[i] = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q[q[:, 0] < 0] *= -1.0
    return q + 0.0
