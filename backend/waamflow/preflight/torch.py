"""The torch's axis as the program states it against the way the part grows (`torch_axis`).

A robot program carries an orientation on every target (KUKA A, B, C; ABB quaternions; Fanuc W,
P, R; Yaskawa Rx, Ry, Rz); the points may be right while the torch points sideways or up: a
quaternion typed with its components swapped, angles in radians where degrees belong, the
controller's tool direction X read as Z. Before this check such a program passed "ok" (the
preflight read positions only). The build direction of a layer: +z for planar programs; for
others the normal of the plane the layer's points lie in (a fan layer), up when it lies within 60°
of vertical, else turned away from the layer before it (a fan layer turned far over; a layer on
one line: the step from the layer before, across the line). The
angle between the torch (tool axis: from the torch towards the part) and the way down the build
direction is checked at every arc-ON target that states an orientation: our plans weld along it
(0° in the part's frame, a positioner's lean included), a lead or work angle is tens of degrees;
a torch at a right angle or upside down is a wrong program. On a layer that is not flat (a
helix climbing through the layers in one run, a conformal layer) each target grows from the bead
it is laid on: the direction from the nearest point of the beads deposited before it within
`LOCAL_REACH` layer spacings (the layer before, or earlier in its own layer when the point lies
below it: a helix's turn below; the path's own last stretch never), or +z on the plate; a target
with neither is not judged (`torch_axis_unjudged_layers`, and the report's notes say so). Before,
such a layer was not judged at all: thin-wall-panel's tube, one helix of 15 turns, in a KRL
program with every torch of it upside down passed "ok".
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..core.pairs import pairs_between
from .read import ProgramRead, Run
from .samples import segment_samples

UPWARD = 0.5  # |z| of a layer's normal from which it grows up (within 60° of vertical), not by the step
LOCAL_REACH = 2.5  # layer spacings: how far below a target of a layer that is not flat its bead is looked for
# A bead of the target's own layer (a helix's turn below) counts within 30° of vertical only, and at half a
# layer spacing or more: thin-wall-panel's tube ramps up from its first turn, 0.02 mm above it where it
# starts, and the arcs its KRL fits (0.05 mm) put the turn below off to the side by as much: 18.7°
# taken from there, 60° from a stretch of its own turn with the cone at 60°
SAME_LAYER_COS = float(np.cos(np.radians(30.0)))


def _layer_plane(pts: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, bool]:
    """(centroid, unit normal of the points' plane or None when they lie on one line, the line's
    unit direction or None when the points coincide, flat): flat = every point within `tol` of that
    plane (of that line when collinear)."""
    c = pts.mean(axis=0)
    _u, sv, vt = np.linalg.svd(pts - c, full_matrices=False)
    line = vt[0] if sv[0] >= 1e-9 else None
    if len(pts) < 3 or sv[1] <= 1e-3 * max(sv[0], 1e-12) or sv[1] < 1e-6:
        return c, None, line, True
    return c, vt[2], line, bool(np.abs((pts - c) @ vt[2]).max() <= tol)


def build_directions(layers: Sequence[tuple[int, list[Run]]], planar: bool, spacing: float | None) -> np.ndarray:
    """(L, 3) the way each layer grows, unit; nan rows for layers not judged (not flat, or a line
    with no step across it)."""
    n_layers = len(layers)
    if planar:
        return np.tile([0.0, 0.0, 1.0], (n_layers, 1))
    tol = max(1.0, 0.5 * spacing) if spacing else 1.0
    planes = [_layer_plane(np.vstack([r.points for r in runs]), tol) for _i, runs in layers]
    out = np.full((n_layers, 3), np.nan)
    for k, (c, normal, line, flat) in enumerate(planes):
        step = c - planes[k - 1][0] if k > 0 else (planes[1][0] - c if n_layers > 1 else np.array([0.0, 0.0, 1.0]))
        if normal is None:  # one line: the step from the layer before, across the line
            if line is None:
                continue
            normal = step - (step @ line) * line
            if np.linalg.norm(normal) < 1e-6:
                continue
        elif not flat:
            continue
        normal = normal / np.linalg.norm(normal)
        if abs(normal[2]) >= UPWARD:  # within 60° of vertical: parts grow up, onto the plate
            out[k] = normal if normal[2] > 0 else -normal
        elif abs(normal @ step) > 1e-6 * max(1.0, float(np.linalg.norm(step))):  # a fan layer turned far over
            out[k] = normal if normal @ step > 0 else -normal
    return out


def torch_axis_problems(
    layers: Sequence[tuple[int, list[Run]]],
    prog: ProgramRead,
    directions: np.ndarray,
    spacing: float | None,
    out: dict,
    rep: Any,
    s: Any,
) -> None:
    """The `torch_axis` problem (`s.torch_axis`): the arc-ON target whose torch lies farthest from
    its layer's build direction, beyond `s.torch_axis_warn_deg` (a warning) or
    `s.torch_axis_fail_deg` (s.torch_axis); out["torch_angle_max_deg"]: that angle, degrees.
    directions: each layer's build direction (`build_directions`), spacing: the layers' (mm)."""
    if s.torch_axis == "off" or not prog.oriented or not layers:
        return
    from scipy.spatial import cKDTree  # not at import: the fork server preloads this module without scipy

    pts = np.array([p for p, _a in prog.oriented], float)
    axes = np.array([a for _p, a in prog.oriented], float)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    runs = [(k, r) for k, (_i, rs) in enumerate(layers) for r in rs]
    run_pts = np.vstack([r.points for _k, r in runs])
    sizes = np.array([len(r.points) for _k, r in runs])
    _d, nearest = cKDTree(run_pts).query(pts)
    own = np.repeat(np.arange(len(runs)), sizes)[nearest]  # the run each target lies on
    li = np.array([k for k, _r in runs], int)[own]  # and its layer
    grow = directions[li]
    judged = np.isfinite(grow).all(axis=1)
    if not judged.all() and spacing:
        first = np.cumsum(sizes) - sizes  # each run's first point in run_pts
        fill = local_directions(runs, pts, own, nearest - first[own], ~judged, spacing)
        grow[~judged] = fill[~judged]
        judged = np.isfinite(grow).all(axis=1)
    left = np.isnan(directions[:, 0])
    left[li[judged]] = False  # a layer none of whose targets is left unjudged counts judged
    left[li[~judged]] = True
    out["torch_axis_unjudged_layers"] = int(left.sum())
    if (~judged).any():
        out.setdefault("notes", []).append(
            f"{int((~judged).sum())} arc-ON target{'s' if (~judged).sum() != 1 else ''} in {int(left.sum())} "
            f"layer{'s' if left.sum() != 1 else ''} neither flat nor laid on a bead (or the plate) within "
            f"{LOCAL_REACH * (spacing or 0):.1f} mm below: the torch axis is not judged there"
        )
    if not judged.any():
        return
    angle = np.full(len(pts), np.nan)
    angle[judged] = np.degrees(np.arccos(np.clip(-(axes[judged] * grow[judged]).sum(axis=1), -1.0, 1.0)))
    k = int(np.nanargmax(angle))
    worst = float(angle[k])
    out["torch_angle_max_deg"] = round(worst, 2)
    if worst <= s.torch_axis_warn_deg:
        return
    severity = s.torch_axis if worst > s.torch_axis_fail_deg else "warn"
    over = int(np.count_nonzero(angle > s.torch_axis_warn_deg))
    idx = layers[int(li[k])][0]
    ax, gw = axes[k], grow[k]
    rep.problem(
        "torch_axis",
        severity,
        f"layer {idx}: the torch points {worst:.0f}° away from the way the part grows at "
        f"({pts[k][0]:.1f}, {pts[k][1]:.1f}, {pts[k][2]:.1f}) (tool axis ({ax[0]:.2f}, {ax[1]:.2f}, {ax[2]:.2f}), "
        f"build direction ({gw[0]:.2f}, {gw[1]:.2f}, {gw[2]:.2f}); {over} arc-ON target{'s' if over != 1 else ''} "
        f"beyond {s.torch_axis_warn_deg:g}°): a torch sideways or upside down welds off the bead or not at all. "
        "Check the orientation in the program (angle order, degrees, quaternion order) and the tool direction "
        "the controller uses (`tool direction X|Z` in the header)",
        layer=idx,
        value=worst,
        limit=s.torch_axis_fail_deg if severity != "warn" else s.torch_axis_warn_deg,
        point=tuple(pts[k]),
    )


def local_directions(
    runs: Sequence[tuple[int, Run]], pts: np.ndarray, own: np.ndarray, index: np.ndarray, want: np.ndarray, h: float
) -> np.ndarray:
    """(n, 3) the way the part grows at each wanted target (nan elsewhere, and where not found):
    from the foot of the nearest earlier bead within `LOCAL_REACH`·h (h: the layer spacing, mm) to
    the target. runs: (layer position, run) in program order; own, index: each target's run (its
    position in `runs`) and point (its index in that run's points); the nearest foot at half a spacing or more counts. Earlier:
    a run of the layer before, or of the target's own layer when the target lies above it (within
    30° of vertical, `SAME_LAYER_COS`: a bead beside it never counts), its own run only more than
    twice the reach behind it. A target within a layer spacing of the program's lowest arc-ON
    point, or with none within the reach of it, stands on the plate: +z."""
    out = np.full((len(pts), 3), np.nan)
    idx = np.flatnonzero(want)
    reach, step = LOCAL_REACH * h, h / 4.0
    layer_of = np.array([k for k, _r in runs], int)
    near = np.isin(layer_of, np.concatenate([layer_of[own[idx]], layer_of[own[idx]] - 1]))
    cand = np.flatnonzero(near & np.array([len(r.points) > 1 for _k, r in runs]))
    if not len(idx) or not len(cand):
        return out
    arc = {c: _along(runs[c][1].points) for c in set(cand.tolist()) | set(own[idx].tolist())}
    at = np.zeros(len(pts))
    at[idx] = [arc[c][i] for c, i in zip(own[idx].tolist(), index[idx].tolist())]  # each target along its run
    lines = [runs[c][1].points for c in cand.tolist()]
    a = np.vstack([p[:-1] for p in lines])
    b = np.vstack([p[1:] for p in lines])
    seg_run = np.repeat(cand, [len(p) - 1 for p in lines])
    length = np.linalg.norm(b - a, axis=1)
    arc0 = np.concatenate([arc[c][:-1] for c in cand.tolist()])  # each segment's start along its run
    samples, seg, _frac = segment_samples(a, b, step)
    ti, sj = pairs_between(pts[idx], samples, reach + step)
    t, g = idx[ti], seg[sj]
    d = b[g] - a[g]
    u = np.clip(np.einsum("ij,ij->i", pts[t] - a[g], d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-12), 0.0, 1.0)
    v = pts[t] - (a[g] + u[:, None] * d)  # from the foot on the segment to the target
    dist = np.linalg.norm(v, axis=1)
    lt, ls, rt, rs = layer_of[own[t]], layer_of[seg_run[g]], own[t], seg_run[g]
    same = ls == lt
    before = (ls == lt - 1) | (same & ((rs < rt) | ((rs == rt) & (arc0[g] + u * length[g] < at[t] - 2.0 * reach))))
    ok = before & (dist >= 0.5 * h) & (dist <= reach) & (~same | (v[:, 2] >= SAME_LAYER_COS * dist))
    t, v, dist = t[ok], v[ok], dist[ok]
    order = np.lexsort((dist, t))  # nearest first per target
    t, v, dist = t[order], v[order], dist[order]
    head = np.r_[True, t[1:] != t[:-1]] if len(t) else np.zeros(0, bool)
    out[t[head]] = v[head] / dist[head][:, None]
    # on the plate: within a layer of the program's lowest point (a helix's ramp, laid on its own first
    # turn less than half a layer above it), or with no bead below within the reach
    low = min(float(r.points[:, 2].min()) for _k, r in runs if len(r.points))
    plate = want & ((pts[:, 2] <= low + h) | (np.isnan(out[:, 0]) & (pts[:, 2] <= low + reach)))
    out[plate] = (0.0, 0.0, 1.0)
    return out


def _along(points: np.ndarray) -> np.ndarray:
    """(k,) each point's distance along the polyline from its first, mm."""
    return np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]
