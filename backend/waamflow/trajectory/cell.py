"""Cell description: robot arm, tool, positioner, table/fixtures and where they stand (JSON file).

A cell file (shipped in `waamflow/data/cells/<name>.json` or a user's path) names the arm URDF, the
tool (TCP in the flange frame, torch collision shape), the optional positioner (URDF with 1-2
revolute axes: tilt then rotate; limits and speeds come from the URDF), the table and fixtures as
simple shapes, the base placements and the work frame on the positioner's flange. All lengths mm,
angles deg. `Cell.frames(angles)` turns it into the kinematics' `CellFrames` for given positioner
angles (the `fixed` policy: the angles stay at `positioner.fixed_deg` for the whole program).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..core.errors import InputFileError
from .kinematics import CellFrames
from .profile import ROBOTS_DIR

CELLS_DIR = Path(__file__).resolve().parent.parent / "data" / "cells"

Vec3 = tuple[float, float, float]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Placement(_Strict):
    """A frame in its parent: translation (mm) then rotation about z (deg)."""

    xyz_mm: Vec3 = (0.0, 0.0, 0.0)
    yaw_deg: float = Field(0.0, ge=-360, le=360)


class Shape(_Strict):
    """A collision/visual primitive in its parent frame: box (size = full x,y,z extents) or
    cylinder (size = radius, radius, length along local z); centred at `xyz_mm`."""

    name: str = Field(..., min_length=1, max_length=64)
    kind: Literal["box", "cylinder"]
    size_mm: Vec3
    xyz_mm: Vec3 = (0.0, 0.0, 0.0)


class Tool(_Strict):
    """The welding torch: TCP in the flange (tool0) frame, z along the torch towards the part."""

    tcp_mm: Vec3 = (0.0, 0.0, 400.0)
    shapes: list[Shape] = Field(default_factory=list, description="Torch collision shapes in the flange frame")


class Positioner(_Strict):
    """A tilt (+ rotate) positioner; `flange` is the URDF link the part is fixed to."""

    urdf: str = Field(..., min_length=1, max_length=128, description="URDF in data/robots")
    flange: str = Field("table_top", min_length=1, max_length=64)
    base: Placement = Placement()
    fixed_deg: list[float] = Field(default_factory=list, max_length=2,
                                   description="Axis angles for the `fixed` policy (E1 tilt, E2 rotate; empty = 0)")


class Cell(_Strict):
    """A robot cell (see the module doc)."""

    name: str = Field(..., min_length=1, max_length=64)
    source: str = Field("", description="Where the kinematic numbers come from (datasheet, URDF)")
    robot_urdf: str = Field(..., min_length=1, max_length=128, description="Arm URDF in data/robots")
    robot_base: Placement = Placement(xyz_mm=(-1500.0, 0.0, -600.0))
    tool: Tool = Tool()
    positioner: Positioner | None = None
    work_frame: Placement = Field(Placement(), description="Part origin on the positioner flange (or in the world)")
    fixtures: list[Shape] = Field(default_factory=list, description="Table and fixtures in the world frame")

    def positioner_pose(self, angles_deg=None) -> tuple[np.ndarray, np.ndarray]:
        """World rotation (3x3) and translation (mm) of the positioner flange at the given angles."""
        import pinocchio as pin

        pos = self.positioner
        if pos is None:
            return np.eye(3), np.zeros(3)
        model = _positioner_model(pos.urdf)
        if not model.existFrame(pos.flange):
            raise InputFileError(f"cell {self.name}: positioner has no link {pos.flange!r}")
        ang = list(angles_deg if angles_deg is not None else pos.fixed_deg)
        if len(ang) > model.nq:
            raise InputFileError(f"cell {self.name}: {len(ang)} positioner angles for {model.nq} axes")
        q = np.zeros(model.nq)
        q[: len(ang)] = np.radians(ang)
        if np.any(q < model.lowerPositionLimit - 1e-9) or np.any(q > model.upperPositionLimit + 1e-9):
            raise InputFileError(f"cell {self.name}: positioner angles {ang} deg outside the axis limits")
        data = model.createData()
        pin.framesForwardKinematics(model, data, q)
        M = data.oMf[model.getFrameId(pos.flange)]
        Rb = _rz(pos.base.yaw_deg)
        return Rb @ M.rotation, Rb @ (M.translation * 1000.0) + np.asarray(pos.base.xyz_mm, float)

    def frames(self, angles_deg=None) -> CellFrames:
        """Kinematics frames with the part on the positioner flange at the given (or fixed) angles."""
        R, t = self.positioner_pose(angles_deg)
        Rw = R @ _rz(self.work_frame.yaw_deg)
        tw = R @ np.asarray(self.work_frame.xyz_mm, float) + t
        return CellFrames(base_xyz_mm=tuple(float(v) for v in self.robot_base.xyz_mm),
                          base_yaw_deg=self.robot_base.yaw_deg,
                          work_xyz_mm=tuple(float(v) for v in tw),
                          work_rot=tuple(tuple(float(v) for v in row) for row in Rw))


def _rz(deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _urdf_path(name: str) -> Path:
    return ROBOTS_DIR / Path(name).name          # shipped descriptions only: a cell never reads arbitrary paths


def _positioner_model(urdf: str):
    import pinocchio as pin

    path = _urdf_path(urdf)
    if not path.exists():
        raise InputFileError(f"positioner description {urdf!r} not found")
    try:
        return pin.buildModelFromXML(path.read_text())
    except Exception as e:
        raise InputFileError(f"positioner description {urdf}: {e}") from e


def shipped_cells() -> list[str]:
    return sorted(p.stem for p in CELLS_DIR.glob("*.json"))


def load_cell(name_or_path: str, text: str | None = None) -> Cell:
    """A shipped cell by name, or a cell JSON's text (a user's file read by the caller).
    Errors name the file and field."""
    if text is None:
        path = CELLS_DIR / f"{Path(name_or_path).name}.json"
        if not path.exists():
            raise InputFileError(f"cell {name_or_path!r} not found (shipped: {', '.join(shipped_cells())})")
        text = path.read_text()
    try:
        return Cell.model_validate(json.loads(text))
    except json.JSONDecodeError as e:
        raise InputFileError(f"cell {name_or_path}: not JSON ({e.msg}, line {e.lineno})") from e
    except ValidationError as e:
        err = e.errors()[0]
        where = ".".join(str(x) for x in err["loc"])
        raise InputFileError(f"cell {name_or_path}: {where}: {err['msg']}") from e
