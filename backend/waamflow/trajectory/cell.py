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
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, ValidationError, model_validator

from ..core.errors import InputFileError
from ..core.files import read_shipped
from .kinematics import CellFrames
from .positionerkin import PositionerKin as PositionerKin
from .positionerkin import _positioner_model as _positioner_model
from .positionerkin import _rz as _rz
from .positionerkin import _urdf_path as _urdf_path
from .positionerkin import positioner_kin as positioner_kin
from .positionerkin import rpy_matrix as rpy_matrix


CELLS_DIR = Path(__file__).resolve().parent.parent / "data" / "cells"

Vec3 = tuple[float, float, float]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Placement(_Strict):
    """A frame in its parent: translation (mm) then rotation about z (deg)."""

    xyz_mm: Vec3 = (0.0, 0.0, 0.0)
    yaw_deg: float = Field(0.0, ge=-360, le=360)


class Shape(_Strict):
    """A collision/visual body: box (size = full x, y, z extents), cylinder (size = radius, radius,
    length along its local z) or mesh (`mesh`: an STL/OBJ/PLY file, mm, scaled by `size_mm`),
    placed at `xyz_mm` with fixed-axis roll/pitch/yaw `rpy_deg` (x then y then z, as in URDF) in
    the frame of `link`: "" = the parent's default (the world for fixtures, the flange for the
    positioner's shapes), else a positioner URDF link (e.g. "table_top": clamps turn with the part)."""

    name: str = Field(..., min_length=1, max_length=64)
    kind: Literal["box", "cylinder", "mesh"]
    size_mm: Vec3 = Field(
        (1.0, 1.0, 1.0), description="box: x, y, z extents; cylinder: radius, radius, length; mesh: scale factors"
    )
    xyz_mm: Vec3 = (0.0, 0.0, 0.0)
    rpy_deg: Vec3 = Field((0.0, 0.0, 0.0), description="Fixed-axis roll, pitch, yaw (deg)")
    link: str = Field(
        "",
        max_length=64,
        description="Frame the shape is fixed to: '' = world (fixtures) or the "
        "positioner flange (positioner shapes); or a positioner link",
    )
    mesh: str = Field("", max_length=256, description="kind mesh: file next to the cell file (or in data/cells)")

    @model_validator(mode="after")
    def _mesh_named(self):
        if self.kind == "mesh" and not self.mesh:
            raise ValueError(f"shape {self.name!r}: kind mesh needs a `mesh` file")
        if self.kind == "cylinder" and self.size_mm[0] <= 0 or self.kind == "box" and min(self.size_mm) <= 0:
            raise ValueError(f"shape {self.name!r}: sizes must be > 0")
        return self

    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        """(R, t mm) of the shape in its link frame."""
        return rpy_matrix(self.rpy_deg), np.asarray(self.xyz_mm, float)


class Tool(_Strict):
    """The welding torch: TCP in the flange (tool0) frame, z along the torch towards the part."""

    tcp_mm: Vec3 = (0.0, 0.0, 400.0)
    shapes: list[Shape] = Field(default_factory=list, description="Torch collision shapes in the flange frame")


# The turntable disc of cells written before the positioner carried its own shapes (migration).
LEGACY_TABLE = {"name": "table", "kind": "cylinder", "size_mm": [300.0, 300.0, 40.0], "xyz_mm": [0.0, 0.0, -20.0]}


class Positioner(_Strict):
    """A 1- or 2-axis positioner (URDF revolute joints in chain order: tilt then rotate; limits and
    speeds from the URDF); `flange` is the URDF link the part is fixed to; `shapes` its moving
    bodies (the table, in the flange frame unless a shape names another positioner link)."""

    urdf: str = Field(..., min_length=1, max_length=128, description="URDF in data/robots")
    flange: str = Field("table_top", min_length=1, max_length=64)
    base: Placement = Placement()
    fixed_deg: list[float] = Field(
        default_factory=list,
        max_length=2,
        description="Axis angles for the `fixed` policy (E1 tilt, E2 rotate; empty = 0)",
    )
    shapes: list[Shape] = Field(
        default_factory=list,
        description="The positioner's moving bodies (table disc, tilt frame), "
        "collision-checked and drawn; flange frame unless `link` names another",
    )

    @model_validator(mode="before")
    @classmethod
    def _migrate(cls, data):
        if isinstance(data, dict) and "shapes" not in data:  # cells before the table was a shape
            data = {**data, "shapes": [dict(LEGACY_TABLE)]}
        return data


