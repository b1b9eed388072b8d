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
a torch at a right angle or upside down is a wrong program. Layers that are not flat (a
conformal layer) are not judged (`torch_axis_unjudged_layers`).
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from .read import ProgramRead, Run

UPWARD = 0.5  # |z| of a layer's normal from which it grows up (within 60° of vertical), not by the step


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
    planar: bool,
    spacing: float | None,
    out: dict,
    rep: Any,
    s: Any,
) -> None:
    """The `torch_axis` problem (`s.torch_axis`): the arc-ON target whose torch lies farthest from
    its layer's build direction, beyond `s.torch_axis_warn_deg` (a warning) or
    `s.torch_axis_fail_deg` (s.torch_axis); out["torch_angle_max_deg"]: that angle, degrees."""
    if s.torch_axis == "off" or not prog.oriented or not layers:
        return
    from scipy.spatial import cKDTree  # not at import: the fork server preloads this module without scipy

    pts = np.array([p for p, _a in prog.oriented], float)
    axes = np.array([a for _p, a in prog.oriented], float)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    run_pts = np.vstack([r.points for _i, runs in layers for r in runs])
    label = np.repeat(np.arange(len(layers)), [sum(len(r.points) for r in runs) for _i, runs in layers])
    _d, nearest = cKDTree(run_pts).query(pts)
    li = label[nearest]  # the layer each target lies in
    directions = build_directions(layers, planar, spacing)
    out["torch_axis_unjudged_layers"] = int(np.isnan(directions[:, 0]).sum())
    grow = directions[li]
    judged = np.isfinite(grow).all(axis=1)
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
