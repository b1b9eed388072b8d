"""Interpass treatment paths: a rolling (or peening) pass over each layer's deposited beads
(MPP study: the A320 pylon bracket was planned "with in-process cold rolling planned by the same
tool"; issue 16).

The tool runs along the bead centre line (the arc-ON stretches of the layer's section paths) at
the bead top, z = the layer's height. A weaving strategy (`oscillate`) lays one wide bead along
its guide: there the centre line is the weave averaged over one period (`weave_centre`), so the
roller runs once along the weave instead of along every zig-zag leg. Because a rolling wheel cannot pivot under load, the centre
line is cut into strokes wherever its heading turns by more than `max_turn_deg`; each stroke is
simplified (Douglas-Peucker, `tolerance` mm — collinear points dropped, the path stays within the
tolerance of the bead centre) and flown as: approach from `clearance` mm above its start, lower
onto the bead, roll at `speed`, lift `clearance` mm at its end. Strokes shorter than
`min_stroke` mm are skipped (reported). A peening tool uses the same path (`tool` = "peening").
Each stroke is a tool section (`SectionPath.tool` = the tool, `tool_params` = force_n,
tool_width_mm, speed_mm_s): the post-processor engages the tool with the machine's command
carrying these values before the stroke's contact motions and lifts it after (program/plan.py).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import shapely
from shapely.geometry import LineString

from ..core.model import LayerPaths, Layered, SectionPath
from .interpass import climb


@dataclass(frozen=True)
class TreatmentSpec:
    tool: str = "rolling"  # rolling | peening
    tool_width_mm: float = 8.0
    force_n: float = 25_000.0  # rolling load (N); for peening: impact energy is set on the tool
    speed: float = 10.0  # mm/s along the bead
    clearance_mm: float = 10.0  # approach/retract height above the bead top
    max_turn_deg: float = 30.0  # a sharper turn ends the stroke (the wheel is lifted and turned)
    tolerance_mm: float = 0.05  # simplification tolerance of the centre line
    min_stroke_mm: float = 2.0


def _runs(sp: SectionPath) -> list[np.ndarray]:
    pts = np.asarray(sp.points, float)
    arc = np.asarray(sp.arc, bool)
    out, start = [], None
    for i, on in enumerate(np.concatenate([arc, [False]])):
        if on and start is None:
            start = i
        elif not on and start is not None:
            out.append(pts[start : i + 1])
            start = None
    return out


# Strategies that lay ONE bead along their guide by weaving the torch across it: the bead centre
# is the weave's centre line, not the torch path.
WEAVE_STRATEGIES = frozenset({"oscillate"})


def weave_centre(run: np.ndarray, max_turn_deg: float) -> np.ndarray | None:
    """Centre line of a weave (zig-zag torch path laying one wide bead): the torch path averaged
    over one weave period of arc length (a window of two legs: the mean of a symmetric zig-zag
    over a full period is its centre line), sampled every ≤ 0.25 mm where the whole window lies
    on the run — half a period is lost at each end. None when the run has fewer than three
    alternating sharp turns (no weave to average)."""
    p = np.asarray(run, float)
    d = np.diff(p, axis=0)
    L = np.linalg.norm(d, axis=1)
    keep = L > 1e-9
    if keep.sum() < 4:
        return None
    p = np.vstack([p[:1], p[1:][keep]])
    d, L = d[keep], L[keep]
    u = d[:, :2] / L[:, None]
    cross = u[:-1, 0] * u[1:, 1] - u[:-1, 1] * u[1:, 0]
    cos = np.einsum("ij,ij->i", u[:-1], u[1:])
    turns = np.flatnonzero(cos < np.cos(np.radians(max_turn_deg)))
    if len(turns) < 3 or np.any(np.sign(cross[turns][1:]) == np.sign(cross[turns][:-1])):
        return None
    s = np.concatenate([[0.0], np.cumsum(L)])
    legs = np.diff(s[turns + 1])
    period = 2.0 * float(np.median(legs))
    ds = min(0.25, period / 40.0)
    n_win = max(2, int(round(period / ds)))
    ds = period / n_win
    grid = np.arange(0.0, s[-1] + 1e-9, ds)
    if len(grid) <= n_win:
        return None
    samples = np.column_stack([np.interp(grid, s, p[:, k]) for k in range(p.shape[1])])
    # trapezoid mean over each window of n_win steps (exact for a piecewise-linear path sampled at its vertices' scale)
    mid = 0.5 * (samples[1:] + samples[:-1])
    csum = np.vstack([np.zeros((1, p.shape[1])), np.cumsum(mid, axis=0)])
    centre = (csum[n_win:] - csum[:-n_win]) / n_win
    return centre


def strokes(centre: np.ndarray, max_turn_deg: float) -> list[np.ndarray]:
    """Cut a polyline where its heading turns by more than max_turn_deg."""
    d = np.diff(centre, axis=0)
    L = np.linalg.norm(d, axis=1)
    keep = np.concatenate([[True], L > 1e-9])
    p = centre[keep]
    if len(p) < 2:
        return []
    u = np.diff(p, axis=0)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    cos = np.einsum("ij,ij->i", u[:-1], u[1:])
    cut = np.flatnonzero(cos < np.cos(np.radians(max_turn_deg))) + 1
    bounds = np.concatenate([[0], cut, [len(p) - 1]])
    return [p[a : b + 1] for a, b in zip(bounds[:-1], bounds[1:]) if b > a]


def plan_layer(lp: LayerPaths, spec: TreatmentSpec) -> tuple[tuple[SectionPath, ...], dict]:
    """Treatment section paths for one layer (one per stroke) and the layer's figures."""
    up = lp.layer.normal
    out, rolled, skipped, n = [], 0.0, 0, 0
    climbing: list[dict] = []
    for sp in lp.sections:
        c = climb(sp, lp.layer)
        if c is not None:  # a helix: its lower laps lie under the next before any treatment comes
            climbing.append({"section": sp.key, "laps": c.laps, "z_from": round(c.z_from, 3), "z_to": round(c.z_to, 3)})
            continue
        for run in _runs(sp):
            centre = weave_centre(run, spec.max_turn_deg) if sp.strategy in WEAVE_STRATEGIES else None
            for st in strokes(run if centre is None else centre, spec.max_turn_deg):
                line = LineString(st).simplify(spec.tolerance_mm, preserve_topology=False)
                pts = np.asarray(line.coords, float)
                if line.length < spec.min_stroke_mm:
                    skipped += 1
                    continue
                top = pts + 0.0 * up
                lift = top[-1] + spec.clearance_mm * up
                points = np.vstack([top, lift])
                k = len(points) - 1
                arc = np.zeros(k, bool)
                speed = np.full(k, spec.speed)
                speed[-1] = np.nan  # the lift flies at the machine's travel speed
                inside = np.ones(k, bool)
                inside[-1] = False
                out.append(
                    SectionPath(
                        key=f"{sp.key}/{spec.tool}{n}",
                        strategy=spec.tool,
                        points=points,
                        arc=arc,
                        inside=inside,
                        speed=speed,
                        approach=(top[0] + spec.clearance_mm * up)[None, :],
                        tool=spec.tool,
                        tool_params={
                            "force_n": spec.force_n,
                            "tool_width_mm": spec.tool_width_mm,
                            "speed_mm_s": spec.speed,
                        },
                    )
                )
                rolled += float(line.length)
                n += 1
    return tuple(out), {
        "layer": lp.index,
        "strokes": n,
        "rolled_length_mm": round(rolled, 3),
        "skipped_short": skipped,
        "skipped_climbing": climbing,
        "time_s": round(rolled / spec.speed, 3),
    }