class Cell(_Strict):
    """A robot cell (see the module doc)."""

    name: str = Field(..., min_length=1, max_length=64)
    source: str = Field("", description="Where the kinematic numbers come from (datasheet, URDF)")
    robot_urdf: str = Field(..., min_length=1, max_length=128, description="Arm URDF in data/robots")
    robot_base: Placement = Placement(xyz_mm=(-1500.0, 0.0, -600.0))
    robot_home_deg: list[float] | None = Field(
        None,
        min_length=6,
        max_length=6,
        description="IK seed pose of the arm (deg; empty = 0 −90 90 0 90 0, the KUKA upright pose with the wrist down)",
    )
    tool: Tool = Tool()
    positioner: Positioner | None = None
    work_frame: Placement = Field(Placement(), description="Part origin on the positioner flange (or in the world)")
    fixtures: list[Shape] = Field(
        default_factory=list,
        description="Table, pedestal, floor and fixtures: in the world frame, or fixed to "
        "a positioner link (`link`), turning with it",
    )
    _meshes: dict = PrivateAttr(default_factory=dict)

    @model_validator(mode="after")
    def _links_exist(self):
        if self.positioner is not None and not _urdf_path(self.positioner.urdf).exists():
            return self  # named when the positioner is first used
        links = {"", *(positioner_kin(self.positioner.urdf).links if self.positioner is not None else ())}
        for sh in [*self.fixtures, *(self.positioner.shapes if self.positioner else [])]:
            if sh.link not in links:
                raise ValueError(
                    f"shape {sh.name!r}: link {sh.link!r} is not a positioner link "
                    f"({', '.join(sorted(links - {''})) or 'no positioner'})"
                )
        return self

    # ---- positioner ------------------------------------------------------------------------
    @property
    def axes(self) -> int:
        """Number of positioner axes (0 without a positioner)."""
        return 0 if self.positioner is None else positioner_kin(self.positioner.urdf).nq

    def fixed_angles(self) -> np.ndarray:
        a = np.zeros(self.axes)
        if self.positioner is not None:
            f = list(self.positioner.fixed_deg)[: self.axes]
            a[: len(f)] = f
        return a

    def link_pose(self, angles_deg, link: str = "") -> tuple[np.ndarray, np.ndarray]:
        """World rotation (3x3) and translation (mm) of a positioner link ("" = the flange) at the
        given angles (deg; checked against the axis limits)."""
        pos = self.positioner
        if pos is None:
            return np.eye(3), np.zeros(3)
        pk = positioner_kin(pos.urdf)
        link = link or pos.flange
        if link not in pk.links:
            raise InputFileError(f"cell {self.name}: positioner has no link {link!r}")
        ang = np.asarray(list(angles_deg if angles_deg is not None else self.fixed_angles()), float)
        if len(ang) > pk.nq:
            raise InputFileError(f"cell {self.name}: {len(ang)} positioner angles for {pk.nq} axes")
        q = np.zeros(pk.nq)
        q[: len(ang)] = ang
        if np.any(q < pk.lower_deg - 1e-7) or np.any(q > pk.upper_deg + 1e-7):
            raise InputFileError(f"cell {self.name}: positioner angles {list(ang)} deg outside the axis limits")
        R, t = pk.pose(q, link)
        Rb = _rz(pos.base.yaw_deg)
        return Rb @ R, Rb @ t + np.asarray(pos.base.xyz_mm, float)

    def positioner_pose(self, angles_deg=None) -> tuple[np.ndarray, np.ndarray]:
        """World rotation (3x3) and translation (mm) of the positioner flange at the given angles."""
        return self.link_pose(angles_deg)

    def work_pose(self, angles_deg=None) -> tuple[np.ndarray, np.ndarray]:
        """World rotation and translation (mm) of the work frame (part origin) at the given angles."""
        R, t = self.positioner_pose(angles_deg)
        return R @ _rz(self.work_frame.yaw_deg), R @ np.asarray(self.work_frame.xyz_mm, float) + t

    def frames(self, angles_deg=None) -> CellFrames:
        """Kinematics frames with the part on the positioner flange at the given (or fixed) angles."""
        Rw, tw = self.work_pose(angles_deg)
        return CellFrames(
            base_xyz_mm=xyz3(self.robot_base.xyz_mm),
            base_yaw_deg=self.robot_base.yaw_deg,
            work_xyz_mm=xyz3(tw),
            work_rot=tuple(xyz3(row) for row in Rw),
        )

    # ---- shapes ------------------------------------------------------------------------------
    def load_meshes(self, read_bytes=None) -> "Cell":
        """Read the mesh shapes' files (read_bytes(name) → bytes for a user's cell; shipped cells
        read data/cells). Errors name the shape and file."""
        import io

        for sh in self.all_shapes():
            if sh.kind != "mesh" or sh.mesh in self._meshes:
                continue
            import trimesh  # here: a cell of boxes and cylinders needs none (0.5 s to import)

            try:
                data = read_bytes(sh.mesh) if read_bytes else (CELLS_DIR / Path(sh.mesh).name).read_bytes()
                m: Any = trimesh.load(
                    io.BytesIO(data), file_type=Path(sh.mesh).suffix.lstrip(".").lower() or "stl", force="mesh"
                )
            except Exception as e:
                raise InputFileError(f"cell {self.name}: shape {sh.name!r}: mesh {sh.mesh!r}: {e}") from e
            if len(m.faces) == 0:
                raise InputFileError(f"cell {self.name}: shape {sh.name!r}: mesh {sh.mesh!r} has no triangles")
            self._meshes[sh.mesh] = (np.asarray(m.vertices, float), np.asarray(m.faces, np.int64))
        return self

    def all_shapes(self) -> list[Shape]:
        return [*self.tool.shapes, *(self.positioner.shapes if self.positioner else []), *self.fixtures]

    def shape_mesh(self, sh: Shape) -> tuple[np.ndarray, np.ndarray]:
        """(vertices mm, faces) of a shape in its own frame (before `pose`): primitives tessellated."""
        import trimesh

        if sh.kind == "box":
            m = trimesh.creation.box(extents=sh.size_mm)
        elif sh.kind == "cylinder":
            m = trimesh.creation.cylinder(radius=sh.size_mm[0], height=sh.size_mm[2], sections=32)
        else:
            if sh.mesh not in self._meshes:
                self.load_meshes()
            v, f = self._meshes[sh.mesh]
            return v * np.asarray(sh.size_mm, float), f
        return np.asarray(m.vertices, float), np.asarray(m.faces, np.int64)


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
    if text is None:  # a shipped name, never a path (core.files)
        text = read_shipped(CELLS_DIR, f"{name_or_path}.json", "cell", shipped_cells(), limit=5_000_000).decode("utf-8")
    try:
        return Cell.model_validate(json.loads(text))
    except json.JSONDecodeError as e:
        raise InputFileError(f"cell {name_or_path}: not JSON ({e.msg}, line {e.lineno})") from e
    except ValidationError as e:
        err = e.errors()[0]
        where = ".".join(str(x) for x in err["loc"])
        raise InputFileError(f"cell {name_or_path}: {where}: {err['msg']}") from e


