"""The arm along the simulated trace, for playback: joint origins in world mm at sampled times.

The shipped URDFs carry kinematics only (no link meshes), so the arm is drawn with primitive link
geometry: a cylinder between consecutive joint origins, thick at the base and thinner towards
the wrist, and a slim torch from the flange to the TCP (`link_mesh`), plus the stick figure
through the joint origins. Inverse kinematics reuses `waamflow.trajectory.kinematics` (Pinocchio,
continuous damped least squares seeded from the previous sample), solved at up to `max_samples`
trace samples evenly spread in time — display only; the simulation's own figures are untouched.
Cell set-up (robot, TCP offset, base and work frames) comes from the simulate node's params,
then the simulation's robot profile, then the kinematics module's defaults.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True, eq=False)
class RobotMotion:
    """t: (k,) s. joints: (k, m, 3) world mm — base, each joint origin, flange, TCP, in chain
    order. reach_err: (k,) IK position residual, mm. name: URDF file name."""

    t: np.ndarray
    joints: np.ndarray
    reach_err: np.ndarray
    name: str

    def at(self, t: float) -> np.ndarray:
        """(m, 3) joint origins at time t (s), linearly blended between the two IK samples around
        t (display only: between samples a few mm apart the blend is indistinguishable)."""
        k = len(self.t)
        i = int(np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, k - 1))
        if i + 1 >= k or self.t[i + 1] <= self.t[i] or t <= self.t[i]:
            return self.joints[i]
        f = min((t - self.t[i]) / (self.t[i + 1] - self.t[i]), 1.0)
        return self.joints[i] * (1 - f) + self.joints[i + 1] * f

    def body(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Link geometry at time t: (vertices, faces) of `link_mesh`."""
        return link_mesh(self.at(t))

    def segments(self, t: float) -> np.ndarray:
        """(m - 1, 2, 3) float32 links of the stick figure at time t."""
        p = self.at(t).astype(np.float32)
        return np.stack([p[:-1], p[1:]], axis=1)


# Link radii, mm, for the primitive arm: an industrial arm of ~2.7 m reach is ~250 mm thick at the
# base and ~100 mm at the wrist; the torch neck is ~30 mm. Display only.
LINK_RADIUS_MM = (130.0, 110.0, 90.0, 70.0, 55.0, 45.0, 40.0, 35.0)
TORCH_RADIUS_MM = 15.0
SIDES = 12


def _cylinder_faces(n_links: int, sides: int = SIDES) -> np.ndarray:
    """(n_links * 2 * sides, 3) uint32 triangles of `n_links` open tubes with end caps left out."""
    k = np.arange(sides)
    a, b = k, (k + 1) % sides
    one = np.concatenate([np.stack([a, b, a + sides], 1), np.stack([b, b + sides, a + sides], 1)])
    return np.concatenate([one + 2 * sides * i for i in range(n_links)]).astype(np.uint32)


