"""Arc-ON moves that leave their layer's plane (planar layers).

A layer whose arc-ON points lie, all but a few, in one plane is meant to be planar: a move of it
that climbs or drops more than half a layer height (at least 1 mm) is a point edited or computed
wrong — a robot point raised 20 mm mid-weld (the arc stretches and breaks off) or lowered into the
bead below. Before this check one such point made the whole program "not planar" and the 3D
checks let it pass with warnings (KRL point P10 of mpp-cross raised 20 mm). A helix rises a layer
a lap in small steps and a fan layer is tilted throughout: neither is a layer of this kind, and
neither has such a step.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from .read.core import Run

FLAT_SHARE = 0.8  # a layer is planar when this share of its arc-ON points lie within `tol` of its median z
MIN_JUMP_MM = 1.0  # the least step that counts, whatever the layer height


def z_jump_problems(layers: Sequence[tuple[int, list[Run]]], h: float | None, tol: float, rep: Any, s: Any) -> None:
    """The `z_jump` problems (`s.z_jump`), one per layer at its largest step."""
    if s.z_jump == "off":
        return
    limit = max(0.5 * h if h else 0.0, MIN_JUMP_MM)
    for idx, runs in layers:
        zs = np.concatenate([r.points[:, 2] for r in runs])
        med = float(np.median(zs))
        if np.mean(np.abs(zs - med) <= tol) < FLAT_SHARE:
            continue
        worst: tuple[float, Run, int] | None = None
        for r in runs:
            dz = np.abs(np.diff(r.points[:, 2]))
            if len(dz) and dz.max() > limit and (worst is None or dz.max() > worst[0]):
                worst = (float(dz.max()), r, int(np.argmax(dz)))
        if worst is None:
            continue
        step, run, k = worst
        a, b = run.points[k], run.points[k + 1]
        pt = a if abs(a[2] - med) > abs(b[2] - med) else b  # the end off the plane
        way = "climbs" if pt[2] > med else "drops"
        rep.problem(
            "z_jump",
            s.z_jump,
            f"an arc-ON move of layer {idx} (section {run.section}) {way} {step:.3f} mm off the layer's plane "
            f"(z {med:.3f}) to z {pt[2]:.3f} at ({pt[0]:.1f}, {pt[1]:.1f}): welding across it the arc stretches "
            "and breaks off, or the torch dips into the bead; check the point in the program (a planar layer "
            "keeps its arc-ON moves in its plane)",
            layer=idx,
            section=run.section,
            value=step,
            limit=limit,
            point=pt,
        )
