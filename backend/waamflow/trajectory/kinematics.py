"""Robot kinematics with Pinocchio: continuous IK along the path, joint limits, speed caps, warnings.

The arm is built from a URDF shipped in `waamflow/data/robots/` (or a user's). The TCP is the
`tool0` flange frame shifted by `tcp_offset_mm` along its own axes (tool z = torch axis, pointing
from the torch towards the part). Cell frames (all mm / degrees):

    world point = work_xyz + R_work p_toolpath           (work frame: where the part sits; R_work
                                                          from a cell's positioner angles, else I)
    robot base  = translation base_xyz, rotation base_yaw_deg about world z

IK: damped least squares on a 5-D task in the TCP frame (LOCAL Jacobian rows): position (3)
and the torch axis direction (2) — the rotation about the torch axis is free, as for a round
welding torch — seeded from the previous point so the solution stays on one branch
(continuous); a sample that has not converged after the usual few iterations gets up to 40 more. Joint speeds are finite differences of q along arc length: dq/ds (rad/mm), so the path
speed at which joint i reaches its limit is qd_max_i / |dq_i/ds| — the per-segment speed cap.

IK is solved on the programmed polyline resampled every `step_mm` (vertices included) rather
than every interpolation cycle: joint motion between samples is smooth for steps well below the
arm's link lengths (1 m) and the cap is a minimum over the samples of each segment.

Units: mm, s, rad inside Pinocchio (m), reported in degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.errors import InputFileError
from ..core.files import read_shipped
from .profile import ROBOTS_DIR

if TYPE_CHECKING:  # imported where used: keeps `waamflow nodes` light
    import pinocchio as pin

SINGULAR_SIGMA = 0.02  # smallest singular value of the 5x6 task Jacobian (m or rad per rad) below which we warn
REACH_TOL_MM = 0.5  # IK position residual above which a point is unreachable
LIMIT_MARGIN = 1e-3  # rad
SIGMA_BOUND = 1000.0  # c in `smallest_singular_values`' bound c·ε·‖J‖²_F on |λ̂ − σ²|
CONVERGED = 1e-12  # squared 5-D IK error: 1 µm / 1 µrad — far below any robot's repeatability


@dataclass(frozen=True, eq=False)
class Arm:
    """A Pinocchio model of the arm with its TCP frame id and limits (rad, rad/s)."""

    model: pin.Model
    tcp: int
    lower: np.ndarray
    upper: np.ndarray
    qd_max: np.ndarray
    home: np.ndarray
    name: str


def shipped_descriptions() -> list[str]:
    """File names of the arm URDFs shipped in waamflow/data/robots."""
    return sorted(p.name for p in ROBOTS_DIR.glob("*.urdf"))


def load_arm(description: str, tcp_offset_mm=(0.0, 0.0, 400.0), urdf_text: str | None = None, home_deg=None) -> Arm:
    """Build the arm from a shipped URDF name (file in data/robots) or URDF text. home_deg: the IK
    seed pose (default: KUKA-style upright with the wrist down, 0 −90 90 0 90 0)."""
    import pinocchio as pin  # lazy: keeps start-up light

    if urdf_text is None:  # a shipped name, never a path (core.files: '/dev/zero' is refused unread)
        urdf_text = read_shipped(
            ROBOTS_DIR, description, "robot description", shipped_descriptions(), limit=20_000_000
        ).decode("utf-8")
    try:
        model = pin.buildModelFromXML(urdf_text)
    except Exception as e:  # pinocchio raises ValueError/RuntimeError on bad XML
        raise InputFileError(f"robot description {description}: {e}") from e
    if not model.existFrame("tool0"):
        raise InputFileError(f"robot description {description}: needs a 'tool0' frame")
    flange = model.getFrameId("tool0")
    fr = model.frames[flange]
    offset = pin.SE3(np.eye(3), np.asarray(tcp_offset_mm, float) / 1000.0)
    tcp = model.addFrame(
        pin.Frame(
            "tcp",
            fr.parentJoint,
            fr.parentFrame if hasattr(fr, "parentFrame") else flange,
            fr.placement * offset,
            pin.FrameType.OP_FRAME,
        )
    )
    home_deg = [0.0, -90.0, 90.0, 0.0, 90.0, 0.0] if home_deg is None else list(home_deg)
    if len(home_deg) < model.nq:
        raise InputFileError(
            f"robot description {description}: home pose has {len(home_deg)} angles for {model.nq} joints"
        )
    home = np.clip(np.radians(home_deg)[: model.nq], model.lowerPositionLimit, model.upperPositionLimit)
    return Arm(
        model,
        tcp,
        model.lowerPositionLimit.copy(),
        model.upperPositionLimit.copy(),
        model.velocityLimit.copy(),
        home,
        Path(description).stem,
    )


@dataclass(frozen=True)
class CellFrames:
    """base_xyz_mm: robot base in world, base_yaw_deg about z; work_xyz_mm: part origin in world;
    The torch's rotation about its own axis is left free (5-D task)."""

    base_xyz_mm: tuple[float, float, float] = (-1500.0, 0.0, -600.0)
    base_yaw_deg: float = 0.0
    work_xyz_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    work_rot: tuple[tuple[float, float, float], ...] | None = (
        None  # work frame rotation in world (3x3), None = identity
    )


