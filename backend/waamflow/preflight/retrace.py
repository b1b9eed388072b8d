"""The same stretch welded twice within one layer (`retrace`).

A run that goes again over a bead an earlier run of its layer laid lays a second bead on the first:
a hump one bead high. Before this check mpp-cross with its layer 3 block pasted twice (its
`layer 3` comment and all: one layer to the order check) passed "ok" without a remark: the layer's
coverage, top and order held and the wire balance stayed in its band; without `layer N` comments
two passes at one height are one layer too. Each run of a layer is sampled every quarter bead
width (only its segments whose box meets another run's, grown by the reach: the 500-layer cross
costs 0.04 s); a sample within `NEAR` of a bead width of a sample of an earlier run of its layer
lies on that run's bead when the two run the same way or back (within 20°): centre lines that close
overlap by more than 60 %; a neighbour at a step-over of half a width or more never does, and runs
that cross do not run together. A run's retraced share (its stretches together) against
`retrace_max_share`: a re-ignition's back-step or a parallel section's U-turn along a weave's leg
through MPP's crossing retrace a small share of their run."""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..core.pairs import close_pairs
from .read.core import Run
from .samples import segment_samples

NEAR = 3.0 / 8.0  # of a bead width: two samples closer are the same bead's centre line
STEP = 0.25  # of a bead width: the samples' spacing along a run
PARALLEL = float(np.cos(np.radians(20.0)))  # |cos| of the angle between two beads that run together


class _Segments:
    """The arc-ON segments of every run of the layers given, in program order, and which of them
    can meet another run of their layer (their box meets that run's, grown by the reach)."""

    def __init__(self, layers: Sequence[tuple[int, list[Run]]], reach: float) -> None:
        self.runs: list[Run] = []
        self.run_layer: list[int] = []  # each run's position in `layers`
        starts, ends, run_of, keep = [], [], [], []
        for li, (_idx, runs) in enumerate(layers):
            runs = [r for r in runs if len(r.points) > 1]
            if len(runs) < 2:
                continue
            lo = np.array([r.points.min(axis=0) for r in runs]) - reach
            hi = np.array([r.points.max(axis=0) for r in runs]) + reach
            touch = np.all((lo[:, None] <= hi[None]) & (lo[None] <= hi[:, None]), axis=2)
            np.fill_diagonal(touch, False)
            near = np.flatnonzero(touch.any(axis=1))
            if not len(near):
                continue
            a = np.vstack([runs[k].points[:-1] for k in near])
            b = np.vstack([runs[k].points[1:] for k in near])
            own = np.repeat(near, [len(runs[k].points) - 1 for k in near])
            if len(runs) > 32:  # a plan of many walls: the pair search sorts them out
                meets = touch[own].any(axis=1)
            else:
                slo, shi = np.minimum(a, b), np.maximum(a, b)
                meets = (np.all((slo[:, None] <= hi[None]) & (shi[:, None] >= lo[None]), axis=2) & touch[own]).any(
                    axis=1
                )
            starts.append(a)
            ends.append(b)
            run_of.append(own + len(self.runs))
            keep.append(meets)
            self.runs += [runs[k] for k in range(len(runs))]
            self.run_layer += [li] * len(runs)
        self.a = np.vstack(starts) if starts else np.zeros((0, 3))
        self.b = np.vstack(ends) if ends else np.zeros((0, 3))
        self.run = np.concatenate(run_of) if run_of else np.zeros(0, int)
        self.keep = np.concatenate(keep) if keep else np.zeros(0, bool)
        d = self.b - self.a
        self.length = np.linalg.norm(d, axis=1)
        self.unit = d / np.where(self.length > 0, self.length, 1.0)[:, None]
        # arc length at each segment's start along its run (segments of a run are consecutive)
        total = np.cumsum(self.length) - self.length
        first = np.r_[True, self.run[1:] != self.run[:-1]] if len(self.run) else np.zeros(0, bool)
        self.arc0 = total - np.maximum.accumulate(np.where(first, total, 0.0)) if len(total) else total

    def samples(self, step: float) -> tuple[np.ndarray, ...]:
        """Samples of the kept segments, each cut into pieces of at most `step`, both ends
        included: (points, directions, arc lengths along the run, segment numbers)."""
        k = np.flatnonzero(self.keep)
        pts, j, frac = segment_samples(self.a[k], self.b[k], step)
        seg = k[j]
        return pts, self.unit[seg], self.arc0[seg] + self.length[seg] * frac, seg