def link_mesh(points: np.ndarray, sides: int = SIDES) -> tuple[np.ndarray, np.ndarray]:
    """Tubes along the chain `points` (m, 3) mm: (vertices (2·sides·(m−1), 3) float32, faces).
    The last link (flange → TCP) is the torch. The vertex count depends only on m, so playback
    moves the same mesh by replacing its vertices. A zero-length link collapses to a ring."""
    pts = np.asarray(points, float)
    n = len(pts) - 1
    ang = 2 * np.pi * np.arange(sides) / sides
    verts = np.empty((n, 2, sides, 3))
    for i in range(n):
        p0, p1 = pts[i], pts[i + 1]
        axis = p1 - p0
        length = np.linalg.norm(axis)
        w = axis / length if length > 1e-9 else np.array([0.0, 0.0, 1.0])
        ref = np.array([1.0, 0.0, 0.0]) if abs(w[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        u = np.cross(w, ref)
        u /= np.linalg.norm(u)
        v = np.cross(w, u)
        r = TORCH_RADIUS_MM if i == n - 1 else LINK_RADIUS_MM[min(i, len(LINK_RADIUS_MM) - 1)]
        ring = r * (np.cos(ang)[:, None] * u + np.sin(ang)[:, None] * v)
        verts[i, 0] = p0 + ring
        verts[i, 1] = p1 + ring
    return verts.reshape(-1, 3).astype(np.float32), _cylinder_faces(n, sides)


def cell_setup(params: dict[str, Any], profile: dict[str, Any]) -> dict[str, Any]:
    """Robot description and frames: node params over the robot profile over the defaults."""
    from ..trajectory.kinematics import CellFrames

    d = CellFrames()

    def pick(key: str, default: Any) -> Any:
        return params.get(key) if params.get(key) not in (None, "") else profile.get(key, default)

    return {
        "description": pick("robot_description", None) or profile.get("description") or "",
        "tcp_offset_mm": tuple(pick("tcp_offset_mm", (0.0, 0.0, 400.0))),
        "base_xyz_mm": tuple(pick("base_xyz_mm", d.base_xyz_mm)),
        "base_yaw_deg": float(pick("base_yaw_deg", d.base_yaw_deg)),
        "work_xyz_mm": tuple(pick("work_xyz_mm", d.work_xyz_mm)),
    }


def robot_motion(trace: dict[str, np.ndarray], setup: dict[str, Any], max_samples: int = 600) -> RobotMotion:
    """Solve the arm along the trace (see module doc). Raises if the robot cannot be loaded."""
    import pinocchio as pin

    from ..trajectory.kinematics import CellFrames, load_arm, solve_path

    if not setup.get("description"):
        raise ValueError("no robot description (URDF) in the simulation's profile or params")
    arm = load_arm(setup["description"], tcp_offset_mm=setup["tcp_offset_mm"])
    t = np.asarray(trace["t"], float)
    pts = np.column_stack([np.asarray(trace[k], float) for k in ("x", "y", "z")])
    idx = np.unique(np.linspace(0, len(t) - 1, min(max_samples, len(t))).round().astype(int))
    idx = idx[np.r_[True, np.linalg.norm(np.diff(pts[idx], axis=0), axis=1) > 1e-6]]  # IK needs moves
    sample = pts[idx]
    frames = CellFrames(
        base_xyz_mm=setup["base_xyz_mm"], base_yaw_deg=setup["base_yaw_deg"], work_xyz_mm=setup["work_xyz_mm"]
    )
    seglen = np.linalg.norm(np.diff(sample, axis=0), axis=1)
    step = float(seglen.max()) + 1.0 if len(seglen) else 1.0  # one IK sample per vertex
    axes = np.tile([0.0, 0.0, -1.0], (len(sample), 1))
    kin = solve_path(arm, sample, axes, frames, step_mm=step)
    model = arm.model
    data = model.createData()
    Rb = pin.utils.rotate("z", np.radians(frames.base_yaw_deg))
    offset = np.asarray(frames.base_xyz_mm, float) - np.asarray(frames.work_xyz_mm, float)
    tool0 = model.getFrameId("tool0") if model.existFrame("tool0") else None
    chain = []
    for q in kin.q:
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        p = [np.zeros(3)] + [data.oMi[j].translation.copy() for j in range(1, model.njoints)]
        if tool0 is not None:
            p.append(data.oMf[tool0].translation.copy())
        p.append(data.oMf[arm.tcp].translation.copy())
        chain.append(np.asarray(p))
    joints = 1000.0 * np.asarray(chain) @ Rb.T + offset  # base frame (m) → toolpath frame (mm)
    n = min(len(joints), len(idx))  # one IK sample per trace sample (step > longest move)
    return RobotMotion(t[idx[:n]], joints[:n], np.asarray(kin.reach_err)[:n], setup["description"])


# ------------------------------------------------------------------------------------------------
# The whole cell (simulate-robot with a cell file): arm, torch, positioner, table and fixtures in
# the world, the part on the positioner, all replayed from the simulation's own solution.


@dataclass(frozen=True, eq=False)
class CellMotion:
    """The cell at k playback samples (times `t`, s). chain: (k, m, 3) world mm — arm base, joint
    origins, flange, TCP; tool: (k, 3, 3) and (k, 3) the flange pose; work: the part frame's
    pose (rotation (k, 3, 3), translation (k, 3) mm) — the positioner turning the part; links:
    positioner link → pose arrays like `work`; angles: (k, axes) positioner deg; unreachable:
    (k,) bool the IK missed the sample; cell: the `trajectory.cell.Cell`."""

    t: np.ndarray
    chain: np.ndarray
    tool: tuple[np.ndarray, np.ndarray]
    work: tuple[np.ndarray, np.ndarray]
    links: dict[str, tuple[np.ndarray, np.ndarray]]
    angles: np.ndarray
    unreachable: np.ndarray
    cell: Any
    name: str

    def index(self, t: float) -> int:
        return int(np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.t) - 1))

    def body(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The arm's link tubes at time t (world mm); the last link (flange → TCP) is left to the
        cell's torch shapes."""
        return link_mesh(self.chain[self.index(t)][:-1])

    def segments(self, t: float) -> np.ndarray:
        p = self.chain[self.index(t)].astype(np.float32)
        return np.stack([p[:-1], p[1:]], axis=1)

    @property
    def reach_err(self) -> np.ndarray:
        return np.where(self.unreachable, np.inf, 0.0)


def programmed_s(value) -> np.ndarray:
    """(n,) programmed arc length (mm) of each trace sample: its programmed segment's start plus
    its projection on the segment (the key to the kinematic solution, which is sampled along
    programmed arc length)."""
    tr = value.trace
    dep = value.deposit
    seg = np.asarray(tr["segment"], np.int64)
    prog = np.asarray(value.programmed, float)
    a, b = prog[seg], prog[seg + 1]
    p = np.column_stack([np.asarray(tr[k], float) for k in ("x", "y", "z")])
    ab = b - a
    f = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12), 0.0, 1.0)
    return np.asarray(dep["s_mm"], float)[seg] + f * np.asarray(dep["length_mm"], float)[seg]


