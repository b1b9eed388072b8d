"""Travel speed per segment from the bead-height model and the local layer height (Rauch et al. 2021).

A segment's needed height is the local layer height at its midpoint (`fan.local_height`: r·Δθ
on a fan layer, the thickness on a planar one); the inverse model gives the travel speed there.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..core.model import LayerPaths, Layered
from .bead import BeadModel, csratio
from .fan import local_height, to_local


def segment_heights(lp: LayerPaths, sp) -> tuple[np.ndarray, np.ndarray]:
    """(n−1,) needed heights (mm) at segment midpoints and (n,) local x (mm; r on a fan layer)."""
    xy = to_local(lp.layer, sp.points)
    return local_height(lp.layer, (xy[:-1] + xy[1:]) / 2.0), xy[:, 0]


def apply_bead_model(lp: LayerPaths, model: BeadModel) -> LayerPaths:
    """The layer's paths with arc-on segment speeds (mm/s) from the inverse model (clamped)."""
    sections = []
    for sp in lp.sections:
        if len(sp.points) < 2:
            sections.append(sp)
            continue
        h, _x = segment_heights(lp, sp)
        ts, _out = model.speed_for_height(h)
        sections.append(replace(sp, speed=np.where(np.asarray(sp.arc, bool), ts / 60.0, sp.speed)))
    return LayerPaths(lp.layer, tuple(sections), lp.dwell_after_s)


def layer_report(lp: LayerPaths, model: BeadModel) -> dict:
    """Per-layer numbers: arc-on segments, clamped ones, needed height and speed ranges, and on fan
    layers the radial extent of the path and its CSratio."""
    row: dict = {"index": lp.index, "segments": 0, "clamped": 0}
    hs, vs, xs = [], [], []
    for sp in lp.sections:
        if len(sp.points) < 2:
            continue
        arc = np.asarray(sp.arc, bool)
        h, x = segment_heights(lp, sp)
        _ts, out = model.speed_for_height(h)
        row["segments"] += int(arc.sum())
        row["clamped"] += int((out & arc).sum())
        hs.append(h[arc])
        vs.append(np.asarray(sp.speed, float)[arc])
        xs.append(x)
    if hs and np.concatenate(hs).size:
        h, v, x = np.concatenate(hs), np.concatenate(vs), np.concatenate(xs)
        row.update(
            height_min_mm=float(h.min()),
            height_max_mm=float(h.max()),
            speed_min_mm_s=float(v.min()),
            speed_max_mm_s=float(v.max()),
        )
        if lp.layer.frame is not None:
            row.update(
                r_min_mm=float(x.min()), r_max_mm=float(x.max()), csratio=csratio(float(x.min()), float(x.max()))
            )
    return row


def toolpath_report(toolpath: Layered[LayerPaths], model: BeadModel) -> list[dict]:
    return [layer_report(lp, model) for lp in toolpath if lp is not None]