POLICIES = ("auto", "fixed", "gravity", "min-motion")


def positioner_angles(cell: Cell, moves, policy: str = "fixed", max_tilt_deg: float = 30.0) -> np.ndarray:
    """Positioner angles (deg) at every programmed point, shape (n, axes): see `plan_positioner`."""
    return plan_positioner(cell, moves, policy, max_tilt_deg)[0]


def positioner_and_torch(
    cell: Cell, moves, policy: str = "fixed", max_tilt_deg: float = 30.0, limits=None
) -> tuple[np.ndarray, np.ndarray]:
    """What a program on this cell must carry: the positioner angles (n, axes) deg and the
    part-frame torch axes (n, 3) — the toolpath's own, or under `auto` the plan's, with the torch
    lean it chose on the layers that needed one (a program written with the toolpath's axes there
    would weld un-leaned where the plan verified only the leaned torch)."""
    if policy == "auto":
        return _auto_plan(cell, moves, limits)
    return plan_positioner(cell, moves, policy, max_tilt_deg)[0], np.asarray(moves.tool_axis, float)


def plan_positioner(
    cell: Cell, moves, policy: str = "fixed", max_tilt_deg: float = 30.0
) -> tuple[np.ndarray, np.ndarray]:
    """Positioner angles (deg) at every programmed point, (n, axes) — E1 (tilt), E2 (rotate) for
    the usual 2-axis positioner, E1 alone for a 1-axis one — and per point whether the policy's
    angle lay outside an axis limit and was clipped into it (n,) bool.

    `fixed`: `positioner.fixed_deg` throughout. `gravity`: each layer turned so its mean layer
    normal n = −torch axis (arc-ON segments) points straight up (world +z), the flat welding
    position of the curved-parts study. With the joint axes w1, w2 in the world at the zero pose
    and R0 the work frame's rotation there, the work frame turns as Rot(w1,e1)·Rot(w2,e2)·R0, so
    Rot(w1,e1)·Rot(w2,e2)·(R0 n) = +z is Paden–Kahan subproblem 2 (two solutions; the closest
    reachable orientation when none is exact); a 1-axis positioner solves subproblem 1 (the angle
    that brings n closest to vertical). Among the solutions, with ±360° shifts, inside the limits
    the one nearest the previous layer's angles is taken (ties: the larger first axis), E2 kept
    when n lies along it. `min-motion`: a layer keeps the previous layer's angles (fixed_deg for
    the first) while its normal stays within `max_tilt_deg` of vertical under them, else it takes
    its gravity angles. Angles are constant along a layer, so the positioner moves only on the
    arc-OFF travel between layers. A point takes the angles of the arc-ON segment it ends (else of
    the segment it starts).

    `auto`: planned per layer with the arm's IK and the collision checks (`trajectory.cellplan`,
    default process limits); a plan that fails is a PlanningError naming the layer and the
    verified cell changes."""
    if policy not in POLICIES:
        raise InputFileError(f"positioner policy {policy!r}: use one of {', '.join(POLICIES)}")
    if policy == "auto":
        return _auto_plan(cell, moves)[0], np.zeros(len(moves.points), bool)
    n = len(moves.points)
    fixed = cell.fixed_angles()
    m = len(fixed)
    if policy == "fixed" or m == 0 or n < 2 or cell.positioner is None:
        return np.tile(fixed, (n, 1)), np.zeros(n, bool)
    pk = positioner_kin(cell.positioner.urdf)
    lo, hi = pk.lower_deg, pk.upper_deg
    Rb = _rz(cell.positioner.base.yaw_deg)
    w = pk.axes_base(cell.positioner.flange) @ Rb.T
    R0 = cell.work_pose(np.zeros(m))[0]
    seg_layer = np.asarray(moves.layer)
    arc = np.asarray(moves.arc, bool)
    axes = np.asarray(moves.tool_axis, float)
    layer_angles: dict[int, tuple[np.ndarray, bool]] = {}
    prev = fixed.copy()
    up = np.array([0.0, 0.0, 1.0])
    # each layer's segments in ascending order (what a mask seg_layer == L selects), by one sort
    layers, counts = np.unique(seg_layer, return_counts=True)
    order = np.argsort(seg_layer, kind="stable")
    bounds = np.concatenate([[0], np.cumsum(counts)])
    for k, L in enumerate(layers.tolist()):
        mine = order[bounds[k] : bounds[k + 1]]
        segs = mine[arc[mine]]
        if len(segs) == 0:
            segs = mine
        nrm = -axes[segs].mean(axis=0)
        nrm /= max(np.linalg.norm(nrm), 1e-12)
        if policy == "min-motion":
            lean = cell.work_pose(prev)[0] @ nrm
            if math.degrees(math.acos(float(np.clip(lean[2], -1.0, 1.0)))) <= max_tilt_deg + 1e-9:
                layer_angles[L] = (prev, False)
                continue
        sols = [np.degrees(s) for s in _gravity_solutions(w, R0 @ nrm, up)]
        if len(sols) == 1 and m == 2 and np.linalg.norm(np.cross(R0 @ nrm, w[1])) < 1e-6:
            sols[0][1] = prev[1]  # n along the turntable axis: E2 free, kept
        prev, out = _nearest(sols, prev, lo, hi)
        layer_angles[L] = (prev, out)
    # a point takes the layer of the arc-ON segment it ends, else of the segment it starts
    i = np.arange(n)
    s = np.minimum(i, n - 2)
    ends_arc = np.zeros(n, bool)
    ends_arc[1:] = arc[: n - 1]
    s[ends_arc] = i[ends_arc] - 1
    row = np.searchsorted(layers, seg_layer[s])
    table = np.array([layer_angles[L][0] for L in layers.tolist()], float).reshape(len(layers), m)
    outside = np.array([layer_angles[L][1] for L in layers.tolist()], bool)
    return table[row], outside[row]


