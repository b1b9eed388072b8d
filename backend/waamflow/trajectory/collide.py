"""Collision checks of the cell along the solved path, with coal (the collision library of Pinocchio).

Bodies (all converted to metres for coal):

* arm links — a capsule between consecutive joint origins of the URDF chain (and joint 6 → tool0),
  radius `LINK_RADIUS_MM` (shoulder to wrist); adjacent links are not tested against each other;
* the torch — the cell tool's shapes (cylinders/boxes/meshes in the flange frame);
* the positioner's bodies (`positioner.shapes`: table disc, tilt frame, in the flange frame or on
  another positioner link) and the fixtures (`fixtures`: in the world, or on a positioner link —
  clamps turn with the part), every shape at the positioner angles of the sample: all of it from
  the cell file;
* the part built so far — every layer below the current one as an oriented box fitted to its
  deposition points (principal axes, ± half a bead across), turning with the positioner.

Pairs tested: arm links and torch vs fixtures and table; torch and the two wrist links vs the
part layers below the current one. Broad phase in numpy per checked sample: every moving body's
bounding sphere against every other body's bounding sphere, then against its oriented bounding box;
coal runs only on the pairs that pass (same pairs, same order, same first hit as testing all).
Sampling: every IK sample at least `step_mm` of programmed path after the previous checked one,
plus every vertex where the layer changes (documented in simulation.json's `collision_step_mm`). The current layer is never
tested: the torch deposits on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import coal
import numpy as np
import pinocchio as pin

LINK_RADIUS_MM = (110.0, 100.0, 90.0, 70.0, 60.0, 45.0)
BEAD_HALF_MM = 1.5
MAX_REPORTED = 50


@dataclass(frozen=True)
class Collision:
    layer: int
    section: str | None
    bodies: tuple[str, str]
    point_mm: tuple[float, float, float]
    s_mm: float


def _tf(R, t_mm) -> coal.Transform3s:
    return coal.Transform3s(np.asarray(R, float), np.asarray(t_mm, float) / 1000.0)


def _shape(sh, cell=None) -> coal.CollisionGeometry:
    if sh.kind == "box":
        return coal.Box(*(np.asarray(sh.size_mm, float) / 1000.0))
    if sh.kind == "cylinder":
        return coal.Cylinder(sh.size_mm[0] / 1000.0, sh.size_mm[2] / 1000.0)
    v, f = cell.shape_mesh(sh)
    m = coal.BVHModelOBBRSS()
    m.beginModel(len(f), len(v))
    m.addVertices(np.asarray(v, float) / 1000.0)
    m.addTriangles(np.asarray(f, np.int64))
    m.endModel()
    return m


def cell_statics(cell):
    """The cell's still and positioner-carried bodies: a function angles → [(name, geometry,
    transform, centre mm, bounding radius mm, R, box centre mm, box half extents mm)] (placed at
    those positioner angles; results cached per angle set). The last three are the body's
    oriented bounding box in the world (the broad phase: a big floor slab is a thin box, not the
    sphere around it)."""
    bodies = []
    for prefix, shapes, default in (
        ("positioner", cell.positioner.shapes if cell.positioner else [], None),
        ("fixture", cell.fixtures, ""),
    ):
        for sh in shapes:
            link = sh.link if sh.link or default is not None else None  # None: the flange
            R, t = sh.pose()
            bodies.append(
                (f"{prefix}:{sh.name}", _shape(sh, cell), link, R, t, _bound_radius(sh, cell), *_local_box(sh, cell))
            )
    still = [
        (n, g, _tf(R, t), t, r, R, R @ bc + t, half)
        for n, g, link, R, t, r, bc, half in bodies
        if link == "" or cell.positioner is None
    ]
    moving = [b for b in bodies if not (b[2] == "" or cell.positioner is None)]
    cache: dict[tuple, list] = {}

    def at(angles) -> list:
        key = tuple(np.round(np.asarray(angles, float), 9))
        if key not in cache:
            out = list(still)
            poses: dict = {}
            for n, g, link, R, t, r, bc, half in moving:
                if link not in poses:
                    poses[link] = cell.link_pose(np.asarray(angles, float), link or "")
                Rl, tl = poses[link]
                c = Rl @ t + tl
                Rw = Rl @ R
                out.append((n, g, _tf(Rw, c), c, r, Rw, Rw @ bc + c, half))
            cache[key] = out
        return cache[key]

    return at


def _local_box(sh, cell=None) -> tuple[np.ndarray, np.ndarray]:
    """(centre, half extents) mm of the shape's bounding box in its own frame."""
    if sh.kind == "box":
        return np.zeros(3), 0.5 * np.asarray(sh.size_mm, float)
    if sh.kind == "cylinder":
        return np.zeros(3), np.array([sh.size_mm[0], sh.size_mm[0], 0.5 * sh.size_mm[2]])
    v = cell.shape_mesh(sh)[0]
    lo, hi = v.min(axis=0), v.max(axis=0)
    return 0.5 * (lo + hi), 0.5 * (hi - lo)


