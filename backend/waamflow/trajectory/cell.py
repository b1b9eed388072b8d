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
import math
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
    robot_home_deg: list[float] | None = Field(None, min_length=6, max_length=6,
                                               description="IK seed pose of the arm (deg; empty = 0 −90 90 0 90 0, "
                                                           "the KUKA upright pose with the wrist down)")
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


def cell_schema() -> dict:
    """The cell file's JSON Schema with every $ref inlined (embedded in simulate-robot's params
    schema as `x-cell-schema`, where root-relative references would not resolve)."""
    raw = Cell.model_json_schema()
    defs = raw.pop("$defs", {})

    def inline(node):
        if isinstance(node, dict):
            if "$ref" in node:
                return inline(defs[node["$ref"].rsplit("/", 1)[-1]])
            return {k: inline(v) for k, v in node.items()}
        if isinstance(node, list):
            return [inline(v) for v in node]
        return node
    return inline(raw)


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


POLICIES = ("fixed", "gravity", "min-motion")


def positioner_angles(cell: Cell, moves, policy: str = "fixed", max_tilt_deg: float = 30.0) -> np.ndarray:
    """Positioner angles (deg) at every programmed point, shape (n, 2) (E1 tilt about x, E2 turn about z).

    `fixed`: `positioner.fixed_deg` throughout. `gravity`: each layer turned so its mean torch axis
    (arc-ON segments) points straight down (world −z), the flat welding position of the
    curved-parts study: with n = −axis, E2 = 90° − atan2(n_y, n_x) brings n's horizontal part onto
    +y, then E1 = atan2(|n_xy|, n_z) tilts it up to +z. E2 is unwrapped by 360° to stay closest to
    the previous layer's (and kept when n is vertical). `min-motion`: a layer keeps the previous
    layer's angles (the cell's fixed_deg for the first) while its normal stays within
    `max_tilt_deg` of vertical under them, else it takes its gravity angles — the fewest positioner
    moves for a torch allowed to lean that much. Angles are constant along a layer, so the
    positioner moves only on the arc-OFF travel between layers. A point takes the angles of the
    arc-ON segment it ends (else of the segment it starts)."""
    if policy not in POLICIES:
        raise InputFileError(f"positioner policy {policy!r}: use one of {', '.join(POLICIES)}")
    n = len(moves.points)
    fixed = np.zeros(2)
    if cell.positioner is not None:
        fixed[: len(cell.positioner.fixed_deg)] = cell.positioner.fixed_deg
    if policy == "fixed" or cell.positioner is None or n < 2:
        return np.tile(fixed, (n, 1))
    model = _positioner_model(cell.positioner.urdf)
    lo, hi = np.degrees(model.lowerPositionLimit), np.degrees(model.upperPositionLimit)
    seg_layer = np.asarray(moves.layer)
    arc = np.asarray(moves.arc, bool)
    axes = np.asarray(moves.tool_axis, float)
    layer_angles: dict[int, np.ndarray] = {}
    prev = fixed.copy()
    for L in sorted(set(seg_layer.tolist())):
        segs = np.flatnonzero((seg_layer == L) & arc)
        if len(segs) == 0:
            segs = np.flatnonzero(seg_layer == L)
        nrm = -axes[segs].mean(axis=0)
        nrm /= max(np.linalg.norm(nrm), 1e-12)
        r = math.hypot(nrm[0], nrm[1])
        e1 = math.degrees(math.atan2(r, nrm[2]))
        e2 = prev[1] if r < 1e-6 else 90.0 - math.degrees(math.atan2(nrm[1], nrm[0]))
        if len(lo) > 1:
            cands = [e2 + 360.0 * k for k in range(-3, 4) if lo[1] - 1e-9 <= e2 + 360.0 * k <= hi[1] + 1e-9]
            if cands:
                e2 = min(cands, key=lambda a: abs(a - prev[1]))
        e1 = float(np.clip(e1, lo[0], hi[0]))
        if policy == "min-motion":
            up = np.asarray(cell.frames(list(prev[: model.nq])).work_rot, float) @ nrm
            if math.degrees(math.acos(float(np.clip(up[2], -1.0, 1.0)))) <= max_tilt_deg + 1e-9:
                layer_angles[L] = prev
                continue
        prev = np.array([e1, e2])
        layer_angles[L] = prev
    out = np.zeros((n, 2))
    for i in range(n):
        if i > 0 and arc[i - 1]:
            s = i - 1
        else:
            s = min(i, n - 2)
        out[i] = layer_angles[int(seg_layer[s])]
    return out


def to_world(cell: Cell, points: np.ndarray, axes: np.ndarray, angles_deg: np.ndarray):
    """Part-frame points and torch axes (n, 3) → world, each with its own positioner angles."""
    pts = np.empty_like(np.asarray(points, float))
    ax = np.empty_like(np.asarray(axes, float))
    uniq, inv = np.unique(np.round(angles_deg, 9), axis=0, return_inverse=True)
    for j, a in enumerate(uniq):
        f = cell.frames(a)
        R, t = np.asarray(f.work_rot), np.asarray(f.work_xyz_mm)
        m = inv.ravel() == j
        pts[m] = np.asarray(points, float)[m] @ R.T + t
        ax[m] = np.asarray(axes, float)[m] @ R.T
    return pts, ax