def _auto_plan(cell: Cell, moves, limits=None) -> tuple[np.ndarray, np.ndarray]:
    """The `auto` plan's angles and torch axes for a writer (post-process): the same plan
    simulate-robot makes with the default limits and spacings."""
    if cell.axes == 0 or len(moves.points) < 2:
        return np.tile(cell.fixed_angles(), (len(moves.points), 1)), np.asarray(moves.tool_axis, float)
    from ..core.errors import PlanningError
    from .cellplan import AutoLimits, plan_auto
    from .kinematics import load_arm
    from .run import auto_failure_text

    arm = load_arm(cell.robot_urdf, tuple(cell.tool.tcp_mm), home_deg=cell.robot_home_deg)
    plan = plan_auto(cell.load_meshes(), moves, arm, limits or AutoLimits())
    if not plan.ok:
        raise PlanningError(auto_failure_text(cell, plan), layer=(plan.failed or {}).get("layer"))
    return plan.angles, plan.tool_axis


def xyz3(v) -> tuple[float, float, float]:
    """Three numbers (a point or a matrix row) as a tuple of floats."""
    return float(v[0]), float(v[1]), float(v[2])


def _sp1(w: np.ndarray, u: np.ndarray, v: np.ndarray) -> float:
    """Angle (rad) of the rotation about unit w taking u closest to v (Paden–Kahan subproblem 1)."""
    up = u - w * (w @ u)
    vp = v - w * (w @ v)
    return math.atan2(float(w @ np.cross(up, vp)), float(up @ vp))


