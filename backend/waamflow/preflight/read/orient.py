"""Tool axes from the orientations robot programs state, by each controller's own convention
(scipy's rotations, not the posts' code): KUKA A, B, C (R = Rz(A)·Ry(B)·Rx(C), intrinsic Z-Y'-X''),
Fanuc W, P, R and Yaskawa Rx, Ry, Rz (fixed axes, R = Rz·Ry·Rx), ABB quaternions [q1..q4] =
[w, x, y, z]. The tool axis is the tool frame's column the controller points along the torch:
x under KUKA's default `$TOOL_DIRECTION = #X`, z for the others (and for KUKA set to #Z)."""

from __future__ import annotations

import re

import numpy as np

_DIRECTION = re.compile(r"tool direction ([XYZ])\b", re.IGNORECASE)


def tool_column(header: str, default: str) -> int:
    """The tool frame's column along the torch: the program's `tool direction X|Y|Z` header line
    (our posts write it), else `default` ("x" KUKA, "z" ABB)."""
    m = _DIRECTION.search(header)
    return "xyz".index((m.group(1) if m else default).lower())


def axes_euler(angles_deg: np.ndarray, seq: str, column: int) -> np.ndarray:
    """(n, 3) angles in degrees → (n, 3) unit tool axes; seq: "ZYX" intrinsic (KUKA A, B, C in that
    order) or "xyz" extrinsic (Fanuc W, P, R; Yaskawa Rx, Ry, Rz)."""
    from scipy.spatial.transform import Rotation  # not at import: the fork server preloads without scipy

    a = np.asarray(angles_deg, float).reshape(-1, 3)
    if not len(a):
        return np.zeros((0, 3))
    return Rotation.from_euler(seq, a, degrees=True).as_matrix()[:, :, column]


def axes_quaternion(q_wxyz: np.ndarray, column: int = 2) -> np.ndarray:
    """(n, 4) ABB quaternions [q1, q2, q3, q4] = [w, x, y, z] → (n, 3) unit tool axes (normalised
    first: a controller refuses a quaternion far from unit length; rounding is forgiven)."""
    from scipy.spatial.transform import Rotation

    q = np.asarray(q_wxyz, float).reshape(-1, 4)
    if not len(q):
        return np.zeros((0, 3))
    return Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()[:, :, column]