def _box_gap2(centres: np.ndarray, R: np.ndarray, bc: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Squared distance (mm²) from each point (m, 3) to each oriented box (s: rotation (s, 3, 3),
    centre (s, 3), half extents (s, 3)): (m, s), 0 inside."""
    local = np.einsum("sji,msj->msi", R, centres[:, None, :] - bc[None, :, :])
    ex = np.maximum(np.abs(local) - half[None, :, :], 0.0)
    return np.einsum("msi,msi->ms", ex, ex)


def _capsule_tf(a, b):
    """Transform placing a z-aligned capsule centred between world points a, b (mm)."""
    d = b - a
    L = float(np.linalg.norm(d))
    z = d / L if L > 1e-9 else np.array([0.0, 0.0, 1.0])
    R = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), z).matrix()
    return _tf(R, 0.5 * (a + b)), L


def layer_boxes(moves) -> dict[int, tuple[coal.Box, np.ndarray, np.ndarray, float]]:
    """Per layer: (coal box, rotation, centre (work mm), bounding radius mm) from its deposition points."""
    out = {}
    dep = np.flatnonzero(moves.kind == 1)
    for L in np.unique(moves.layer[dep]):
        segs = dep[moves.layer[dep] == L]
        P = np.vstack([moves.points[segs], moves.points[segs + 1]])
        c = P.mean(axis=0)
        _, _, Vt = np.linalg.svd(P - c, full_matrices=False)
        R = Vt.T
        if np.linalg.det(R) < 0:
            R[:, 2] *= -1
        loc = (P - c) @ R
        lo, hi = loc.min(axis=0), loc.max(axis=0)
        ext = np.maximum(hi - lo, 0.0) + 2 * BEAD_HALF_MM
        c = c + R @ (0.5 * (lo + hi))
        out[int(L)] = (coal.Box(*(ext / 1000.0)), R, c, float(0.5 * np.linalg.norm(ext)))
    return out


BATCH = 256  # checked samples per pass of the batched broad phase (bounds its (samples, bodies, layers) arrays)


@dataclass
class _Setup:
    """What every checked sample of one `check_path` call shares."""

    model: pin.Model
    data: pin.Data
    tool0: int
    tool_shapes: list
    statics_at: Callable[[Any], list]
    layers: dict
    lay_ids: np.ndarray
    lay_c: np.ndarray
    lay_r: np.ndarray
    lay_R: np.ndarray
    lay_h: np.ndarray
    radii: np.ndarray
    n_links: int
    near: np.ndarray
    t_off: np.ndarray
    t_rad: np.ndarray
    base_R: np.ndarray
    base_t: np.ndarray
    margin_mm: float
    stat_arrays: dict


def _setup(arm, moves, cell, base_R, base_t, layers, margin_mm) -> _Setup:
    model = arm.model
    tool0 = model.getFrameId("tool0")
    tool_shapes = [
        (f"torch:{sh.name}", _shape(sh, cell), *sh.pose(), _bound_radius(sh, cell)) for sh in cell.tool.shapes
    ]
    layers = layer_boxes(moves) if layers is None else layers
    lay_ids = np.array(sorted(layers), dtype=int)
    njoints = model.njoints
    n_links = njoints - 1  # capsules joint j → j+1 and the last joint → tool0
    near_links = np.arange(n_links) >= n_links - 2
    return _Setup(
        model,
        model.createData(),
        tool0,
        tool_shapes,
        cell_statics(cell),
        layers,
        lay_ids,
        np.array([layers[L][2] for L in lay_ids]).reshape(-1, 3),
        np.array([layers[L][3] for L in lay_ids]),
        np.array([layers[L][1] for L in lay_ids]).reshape(-1, 3, 3),
        np.array([np.asarray(layers[L][0].halfSide) * 1000.0 for L in lay_ids]).reshape(-1, 3),
        np.array([LINK_RADIUS_MM[min(j, len(LINK_RADIUS_MM) - 1)] for j in range(njoints)]),
        n_links,
        np.concatenate([near_links, np.ones(len(tool_shapes), bool)]),
        np.array([off for _, _, _, off, _ in tool_shapes]).reshape(-1, 3),
        np.array([rad for *_, rad in tool_shapes]),
        base_R,
        base_t,
        margin_mm,
        {},
    )


def _static_arrays(st: _Setup, statics: list) -> tuple[np.ndarray, ...]:
    """(centres, radii, box rotations, box centres, box half extents) of the still/positioner bodies."""
    sa = st.stat_arrays.get(id(statics))
    if sa is None:
        sa = st.stat_arrays[id(statics)] = (
            np.array([b[3] for b in statics]).reshape(-1, 3),
            np.array([b[4] for b in statics]),
            np.array([b[5] for b in statics]).reshape(-1, 3, 3),
            np.array([b[6] for b in statics]).reshape(-1, 3),
            np.array([b[7] for b in statics]).reshape(-1, 3),
        )
    return sa


def _checked(s: np.ndarray, seg: np.ndarray, layer_of_seg: np.ndarray, step_mm: float) -> list[int]:
    """The samples checked: every one at least step_mm after the previous checked one, the first
    of each layer and the last."""
    out = []
    last_s, last_layer = -math.inf, None
    # Python numbers (the same differences as numpy's): no numpy scalar per sample
    layers = np.asarray(layer_of_seg)[np.asarray(seg)].astype(np.int64).tolist()
    s_l = np.asarray(s, dtype=float).tolist()
    end = len(s_l) - 1
    for i, (si, layer) in enumerate(zip(s_l, layers)):
        if si - last_s < step_mm and layer == last_layer and i != end:
            continue
        last_s, last_layer = si, layer
        out.append(i)
    return out


def _pair_gap2(centres: np.ndarray, R: np.ndarray, bc: np.ndarray, half: np.ndarray) -> np.ndarray:
    """`_box_gap2` for p (point, box) pairs: points (p, 3), rotations (p, 3, 3), centres and half
    extents (p, 3): (p,) squared distances, 0 inside."""
    local = np.einsum("pji,pj->pi", R, centres - bc)
    ex = np.maximum(np.abs(local) - half, 0.0)
    return np.einsum("pi,pi->p", ex, ex)


def _batch_candidates(st: _Setup, q: np.ndarray, rows: list[int], frames: list, layer: np.ndarray) -> np.ndarray:
    """The broad phase of `_sample_check` for many samples at once (numpy over samples, bodies and
    layers): (len(rows),) whether any pair of a sample passes it. Conservative like the
    per-sample one: a sample it passes over has no pair whose bounding volumes meet."""
    m = len(rows)
    oj = np.empty((m, st.n_links + 1, 3))
    rf = np.empty((m, 3, 3))
    model, data = st.model, st.data
    for r, i in enumerate(rows):
        pin.forwardKinematics(model, data, q[i])
        pin.updateFramePlacement(model, data, st.tool0)
        for j in range(1, st.n_links + 1):
            oj[r, j - 1] = data.oMi[j].translation
        oj[r, -1] = data.oMf[st.tool0].translation
        rf[r] = data.oMf[st.tool0].rotation
    joints = (oj * 1000.0) @ st.base_R.T + st.base_t
    Rf = st.base_R @ rf
    seg_len = np.linalg.norm(np.diff(joints, axis=1), axis=2)
    centres = np.concatenate(
        [0.5 * (joints[:, :-1] + joints[:, 1:]), np.einsum("bk,mjk->mbj", st.t_off, Rf) + joints[:, -1:, :]], axis=1
    )
    rads = (
        np.concatenate([0.5 * seg_len + st.radii[: st.n_links], np.broadcast_to(st.t_rad, (m, len(st.t_rad)))], axis=1)
        + st.margin_mm
    )
    hit = np.zeros(m, bool)
    groups: dict[int, list[int]] = {}
    statics_of = [st.statics_at(f[2]) for f in frames]
    for r, statics in enumerate(statics_of):
        groups.setdefault(id(statics), []).append(r)
    for rr in groups.values():
        sc, sr, sR, sbc, sh = _static_arrays(st, statics_of[rr[0]])
        if not len(sr):
            continue
        c = centres[rr]
        d = c[:, :, None, :] - sc[None, None, :, :]
        rb, bb, kk = np.nonzero(np.einsum("mbsk,mbsk->mbs", d, d) <= (rads[rr][:, :, None] + sr[None, None, :]) ** 2)
        if len(rb):
            ok = _pair_gap2(c[rb, bb], sR[kk], sbc[kk], sh[kk]) <= rads[rr][rb, bb] ** 2
            hit[np.asarray(rr)[rb[ok]]] = True
    if len(st.lay_ids):
        Rw = np.array([f[0] for f in frames])
        tw = np.array([f[1] for f in frames])
        cw = st.lay_c[None, :, :] @ Rw.transpose(0, 2, 1) + tw[:, None, :]  # (m, layers, 3)
        below = st.lay_ids[None, :] < layer[:, None]
        nb = np.flatnonzero(st.near)
        dist = np.linalg.norm(cw[:, None, :, :] - centres[:, nb, None, :], axis=3)  # (m, near bodies, layers)
        rb, bi, kk = np.nonzero(below[:, None, :] & (dist <= st.lay_r[None, None, :] + rads[:, nb, None]))
        if len(rb):
            bb = nb[bi]
            ok = _pair_gap2(centres[rb, bb], Rw[rb] @ st.lay_R[kk], cw[rb, kk], st.lay_h[kk]) <= rads[rb, bb] ** 2
            hit[rb[ok]] = True
    return hit


def _sample_check(st: _Setup, qi: np.ndarray, layer: int, frame: tuple, req) -> tuple | None:
    """Broad and narrow phase at one sample: the first colliding pair ((body, body), point) or None."""
    model, data, tool0 = st.model, st.data, st.tool0
    n_links, tool_shapes, radii = st.n_links, st.tool_shapes, st.radii
    pin.forwardKinematics(model, data, qi)
    pin.updateFramePlacement(model, data, tool0)
    oj = np.array([data.oMi[j].translation for j in range(1, model.njoints)] + [data.oMf[tool0].translation])
    joints = (oj * 1000.0) @ st.base_R.T + st.base_t
    Rf = st.base_R @ data.oMf[tool0].rotation
    tf0 = joints[-1]
    seg_len = np.linalg.norm(np.diff(joints, axis=0), axis=1)
    centres = np.vstack([0.5 * (joints[:-1] + joints[1:]), st.t_off @ Rf.T + tf0])
    rads = np.concatenate([0.5 * seg_len + radii[:n_links], st.t_rad]) + st.margin_mm
    Rw, tw, angles = frame
    statics = st.statics_at(angles)
    sa = _static_arrays(st, statics)
    d = centres[:, None, :] - sa[0][None, :, :]
    over = np.einsum("ijk,ijk->ij", d, d) <= (rads[:, None] + sa[1][None, :]) ** 2
    if over.any():  # the bounding spheres meet: do they meet the body's box?
        over &= _box_gap2(centres, sa[2], sa[3], sa[4]) <= rads[:, None] ** 2
    cw = st.lay_c @ Rw.T + tw
    below = st.lay_ids < layer
    part = (
        st.near[:, None]
        & below[None, :]
        & (np.linalg.norm(cw[None, :, :] - centres[:, None, :], axis=2) <= st.lay_r[None, :] + rads[:, None])
    )
    if part.any():
        cols = np.flatnonzero(part.any(axis=0))
        part[:, cols] &= (
            _box_gap2(centres, np.einsum("ij,kjl->kil", Rw, st.lay_R[cols]), cw[cols], st.lay_h[cols])
            <= rads[:, None] ** 2
        )
    if not (over.any() or part.any()):
        return None
    for m in np.flatnonzero(over.any(axis=1) | part.any(axis=1)):
        if m < n_links:
            if seg_len[m] < 1e-6:
                continue
            tf, L = _capsule_tf(joints[m], joints[m + 1])
            name = f"arm:link_{m + 1}"
            g = coal.Capsule(radii[m] / 1000.0, L / 1000.0)
        else:
            name, g, Rs, off, _ = tool_shapes[m - n_links]
            tf = _tf(Rf @ Rs, centres[m])
        for k in np.flatnonzero(over[m]):
            sname, sg, stf = statics[k][:3]
            hit = _collide(g, tf, sg, stf, req, name, sname)
            if hit:
                return hit
        for k in np.flatnonzero(part[m]):
            L = int(st.lay_ids[k])
            box, Rb = st.layers[L][0], st.layers[L][1]
            hit = _collide(g, tf, box, _tf(Rw @ Rb, cw[k]), req, name, f"part:layer_{L}")
            if hit:
                return hit
    return None


def check_path(
    arm,
    q: np.ndarray,
    s: np.ndarray,
    seg: np.ndarray,
    moves,
    cell,
    work_frames,
    base_R,
    base_t,
    step_mm: float = 20.0,
    layers: dict | None = None,
    margin_mm: float = 0.0,
) -> tuple[int, list[Collision], int]:
    """Collisions along the path. q: (k, nq) IK solutions; work_frames(i) → (R, t mm) of the work
    frame and the positioner angles at sample i; base_R/base_t: the robot base in the world (mm);
    layers: `layer_boxes(moves)` when the caller has them; margin_mm: bodies closer than this count
    as colliding (a planner's clearance).
    Returns (number of colliding samples, the first MAX_REPORTED collisions, samples checked).

    The broad phase runs in numpy over BATCH checked samples at a time (`_batch_candidates`); only
    the samples where some pair's bounding volumes meet go through `_sample_check` (the same broad
    phase per sample, then coal on its pairs in order: the first hit is the one reported)."""
    st = _setup(arm, moves, cell, base_R, base_t, layers, margin_mm)
    req = coal.CollisionRequest()
    if margin_mm > 0:
        req.security_margin = margin_mm / 1000.0
    rows = _checked(s, seg, moves.layer, step_mm)
    count = 0
    found: list[Collision] = []
    for b0 in range(0, len(rows), BATCH):
        batch = rows[b0 : b0 + BATCH]
        frames = [work_frames(i) for i in batch]
        layer = np.array([int(moves.layer[seg[i]]) for i in batch], dtype=int)
        cand = _batch_candidates(st, q, batch, frames, layer)
        for r in np.flatnonzero(cand):
            i = batch[r]
            hit = _sample_check(st, q[i], int(layer[r]), frames[r], req)
            if hit:
                count += 1
                if len(found) < MAX_REPORTED:
                    sec = int(moves.section[seg[i]])
                    found.append(
                        Collision(
                            int(layer[r]),
                            moves.section_keys[sec] if 0 <= sec < len(moves.section_keys) else None,
                            hit[0],
                            hit[1],
                            float(s[i]),
                        )
                    )
    return count, found, len(rows)


def _bound_radius(sh, cell=None) -> float:
    """Radius (mm) of a sphere about the shape's origin that holds it."""
    if sh.kind == "box":
        return 0.5 * float(np.linalg.norm(sh.size_mm))
    if sh.kind == "cylinder":
        return float(np.hypot(sh.size_mm[0], 0.5 * sh.size_mm[2]))
    return float(np.linalg.norm(cell.shape_mesh(sh)[0], axis=1).max())


def _collide(g1, t1, g2, t2, req, n1, n2):
    res = coal.CollisionResult()
    if coal.collide(g1, t1, g2, t2, req, res):
        p = res.getContact(0).pos * 1000.0 if res.numContacts() else t1.getTranslation() * 1000.0
        return (n1, n2), tuple(round(float(v), 3) for v in p)
    return None