def _retraced_runs(
    layers: Sequence[tuple[int, list[Run]]], width: float
) -> list[tuple[float, float, int, Run, np.ndarray]]:
    """(share of its length, retraced mm, layer position, run, start of its longest retraced
    stretch) of each run retracing a bead width or more of earlier runs of its layer: one search
    for close pairs (core.pairs, a k-d tree's pairs without importing scipy) over the samples of
    every segment that can meet another run, each layer's apart."""
    segs = _Segments(layers, NEAR * width)
    if not segs.keep.any():
        return []
    pts, tangent, arc, seg = segs.samples(STEP * width)
    run = segs.run[seg]
    layer = np.asarray(segs.run_layer)[run]
    pairs = close_pairs(pts, NEAR * width, groups=layer)
    a, b = pairs[:, 0], pairs[:, 1]
    pairs = pairs[(run[a] != run[b]) & (np.abs(np.einsum("ij,ij->i", tangent[a], tangent[b])) >= PARALLEL)]
    flag = np.zeros(len(pts), bool)
    flag[np.where(run[pairs[:, 0]] > run[pairs[:, 1]], pairs[:, 0], pairs[:, 1])] = True  # runs in program order
    # stretches: flagged samples in a row, on one segment or the next of the same run
    adjacent = (run[1:] == run[:-1]) & (seg[1:] - seg[:-1] <= 1)
    begin = flag & ~np.r_[False, flag[:-1] & adjacent]
    end = flag & ~np.r_[flag[1:] & adjacent, False]
    first, last = np.flatnonzero(begin), np.flatnonzero(end)
    lengths = arc[last] - arc[first]
    total = np.bincount(run[first], weights=lengths, minlength=len(segs.runs))
    out = []
    for r in np.flatnonzero(total >= width):
        mine = run[first] == r
        pt = pts[first[mine][np.argmax(lengths[mine])]]
        out.append((float(total[r] / segs.runs[r].length), float(total[r]), segs.run_layer[r], segs.runs[r], pt))
    return out


def _layer_retrace(runs: list[Run], width: float) -> tuple[float, float, Run, np.ndarray] | None:
    """(the largest share of a run's length that retraces earlier runs, that length in mm, the
    run, the start of its longest retraced stretch) of one layer's runs; None when none retraces a
    bead width."""
    found = _retraced_runs([(0, runs)], width)
    if not found:
        return None
    share, length, _li, run, pt = max(found, key=lambda f: f[0])
    return share, length, run, pt


def retrace_problems(layers: Sequence[tuple[int, list[Run]]], width: float, out: dict, rep: Any, s: Any) -> None:
    """The `retrace` problem (`s.retrace`): the layers with a run that welds more than
    `s.retrace_max_share` of its length (and a bead width at least) over beads earlier runs of its
    layer laid; out["retrace_share"]: the largest such share of the program (0 when none)."""
    if s.retrace == "off" or not width > 0:
        return
    worst: tuple[float, float, int, Run, np.ndarray] | None = None
    bad: list[int] = []
    for share, length, li, run, pt in _retraced_runs(layers, width):
        idx = layers[li][0]
        if worst is None or share > worst[0]:
            worst = (share, length, idx, run, pt)
        if share > s.retrace_max_share and idx not in bad:
            bad.append(idx)
    out["retrace_share"] = round(float(worst[0]), 4) if worst is not None else 0.0
    if not bad or worst is None:
        return
    share, length, idx, run, pt = worst
    more = f" ({len(bad)} layers in all: {', '.join(map(str, bad[:8]))}{', …' if len(bad) > 8 else ''})"
    rep.problem(
        "retrace",
        s.retrace,
        f"layer {idx}, section {run.section or '?'}: an arc-ON run welds {length:.1f} mm, {share:.0%} of its "
        f"{run.length:.1f} mm, over beads earlier runs of its layer laid (from ({pt[0]:.1f}, {pt[1]:.1f}, "
        f"{pt[2]:.1f})){more if len(bad) > 1 else ''}: a second bead on the first, a hump one bead high. A "
        "section or layer sent twice (the sequence, or a program edited by hand), or two walls of the part "
        "closer than a bead width (a thin solid's two faces read as a surface: read it as a solid); weld "
        "each stretch once",
        layer=idx,
        section=run.section,
        value=share,
        limit=s.retrace_max_share,
        point=tuple(pt),
    )
