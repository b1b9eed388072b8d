"""Travel moves through metal already welded (`travel_collision`).

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

Layers that are not horizontal planes (a fan of wedge layers about a bend) grow along each layer's
own build direction (torch.build_directions), so "lower" is along it: a travel sample within half a
bead width of an earlier run's centre line across that direction, and more than half a layer and
at most one and a half below it along it, is in that run's bead (each layer's runs stand for their
own layer's metal; together the layers below a run stand for the rest). Before, such programs'
travels were not checked: curved-duct's KRL with a move from layer 10's end back to layer 6's start
(through the four layers between) passed "ok".
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..core.pairs import pairs_between
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
    directions: np.ndarray | None = None,
) -> None:
    """The `travel_collision` problem (`s.travel_collision`); h: the layers' typical height;
    `directions`: each layer's build direction (torch.build_directions) when the layers are not
    horizontal planes, None for a planar program. out["travel_collisions"]: the travel moves found
    in the metal."""
    if s.travel_collision == "off" or not prog.travels or not prog.runs or not h or not width > 0:
        return
    depth = max(0.5 * h, 0.5)
    if directions is not None:
        _report(layers, prog, _hits_along(layers, prog, directions, h, depth, width), depth, out, rep, s)
        return
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
    _report(layers, prog, hits, depth, out, rep, s)


def _hits_along(
    layers: Sequence[tuple[int, list[Run]]],
    prog: ProgramRead,
    directions: np.ndarray,
    h: float,
    depth: float,
    width: float,
) -> dict[int, tuple[float, np.ndarray, int]]:
    """{travel: (depth in the metal along the build direction, point, the run)} of a program whose
    layers grow along `directions` (one per layer, nan: not judged): see the module doc."""
    runs = prog.runs
    layer_of = {id(r): k for k, (_i, rs) in enumerate(layers) for r in rs}
    grow = np.array([directions[layer_of[id(r)]] if id(r) in layer_of else np.full(3, np.nan) for r in runs])
    deepest = h + depth  # one layer's bead below its centre line, and the hop's allowance
    live = np.array([k for k, (_a, _b, done) in enumerate(prog.travels) if done > 0], int)
    if not len(live):
        return {}
    # every travel, and every run's segments, sampled in one call each
    pts, seg, _f = segment_samples(
        np.array([prog.travels[k][0] for k in live]), np.array([prog.travels[k][1] for k in live]), 0.25 * width
    )
    owner_a = live[seg]
    xyz, seg, _f = segment_samples(
        np.vstack([r.points[:-1] for r in runs]), np.vstack([r.points[1:] for r in runs]), 0.25 * width
    )
    run_no = np.repeat(np.arange(len(runs)), [len(r.points) - 1 for r in runs])[seg]
    i, j = pairs_between(pts, xyz, float(np.hypot(0.5 * width, deepest)))
    t = owner_a[i]
    done = np.array([tr[2] for tr in prog.travels])[t]
    g = grow[run_no[j]]
    v = xyz[j] - pts[i]
    d = np.einsum("ij,ij->i", v, g)  # nan where the layer has no direction: never a hit
    side = np.linalg.norm(v - d[:, None] * g, axis=1)
    hit = (run_no[j] < done) & (side < 0.5 * width) & (d > depth) & (d <= deepest)
    hits: dict[int, tuple[float, np.ndarray, int]] = {}
    for n in np.flatnonzero(hit)[np.argsort(-d[hit], kind="stable")]:  # deepest first
        k = int(t[n])
        if k not in hits:
            hits[k] = (float(d[n]), pts[i[n]], int(run_no[j[n]]))
    return hits


def _report(
    layers: Sequence[tuple[int, list[Run]]],
    prog: ProgramRead,
    hits: dict[int, tuple[float, np.ndarray, int]],
    depth: float,
    out: dict,
    rep: Any,
    s: Any,
) -> None:
    runs = prog.runs
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