def _gravity_solutions(w: np.ndarray, p: np.ndarray, q: np.ndarray) -> list[np.ndarray]:
    """Angles (rad) with Rot(w1,e1)·Rot(w2,e2)·p = q (1 or 2 axes; the closest when unreachable)."""
    if len(w) == 1:
        return [np.array([_sp1(w[0], p, q)])]
    w1, w2 = w
    if np.linalg.norm(np.cross(p, w2)) < 1e-6:  # p along the turntable axis: E2 free
        return [np.array([_sp1(w1, p, q), 0.0])]
    c12 = float(w1 @ w2)
    den = c12 * c12 - 1.0
    if abs(den) < 1e-12:  # parallel axes: one effective axis
        return [np.array([_sp1(w1, p, q), 0.0])]
    al = (c12 * (w2 @ p) - w1 @ q) / den
    be = (c12 * (w1 @ q) - w2 @ p) / den
    nn = np.cross(w1, w2)
    g2 = (p @ p - al * al - be * be - 2 * al * be * c12) / (nn @ nn)
    out = []
    for g in [math.sqrt(g2), -math.sqrt(g2)] if g2 > 1e-12 else [0.0]:
        c = al * w1 + be * w2 + g * nn
        out.append(np.array([_sp1(w1, c, q), _sp1(w2, p, c)]))
    return out


def _nearest(cands: list[np.ndarray], prev: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, bool]:
    """The candidate (deg, with ±360° shifts per axis) nearest `prev` inside the limits (ties: the
    larger first axis); none inside → the nearest clipped into them, flagged."""
    best, best_key, clipped = None, None, True
    for c in cands:
        v, inside = np.empty(len(c)), True
        for j in range(len(c)):
            k0 = round((prev[j] - c[j]) / 360.0)
            opts = [c[j] + 360.0 * k for k in (k0 - 1, k0, k0 + 1)]
            ok = [o for o in opts if lo[j] - 1e-7 <= o <= hi[j] + 1e-7]
            inside &= bool(ok)
            v[j] = min(ok or opts, key=lambda o: abs(o - prev[j]))
        key = (not inside, round(float(np.abs(v - prev).sum()), 6), -round(float(v[0]), 6))
        if best_key is None or key < best_key:
            best, best_key, clipped = v, key, not inside
    if best is None:
        raise ValueError("no candidate positioner angles")
    return np.clip(best, lo, hi), clipped


