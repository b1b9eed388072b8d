"""Travel moves through metal already welded (`travel_collision`, planar programs).

An arc-OFF move goes where the program says, in a straight line: one that passes lower than the
metal welded before it, where that metal stands, drives the torch into the part — a lift deleted by
hand, a machine profile's layer change without one, towers built one after the other with a
straight move from the top of one to the foot of the next. Before this check such a program passed
"ok" (travels were only checked against the plate). Each travel that reaches below the highest
metal welded before it is sampled every quarter bead width; a sample within half a bead width (in
plan) of the centre line of an earlier run, lower than that run's height by more than half a layer,
is in the metal (the programmed point is the bead's top: a hop at the height of the layer just
welded is not). Travels at a clearance above the part, as our posts write them, cost one
comparison each.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from .read import ProgramRead, Run
from .samples import segment_samples


def travel_problems(
    layers: Sequence[tuple[int, list[Run]]],
    prog: ProgramRead,
    h: float | None,
    width: float,
    out: dict,
    rep: Any,
    s: Any,
) -> None:
    """The `travel_collision` problem (`s.travel_collision`) of a planar program; h: the layers'
    typical height. out["travel_collisions"]: the travel moves found in the metal."""
    if s.travel_collision == "off" or not prog.travels or not prog.runs or not h or not width > 0:
        return
    depth = max(0.5 * h, 0.5)
    runs = prog.runs
    tops = np.maximum.accumulate([float(r.points[:, 2].max()) for r in runs])
    cand, owner = [], []  # travel samples below the metal's top, and their travel's number
    for k, (a, b, done) in enumerate(prog.travels):
        if done == 0 or min(a[2], b[2]) >= tops[done - 1] - depth:
            continue
        p = segment_samples(a[None], b[None], 0.25 * width)[0]
        p = p[p[:, 2] < tops[done - 1] - depth]
        cand.append(p)
        owner += [k] * len(p)
    out["travel_collisions"] = 0
    if not cand:
        return
    from scipy.spatial import cKDTree  # not at import: the fork server preloads this module without scipy

    pts = np.vstack(cand)
    run_pts = [segment_samples(r.points[:-1], r.points[1:], 0.25 * width)[0] for r in runs]  # each vertex twice
    xyz = np.vstack(run_pts)
    run_no = np.repeat(np.arange(len(runs)), [len(q) for q in run_pts])
    near = cKDTree(xyz[:, :2]).query_ball_point(pts[:, :2], 0.5 * width)
    hits: dict[int, tuple[float, np.ndarray, int]] = {}  # travel → (depth in the metal, point, the run)
    for i, idx in enumerate(near):
        if not idx:
            continue
        k = owner[i]
        idx = np.asarray(idx)
        idx = idx[run_no[idx] < prog.travels[k][2]]
        if not len(idx):
            continue
        j = idx[np.argmax(xyz[idx, 2])]
        d = float(xyz[j, 2] - pts[i, 2])
        if d > depth and (k not in hits or d > hits[k][0]):
            hits[k] = (d, pts[i], int(run_no[j]))
    out["travel_collisions"] = len(hits)
    if not hits:
        return
    k, (d, pt, j) = max(hits.items(), key=lambda kv: kv[1][0])
    layer_of = {id(r): idx for idx, rs in layers for r in rs}
    last = runs[prog.travels[k][2] - 1]
    where = layer_of.get(id(last))
    rep.problem(
        "travel_collision",
        s.travel_collision,
        f"{len(hits)} travel move{'s' if len(hits) != 1 else ''} (arc off) run{'' if len(hits) != 1 else 's'} into "
        f"metal welded before: the deepest after layer {where}, section {last.section or '?'}, {d:.1f} mm below "
        f"the top of layer {layer_of.get(id(runs[j]))}'s bead at ({pt[0]:.1f}, {pt[1]:.1f}, {pt[2]:.1f}): the torch "
        "would drive into the part. Lift before travelling (the post's travel height, or a retract the program "
        "lost)",
        layer=where,
        section=last.section,
        value=d,
        limit=depth,
        point=tuple(pt),
    )
