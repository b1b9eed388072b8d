"""A positioner's kinematics from its URDF: the Pinocchio model of a shipped positioner description
(`positioner_kin`, cached per file), its axes, limits (deg), speeds (deg/s) and link frames
(`PositionerKin`), and the rotation helpers the cell's placements use (`rpy_matrix`, `_rz`).

Split from `trajectory.cell` (issue 27): that module is the cell file's model (what stands where),
this one the positioner's joint kinematics; every name stays importable from `trajectory.cell`.
Units: mm, deg.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core.errors import InputFileError
from ..core.files import read_shipped
from .profile import ROBOTS_DIR

if TYPE_CHECKING:  # imported where used: keeps `waamflow nodes` light
    import pinocchio as pin


def rpy_matrix(rpy_deg) -> np.ndarray:
    """Fixed-axis roll (x), pitch (y), yaw (z), degrees → R = Rz·Ry·Rx (the URDF convention)."""
    r, p, y = np.radians(np.asarray(rpy_deg, float))
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


@dataclass(frozen=True, eq=False)
class PositionerKin:
    """A positioner URDF as Pinocchio model: axes (revolute joints in chain order), their limits
    (deg) and speeds (deg/s), and every link's frame."""

    model: pin.Model
    names: tuple[str, ...]
    lower_deg: np.ndarray
    upper_deg: np.ndarray
    speed_deg_s: np.ndarray
    links: tuple[str, ...]

    @property
    def nq(self) -> int:
        return len(self.names)

    def pose(self, q_deg, link: str) -> tuple[np.ndarray, np.ndarray]:
        """(R, t mm) of `link` in the positioner base frame."""
        import pinocchio as pin

        data = self.model.createData()
        pin.framesForwardKinematics(self.model, data, np.radians(np.asarray(q_deg, float)))
        M = data.oMf[self.model.getFrameId(link)]
        return M.rotation.copy(), M.translation * 1000.0

    def axes_base(self, link: str) -> np.ndarray:
        """(nq, 3) joint axes in the positioner base frame at the zero pose (the angular part of
        `link`'s Jacobian)."""
        import pinocchio as pin

        data = self.model.createData()
        q = np.zeros(self.nq)
        pin.computeJointJacobians(self.model, data, q)
        pin.updateFramePlacements(self.model, data)
        J = pin.getFrameJacobian(self.model, data, self.model.getFrameId(link), pin.LOCAL_WORLD_ALIGNED)
        w = np.asarray(J, float).reshape(6, -1)[3:, : self.nq].T
        return w / np.linalg.norm(w, axis=1, keepdims=True)


@lru_cache(maxsize=16)
def positioner_kin(urdf: str) -> PositionerKin:
    import pinocchio as pin

    model = _positioner_model(urdf)
    if model.nq < 1 or model.nq > 2 or model.nv != model.nq:
        raise InputFileError(f"positioner description {urdf}: {model.nq} axes (1 or 2 revolute axes supported)")
    names = tuple(model.names[j] for j in range(1, model.njoints))
    links = tuple(f.name for f in model.frames if f.type == pin.FrameType.BODY)
    return PositionerKin(
        model,
        names,
        np.degrees(model.lowerPositionLimit),
        np.degrees(model.upperPositionLimit),
        np.degrees(model.velocityLimit),
        links,
    )


def _rz(deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _urdf_path(name: str) -> Path:
    return ROBOTS_DIR / Path(name).name  # shipped descriptions only: a cell never reads arbitrary paths


def _positioner_model(urdf: str):
    import pinocchio as pin

    text = read_shipped(
        ROBOTS_DIR, _urdf_path(urdf).name, "positioner description", sorted(p.name for p in ROBOTS_DIR.glob("*.urdf"))
    ).decode("utf-8")
    try:
        return pin.buildModelFromXML(text)
    except Exception as e:
        raise InputFileError(f"positioner description {urdf}: {e}") from e