def to_world(cell: Cell, points: np.ndarray, axes: np.ndarray, angles_deg: np.ndarray):
    """Part-frame points and torch axes (n, 3) → world, each with its own positioner angles."""
    P, A = np.asarray(points, float), np.asarray(axes, float)
    pts = np.empty_like(P)
    ax = np.empty_like(A)
    ang = np.asarray(angles_deg, float).reshape(len(pts), -1)
    uniq, inv = np.unique(np.round(ang, 9), axis=0, return_inverse=True)
    # the rows of each angle set in ascending order (what a mask inv == j selects), found by one sort
    order = np.argsort(inv.ravel(), kind="stable")
    bounds = np.searchsorted(inv.ravel()[order], np.arange(len(uniq) + 1))
    for j, a in enumerate(uniq):
        R, t = cell.work_pose(a)
        m = order[bounds[j] : bounds[j + 1]]
        pts[m] = P[m] @ R.T + t
        ax[m] = A[m] @ R.T
    return pts, ax


def coordinated_samples(
    cell: Cell,
    points: np.ndarray,
    axes: np.ndarray,
    angles_deg: np.ndarray,
    step_mm: float = 5.0,
    step_deg: float = 1.0,
):
    """IK samples of a coordinated move (KUKA/ABB coordinated motion: the TCP moves linearly in the
    part frame while the external axes interpolate linearly between targets). Each programmed
    segment gets ceil(max(L/step_mm, |Δangle|/step_deg, |Δtorch axis|/step_deg)) samples
    (vertices included), so a positioner turn on a short travel is followed in ≤ step_deg steps
    and the wrist never sees a jump. At each sample: part point and torch axis interpolated
    (the axis normalised), positioner angles interpolated, then turned into the world with the
    work frame at those angles.
    Returns s (k,) programmed arc length mm, world xyz (k, 3), world torch axes (k, 3),
    seg (k,), angles (k, axes)."""
    P = np.asarray(points, float)
    A = np.asarray(axes, float)
    E = np.asarray(angles_deg, float).reshape(len(P), -1)
    L = np.linalg.norm(np.diff(P, axis=0), axis=1)
    dE = np.abs(np.diff(E, axis=0)).max(axis=1, initial=0.0)
    dA = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", A[:-1], A[1:]), -1.0, 1.0)))
    counts = np.maximum(1, np.ceil(np.maximum.reduce([L / step_mm, dE / step_deg, dA / step_deg]) - 1e-9)).astype(int)
    seg = np.repeat(np.arange(len(L)), counts)
    frac = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / np.repeat(counts, counts)
    seg = np.concatenate([seg, [len(L) - 1]])
    frac = np.concatenate([frac, [1.0]])
    f = frac[:, None]
    pts = P[seg] + f * (P[seg + 1] - P[seg])
    ax = A[seg] + f * (A[seg + 1] - A[seg])
    ax /= np.maximum(np.linalg.norm(ax, axis=1, keepdims=True), 1e-12)
    ang = E[seg] + f * (E[seg + 1] - E[seg])
    s0 = np.concatenate([[0.0], np.cumsum(L)])
    s = s0[seg] + frac * L[seg]
    xyz, axw = to_world(cell, pts, ax, ang)
    return s, xyz, axw, seg, ang


def positioner_caps(cell: Cell, points: np.ndarray, angles_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per programmed segment: the path speed (mm/s) at which a positioner axis reaches its URDF
    speed (inf when no axis moves) — ω·L/|Δangle|, the smallest over the axes — and the time (s)
    the positioner needs for the segment's turn (max |Δangle|/ω; what a zero-length segment,
    e.g. a turn in place, must wait)."""
    P = np.asarray(points, float)
    n = len(P)
    if cell.axes == 0 or n < 2 or cell.positioner is None:
        return np.full(max(n - 1, 0), np.inf), np.zeros(max(n - 1, 0))
    w = positioner_kin(cell.positioner.urdf).speed_deg_s
    d = np.abs(np.diff(np.asarray(angles_deg, float).reshape(n, -1), axis=0))
    L = np.linalg.norm(np.diff(P, axis=0), axis=1)
    need = (d / np.maximum(w, 1e-12)).max(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        cap = np.where(need > 1e-12, L / np.maximum(need, 1e-300), np.inf)
    return cap, need