def cell_motion(value, max_samples: int = 600) -> CellMotion:
    """Replay a cell simulation: at up to `max_samples` trace times, the simulation's joint angles
    and positioner angles (interpolated in programmed arc length), then forward kinematics of
    the arm and the positioner. Raises when the result carries no cell motion."""
    import pinocchio as pin

    from ..trajectory.cell import Cell
    from ..trajectory.kinematics import load_arm

    mot = (getattr(value, "kinematics", None) or {}).get("motion")
    if not mot:
        raise ValueError("the simulation carries no cell motion")
    cell = Cell.model_validate(mot["cell"])
    arm = load_arm(cell.robot_urdf, cell.tool.tcp_mm, home_deg=cell.robot_home_deg)
    t = np.asarray(value.trace["t"], float)
    idx = np.unique(np.linspace(0, len(t) - 1, min(max_samples, len(t))).round().astype(int))
    sp = programmed_s(value)[idx]
    s = np.asarray(mot["s"], float)
    q = np.column_stack([np.interp(sp, s, np.asarray(mot["q"])[:, j]) for j in range(arm.model.nq)])
    ang_s = np.asarray(mot["positioner_deg"], float).reshape(len(s), -1)
    ang = (
        np.column_stack([np.interp(sp, s, ang_s[:, j]) for j in range(ang_s.shape[1])])
        if ang_s.shape[1]
        else np.zeros((len(sp), 0))
    )
    bad = np.interp(sp, s, np.asarray(mot["unreachable"], float)) > 0.5
    model, data = arm.model, arm.model.createData()
    yaw = np.radians(cell.robot_base.yaw_deg)
    Rb = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    tb = np.asarray(cell.robot_base.xyz_mm, float)
    tool0 = model.getFrameId("tool0")
    chain, tR, tP = [], [], []
    for qi in q:
        pin.forwardKinematics(model, data, qi)
        pin.updateFramePlacements(model, data)
        pts = [np.zeros(3)] + [data.oMi[j].translation * 1000.0 for j in range(1, model.njoints)]
        pts += [data.oMf[tool0].translation * 1000.0, data.oMf[arm.tcp].translation * 1000.0]
        chain.append(np.asarray(pts) @ Rb.T + tb)
        tR.append(Rb @ data.oMf[tool0].rotation)
        tP.append(Rb @ data.oMf[tool0].translation * 1000.0 + tb)
    names = {sh.link for sh in (cell.positioner.shapes if cell.positioner else [])} | {
        sh.link for sh in cell.fixtures if sh.link
    }
    links: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    work_R, work_t = [], []
    lp: dict[str, tuple[list[Any], list[Any]]] = {n: ([], []) for n in names}
    for a in ang:
        R, tw = cell.work_pose(a)
        work_R.append(R)
        work_t.append(tw)
        for n in names:
            Rl, tl = cell.link_pose(a, n)
            lp[n][0].append(Rl)
            lp[n][1].append(tl)
    for n, (Rs, ts) in lp.items():
        links[n] = (np.asarray(Rs), np.asarray(ts))
    return CellMotion(
        t[idx],
        np.asarray(chain),
        (np.asarray(tR), np.asarray(tP)),
        (np.asarray(work_R), np.asarray(work_t)),
        links,
        ang,
        bad,
        cell,
        cell.name,
    )


def shape_arrays(cell, sh) -> tuple[np.ndarray, np.ndarray]:
    """(vertices float32 mm, faces uint32) of a cell shape in its link frame (its own pose applied)."""
    v, f = cell.shape_mesh(sh)
    R, t = sh.pose()
    return (np.asarray(v, float) @ R.T + t).astype(np.float32), np.asarray(f, np.uint32)


def wxyz(R: np.ndarray) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(R).as_quat()
    return (float(w), float(x), float(y), float(z))