def plan_treatment(toolpath: Layered, spec: TreatmentSpec, interleave: bool) -> tuple[Layered, dict]:
    """Treatment passes per layer: alone (its own program) or after each layer's deposition."""
    items: list[Any] = []
    rows: list[Any] = []
    for lp in toolpath.items:
        if lp is None:
            items.append(None)
            continue
        secs, row = plan_layer(lp, spec)
        rows.append(row)
        items.append(
            replace(
                lp,
                sections=(tuple(lp.sections) + secs) if interleave else secs,
                dwell_after_s=lp.dwell_after_s if interleave else 0.0,
            )
        )
    report = {
        "tool": spec.tool,
        "tool_width_mm": spec.tool_width_mm,
        "force_n": spec.force_n,
        "speed_mm_s": spec.speed,
        "clearance_mm": spec.clearance_mm,
        "max_turn_deg": spec.max_turn_deg,
        "interleaved": interleave,
        "strokes": sum(r["strokes"] for r in rows),
        "rolled_length_mm": round(sum(r["rolled_length_mm"] for r in rows), 3),
        "time_s": round(sum(r["time_s"] for r in rows), 3),
        "layers": rows,
    }
    return Layered(tuple(items)), report


def max_distance_to_centre(treatment: SectionPath, beads: list[np.ndarray]) -> float:
    """Largest distance (mm) from the rolling contact points (all but the lift) to the bead centre."""
    contact = np.asarray(treatment.points, float)[:-1]
    lines = shapely.union_all([LineString(b) for b in beads if len(b) >= 2])
    return float(max(lines.distance(shapely.points(p)) for p in contact))
