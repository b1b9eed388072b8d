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

from dataclasses import dataclass

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
    for prefix, shapes, default in (("positioner", cell.positioner.shapes if cell.positioner else [], None),
                                    ("fixture", cell.fixtures, "")):
        for sh in shapes:
            link = sh.link if sh.link or default is not None else None      # None: the flange
            R, t = sh.pose()
            bodies.append((f"{prefix}:{sh.name}", _shape(sh, cell), link, R, t, _bound_radius(sh, cell),
                           *_local_box(sh, cell)))
    still = [(n, g, _tf(R, t), t, r, R, R @ bc + t, half) for n, g, link, R, t, r, bc, half in bodies
             if link == "" or cell.positioner is None]
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


def check_path(arm, q: np.ndarray, s: np.ndarray, seg: np.ndarray, moves, cell, work_frames, base_R, base_t,
               step_mm: float = 20.0, layers: dict | None = None,
               margin_mm: float = 0.0) -> tuple[int, list[Collision], int]:
    """Collisions along the path. q: (k, nq) IK solutions; work_frames(i) → (R, t mm) of the work
    frame and the positioner angles at sample i; base_R/base_t: the robot base in the world (mm);
    layers: `layer_boxes(moves)` when the caller has them; margin_mm: bodies closer than this count
    as colliding (a planner's clearance).
    Returns (number of colliding samples, the first MAX_REPORTED collisions, samples checked)."""
    model, data = arm.model, arm.model.createData()
    tool0 = model.getFrameId("tool0")
    tool_shapes = [(f"torch:{sh.name}", _shape(sh, cell), *sh.pose(), _bound_radius(sh, cell))
                   for sh in cell.tool.shapes]
    statics_at = cell_statics(cell)
    layers = layer_boxes(moves) if layers is None else layers
    lay_ids = np.array(sorted(layers), dtype=int)
    lay_c = np.array([layers[L][2] for L in lay_ids]).reshape(-1, 3)
    lay_r = np.array([layers[L][3] for L in lay_ids])
    lay_R = np.array([layers[L][1] for L in lay_ids]).reshape(-1, 3, 3)
    lay_h = np.array([np.asarray(layers[L][0].halfSide) * 1000.0 for L in lay_ids]).reshape(-1, 3)
    req = coal.CollisionRequest()
    if margin_mm > 0:
        req.security_margin = margin_mm / 1000.0
    count, found, checked = 0, [], 0
    last_s, last_layer = -np.inf, None
    njoints = model.njoints
    radii = np.array([LINK_RADIUS_MM[min(j, len(LINK_RADIUS_MM) - 1)] for j in range(njoints)])
    n_links = njoints - 1                       # capsules joint j → j+1 and the last joint → tool0
    near_links = np.arange(n_links) >= n_links - 2
    t_off = np.array([off for _, _, _, off, _ in tool_shapes]).reshape(-1, 3)
    t_rad = np.array([rad for *_, rad in tool_shapes])
    near = np.concatenate([near_links, np.ones(len(tool_shapes), bool)])
    # broad phase in numpy: the bounding spheres of every moving body (links, torch) against every
    # still/positioner body and every part layer at once; coal runs only on the pairs whose spheres
    # meet, in the same order as one body after the other (the first hit is the one reported)
    stat_arrays: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for i in range(len(s)):
        layer = int(moves.layer[seg[i]])
        if s[i] - last_s < step_mm and layer == last_layer and i != len(s) - 1:
            continue
        last_s, last_layer = s[i], layer
        checked += 1
        pin.forwardKinematics(model, data, q[i])
        pin.updateFramePlacement(model, data, tool0)
        oj = np.array([data.oMi[j].translation for j in range(1, njoints)] + [data.oMf[tool0].translation])
        joints = (oj * 1000.0) @ base_R.T + base_t
        Rf = base_R @ data.oMf[tool0].rotation
        tf0 = joints[-1]
        seg_len = np.linalg.norm(np.diff(joints, axis=0), axis=1)
        centres = np.vstack([0.5 * (joints[:-1] + joints[1:]), t_off @ Rf.T + tf0])
        rads = np.concatenate([0.5 * seg_len + radii[:n_links], t_rad]) + margin_mm
        Rw, tw, angles = work_frames(i)
        statics = statics_at(angles)
        sa = stat_arrays.get(id(statics))
        if sa is None:
            sa = stat_arrays[id(statics)] = (np.array([b[3] for b in statics]).reshape(-1, 3),
                                             np.array([b[4] for b in statics]),
                                             np.array([b[5] for b in statics]).reshape(-1, 3, 3),
                                             np.array([b[6] for b in statics]).reshape(-1, 3),
                                             np.array([b[7] for b in statics]).reshape(-1, 3))
        d = centres[:, None, :] - sa[0][None, :, :]
        over = np.einsum("ijk,ijk->ij", d, d) <= (rads[:, None] + sa[1][None, :]) ** 2
        if over.any():                           # the bounding spheres meet: do they meet the body's box?
            over &= _box_gap2(centres, sa[2], sa[3], sa[4]) <= rads[:, None] ** 2
        cw = lay_c @ Rw.T + tw
        below = lay_ids < layer
        part = near[:, None] & below[None, :] & (np.linalg.norm(cw[None, :, :] - centres[:, None, :], axis=2)
                                                 <= lay_r[None, :] + rads[:, None])
        if part.any():
            k = np.flatnonzero(part.any(axis=0))
            part[:, k] &= _box_gap2(centres, np.einsum("ij,kjl->kil", Rw, lay_R[k]), cw[k], lay_h[k]) \
                <= rads[:, None] ** 2
        if not (over.any() or part.any()):
            continue
        hit = None
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
                    break
            if hit:
                break
            for k in np.flatnonzero(part[m]):
                L = int(lay_ids[k])
                box, Rb = layers[L][0], layers[L][1]
                hit = _collide(g, tf, box, _tf(Rw @ Rb, cw[k]), req, name, f"part:layer_{L}")
                if hit:
                    break
            if hit:
                break
        if hit:
            count += 1
            if len(found) < MAX_REPORTED:
                sec = int(moves.section[seg[i]])
                found.append(Collision(layer, moves.section_keys[sec] if 0 <= sec < len(moves.section_keys) else None,
                                       hit[0], hit[1], float(s[i])))
    return count, found, checked


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