@dataclass(frozen=True, eq=False)
class KinematicsResult:
    """s: (k,) programmed arc length of the IK samples, mm. q: (k, nq) joint angles, rad.
    seg: (k,) programmed segment of each sample. reach_err: (k,) IK position residual, mm.
    sigma_min: (k,) smallest Jacobian singular value. segment_cap: (n-1,) path speed (mm/s) at
    which a joint reaches its speed limit, per programmed segment (inf if none).
    issues: list of dicts {kind, layer, section, s_from, s_to, count, detail}."""

    s: np.ndarray
    q: np.ndarray
    seg: np.ndarray
    reach_err: np.ndarray
    sigma_min: np.ndarray
    segment_cap: np.ndarray
    issues: list = field(default_factory=list)


def resample(points: np.ndarray, step_mm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Polyline (n, 3) → samples every ≤ step_mm including vertices: (s (k,), xyz (k, 3), seg (k,))."""
    L = np.linalg.norm(np.diff(points, axis=0), axis=1)
    counts = np.maximum(1, np.ceil(L / step_mm).astype(int))
    seg = np.repeat(np.arange(len(L)), counts)
    frac = (
        np.concatenate([np.arange(c) / c for c in counts])
        if len(counts) < 50000
        else (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / np.repeat(counts, counts)
    )
    xyz = points[seg] + frac[:, None] * (points[seg + 1] - points[seg])
    s0 = np.concatenate([[0.0], np.cumsum(L)])
    s = s0[seg] + frac * L[seg]
    xyz = np.vstack([xyz, points[-1:]])
    s = np.concatenate([s, [s0[-1]]])
    seg = np.concatenate([seg, [len(L) - 1]])
    return s, xyz, seg


def solve_path(
    arm: Arm,
    points: np.ndarray,
    tool_axis: np.ndarray,
    frames: CellFrames = CellFrames(),
    step_mm: float = 5.0,
    q_seed: np.ndarray | None = None,
    iters: int = 6,
    progress=None,
) -> KinematicsResult:
    """Continuous DLS IK along a polyline (world/work mm) — see the module doc.
    progress: optional callable(fraction 0..1) called every 2000 samples."""
    s, xyz, seg = resample(np.asarray(points, float), step_mm)
    axes = np.asarray(tool_axis, float)
    ax = axes[seg] if len(axes) == len(points) else np.tile([0.0, 0.0, -1.0], (len(s), 1))
    return solve_samples(arm, s, xyz, seg, ax, len(points) - 1, frames, q_seed=q_seed, iters=iters, progress=progress)


def _in_base(xyz, ax, frames: CellFrames) -> tuple[np.ndarray, np.ndarray]:
    """Targets (k, 3) mm and torch axes (k, 3) in the work frame → robot base frame: points in m,
    unit axes."""
    import pinocchio as pin  # lazy: keeps start-up light

    xyz, ax = np.asarray(xyz, float), np.asarray(ax, float)
    Rb = pin.utils.rotate("z", np.radians(frames.base_yaw_deg))
    if frames.work_rot is not None:  # part turned by a positioner
        Rw = np.asarray(frames.work_rot, float)
        xyz, ax = xyz @ Rw.T, ax @ Rw.T
    p_base = ((xyz + np.asarray(frames.work_xyz_mm)) - np.asarray(frames.base_xyz_mm)) @ Rb / 1000.0
    z_base = ax @ Rb  # torch axes in the base frame
    z_base /= np.linalg.norm(z_base, axis=1, keepdims=True)
    return p_base, z_base


def solve_samples(
    arm: Arm,
    s: np.ndarray,
    xyz: np.ndarray,
    seg: np.ndarray,
    ax: np.ndarray,
    nseg: int,
    frames: CellFrames = CellFrames(),
    q_seed: np.ndarray | None = None,
    iters: int = 6,
    progress=None,
    stop_unreachable: bool = False,
) -> KinematicsResult:
    """`solve_path` on given samples: s (k,) programmed arc length, xyz (k, 3) and torch axes
    ax (k, 3) in the work/world frame, seg (k,) their programmed segment (of nseg).
    stop_unreachable: stop at the first unreachable sample (a planner's yes/no; the result then
    holds the samples up to it)."""
    import pinocchio as pin  # lazy: keeps start-up light

    model = arm.model
    data = model.createData()
    p_base, z_base = _in_base(xyz, ax, frames)
    k = len(s)
    Q = np.zeros((k, model.nq))
    err_mm = np.zeros(k)
    q = arm.home.copy() if q_seed is None else np.asarray(q_seed, float).copy()
    Js = np.zeros((k, 5, model.nv))
    mid, roll = _wrist_roll_pull(arm, model.nv)
    lower, upper = arm.lower, arm.upper
    # the loop runs ~2 iterations per sample over tens of thousands of samples: bound methods,
    # scalar maths on Python floats and LAPACK's Cholesky solve (J·Jᵀ + λ²I is symmetric positive
    # definite) instead of np.linalg.solve keep its overhead down (the same iteration as before)
    fk, upd, jac = pin.forwardKinematics, pin.updateFramePlacement, pin.computeFrameJacobian
    LOCAL, tcp, dposv = pin.LOCAL, arm.tcp, lapack_dposv()
    lam_eye = 1e-4 * np.eye(5)  # λ² = 1e-4
    rhs = np.empty((5, 2))
    e = np.empty(5)
    Z = z_base.tolist()
    retry = 40
    atan2, sqrt = math.atan2, math.sqrt
    last = None  # (TCP rotation rows, Rᵀ, translation, J, Jᵀ) where the previous sample converged
    for i in range(k):
        if progress is not None and i % 2000 == 0:
            progress(i / k)
        pt = p_base[i]
        zt0, zt1, zt2 = Z[i]
        n_it = 80 if i == 0 else iters
        it = 0
        while True:
            if it == 0 and last is not None:  # q unchanged since the previous sample's last FK
                rows, RcT, tr, J, JT = last  # its pose as read then (no FK or read in between)
            else:
                fk(model, data, q)
                cur = upd(model, data, tcp)
                Rc = cur.rotation
                RcT = Rc.T
                rows = Rc.tolist()
                tr = cur.translation
                J = None
            (r00, r01, zc0), (r10, r11, zc1), (r20, r21, zc2) = rows
            # rotation (axis · angle) that aligns the torch axis
            w0, w1, w2 = zc1 * zt2 - zc2 * zt1, zc2 * zt0 - zc0 * zt2, zc0 * zt1 - zc1 * zt0
            sw = sqrt(w0 * w0 + w1 * w1 + w2 * w2)
            dp = pt - tr
            e[:3] = RcT @ dp
            if sw > 1e-12:
                f = atan2(sw, zc0 * zt0 + zc1 * zt1 + zc2 * zt2) / sw
                e[3] = (r00 * w0 + r10 * w1 + r20 * w2) * f
                e[4] = (r01 * w0 + r11 * w1 + r21 * w2) * f
            else:
                e[3] = e[4] = 0.0
            if J is None:
                J = jac(model, data, q, tcp, LOCAL)[:5]
                JT = J.T
            it += 1
            ee = float(e @ e)
            if ee < CONVERGED or it > n_it + (retry if ee > 1e-8 else 0):
                last = (rows, RcT, tr, J, JT)
                break
            # damped least squares + null-space pull of the wrist rolls: one solve, two right-hand sides
            r = roll * (mid - q)
            rhs[:, 0] = e
            rhs[:, 1] = J @ r
            sol = dposv(J @ JT + lam_eye, rhs)[1]
            q = np.minimum(np.maximum(q + JT @ (sol[:, 0] - sol[:, 1]) + r, lower), upper)
        err_mm[i] = 1000.0 * sqrt(float(dp @ dp))
        retry = 40 if err_mm[i] < REACH_TOL_MM else 0  # don't grind on through an unreachable stretch
        Js[i] = J
        Q[i] = q
        if stop_unreachable and not retry:
            k = i + 1
            s, seg, Q, err_mm, Js = s[:k], seg[:k], Q[:k], err_mm[:k], Js[:k]
            break
    return KinematicsResult(s, Q, seg, err_mm, smallest_singular_values(Js), _speed_caps(arm, s, Q, seg, nseg))


def smallest_singular_values(J: np.ndarray) -> np.ndarray:
    """Smallest singular value of each (m, n) matrix of J (k, m, n), m ≤ n — where it decides a
    figure, exactly the number `np.linalg.svd(J, compute_uv=False)[:, -1]` gives, at about half
    its cost.

    √ of the smallest eigenvalue of J·Jᵀ (symmetric m × m: LAPACK's eigvalsh) is close to it: the
    Gram product and the symmetric eigensolver are backward stable, |λ̂ − σ²| ≤ c·ε·σ_max² ≤
    c·ε·‖J‖²_F =: d, hence |√λ̂ − σ| ≤ min(√d, d / √λ̂), with c = SIGMA_BOUND (100 times the few
    units the analysis gives). The samples that bound does not put above SINGULAR_SIGMA (they may
    be near-singular) and those that may hold the smallest value get the SVD's own number, so the
    near-singular flags and the smallest value are the SVD's to the bit; the others differ from
    it by less than their bound (≈ 1e-13 at σ = 0.02)."""
    k = len(J)
    if k == 0 or not np.isfinite(J).all():
        return np.linalg.svd(J, compute_uv=False)[:, -1] if k else np.zeros(0)
    lam = np.linalg.eigvalsh(J @ J.transpose(0, 2, 1))[:, 0]
    sig = np.sqrt(np.maximum(lam, 0.0))
    d = SIGMA_BOUND * np.finfo(float).eps * np.einsum("kij,kij->k", J, J)
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = np.minimum(np.sqrt(d), np.where(sig > 0, d / sig, np.inf))
    low = sig - bound
    exact = (low < SINGULAR_SIGMA) | (low <= (sig + bound).min())
    if exact.any():
        sig[exact] = np.linalg.svd(J[exact], compute_uv=False)[:, -1]
    return sig


def lapack_dposv() -> Any:
    """LAPACK's dposv (Cholesky solve of a symmetric positive definite system) as scipy wraps it,
    `scipy.linalg.lapack.dposv`, loaded where it can be without scipy.linalg's package init: that
    imports ~180 modules (numpy.f2py, numpy.testing, numpy.random, ...: 0.2 s of CPU in a run that
    needs this one routine). Its compiled extension module `scipy.linalg._flapack` is loaded
    from its file (not registered: an `import scipy.linalg` later loads it as usual, and CPython
    hands it the same functions); if that module is not where this scipy keeps it, the usual
    import. The same compiled function either way."""
    if _DPOSV:
        return _DPOSV[0]
    import sys

    mod = sys.modules.get("scipy.linalg._flapack")
    if mod is None:
        try:
            import importlib.machinery
            import importlib.util

            import scipy

            where = Path(scipy.__file__).parent / "linalg"
            path = next(
                where / f"_flapack{suffix}"
                for suffix in importlib.machinery.EXTENSION_SUFFIXES
                if (where / f"_flapack{suffix}").is_file()
            )
            loader = importlib.machinery.ExtensionFileLoader("scipy.linalg._flapack", str(path))
            spec = importlib.util.spec_from_file_location("scipy.linalg._flapack", path, loader=loader)
            if spec is None:
                raise ImportError("scipy.linalg._flapack")
            mod = importlib.util.module_from_spec(spec)
            loader.exec_module(mod)
        except Exception:  # another layout: the usual import
            mod = None
    if mod is None or not hasattr(mod, "dposv"):
        from scipy.linalg.lapack import dposv

        _DPOSV.append(dposv)
    else:
        _DPOSV.append(mod.dposv)
    return _DPOSV[0]


_DPOSV: list[Any] = []  # lapack_dposv's function, once found


def _wrist_roll_pull(arm: Arm, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """Null-space preference of `solve_samples`: keep the wrist rolls (A4, A6) near mid-range — the
    rotation about the torch axis is free, so use it to avoid winding them up through wrist
    singularities. Returns the mid-range joint angles and the pull gain per joint."""
    mid = 0.5 * (arm.lower + arm.upper)
    roll = np.zeros(nv)
    if nv >= 6:
        roll[[3, 5]] = 0.05
    return mid, roll


def _speed_caps(arm: Arm, s: np.ndarray, Q: np.ndarray, seg: np.ndarray, nseg: int) -> np.ndarray:
    """Per programmed segment (of nseg): the highest path speed (mm/s) at which no joint exceeds
    its speed limit, from the joint speed per unit path speed dq/ds (rad/mm) between samples."""
    ds = np.diff(s)
    dq = np.abs(np.diff(Q, axis=0)) / np.maximum(ds, 1e-9)[:, None]
    with np.errstate(divide="ignore"):
        cap_i = np.min(np.where(dq > 1e-12, arm.qd_max[None, :] / dq, np.inf), axis=1)
    cap = np.full(nseg, np.inf)
    np.minimum.at(cap, seg[:-1], cap_i)
    return cap


def find_issues(
    kin: KinematicsResult,
    arm: Arm,
    seg_layer: np.ndarray,
    seg_section: np.ndarray,
    section_keys: tuple[str, ...],
    seg_speed: np.ndarray,
) -> list[dict]:
    """Unreachable points, joint-limit hits, near-singular stretches and joint-speed caps, grouped
    into contiguous stretches per (layer, section). s in mm of programmed arc length."""
    at_limit = np.any((kin.q <= arm.lower + LIMIT_MARGIN) | (kin.q >= arm.upper - LIMIT_MARGIN), axis=1)
    flags = {
        "unreachable": kin.reach_err > REACH_TOL_MM,
        "joint_limit": at_limit,
        "near_singular": kin.sigma_min < SINGULAR_SIGMA,
    }
    speed_cap = kin.segment_cap < seg_speed
    issues: list[dict] = []
    for kind, f in flags.items():
        for st in _stretches(kind, f, kin.s, kin.seg, seg_layer, seg_section, section_keys):
            if kind == "joint_limit":
                m = (kin.s >= st["s_from"]) & (kin.s <= st["s_to"])
                hit = np.any((kin.q[m] <= arm.lower + LIMIT_MARGIN) | (kin.q[m] >= arm.upper - LIMIT_MARGIN), axis=0)
                st["axes"] = [f"A{j + 1}" for j in np.flatnonzero(hit)]
                st["detail"] = f"{', '.join(st['axes'])} at the limit"
            issues.append(st)
    if speed_cap.any():
        segs = np.flatnonzero(speed_cap)
        f = np.isin(kin.seg, segs)
        for st in _stretches("joint_speed", f, kin.s, kin.seg, seg_layer, seg_section, section_keys):
            m = f & (kin.s >= st["s_from"]) & (kin.s <= st["s_to"])
            ss = np.unique(kin.seg[m])
            k = np.flatnonzero(m[:-1])
            ds = np.maximum(np.diff(kin.s)[k], 1e-9)
            rate = np.abs(np.diff(kin.q, axis=0)[k]) / ds[:, None] / np.maximum(arm.qd_max, 1e-12)
            st["axes"] = sorted({f"A{j + 1}" for j in rate.argmax(axis=1)}) if len(k) else []
            st["detail"] = f"path speed capped to {kin.segment_cap[ss].min():.1f} mm/s by joint speed limits" + (
                f" ({', '.join(st['axes'])})" if st["axes"] else ""
            )
            issues.append(st)
    return issues


def _stretches(kind, flag, s, seg, seg_layer, seg_section, keys) -> list[dict]:
    out: list[dict] = []
    if not flag.any():
        return out
    idx = np.flatnonzero(flag)
    breaks = np.flatnonzero(
        (np.diff(idx) > 1)
        | (seg_section[seg[idx[1:]]] != seg_section[seg[idx[:-1]]])
        | (seg_layer[seg[idx[1:]]] != seg_layer[seg[idx[:-1]]])
    )
    starts = np.concatenate([[0], breaks + 1])
    ends = np.concatenate([breaks, [len(idx) - 1]])
    for a, b in zip(starts, ends):
        i0, i1 = idx[a], idx[b]
        sg = seg[i0]
        sec = int(seg_section[sg])
        out.append(
            {
                "kind": kind,
                "layer": int(seg_layer[sg]),
                "section": keys[sec] if 0 <= sec < len(keys) else None,
                "s_from": float(s[i0]),
                "s_to": float(s[i1]),
                "count": int(b - a + 1),
                "detail": "",
            }
        )
    return out
