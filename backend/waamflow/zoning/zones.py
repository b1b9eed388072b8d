"""Zoning of section paths (Michel et al. 2019, step 5 and "3D zoning").

Each section path starts as one zone. The user splits it by *lengths* measured along the path from
its start and from its end (ignition and termination need their own parameters for a limited
length) and by *points*: a point cuts the path where it crosses the plane through the point normal to
the path's axis (the guide direction), i.e. exactly at the point's station along the section. Along the path the zones are, in order:

    start  [0, start_length)         — only when start_length > 0
    z1 … zK                          — between the start zone, the split points and the end zone
    end    [L − end_length, L]       — only when end_length > 0

The middle zones are numbered by the split points sorted along the path, so `z2` is always the
zone after the first split point, on every layer: ids are stable across layers and the XML
parameter file can address them. A middle zone of zero length on some layer (a split point projected
inside a length zone) does not appear on that layer.

3D zoning follows by construction: lengths are re-measured on every layer (length zones keep their
length), split points are projected on every layer's path (point zones stay at their points), and
the zones between stretch or shrink with the path.

If start_length + end_length exceed a path's length L, both are scaled down in proportion so they
meet (the path is all start and end zone).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..core.model import SectionPath
from ..core.tolerances import TOL

# Stable colours per zone id (fixed, colour-blind-friendlier palette): start red, end blue, middle
# zones cycle through the rest. The paper identifies zones in the XML by colour.
START_COLOR = "#d62728"
END_COLOR = "#1f77b4"
MIDDLE_COLORS = ("#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f")


def zone_color(zone_id: str) -> str:
    """The stable "#rrggbb" colour of a zone id ("start", "end", "z<k>")."""
    if zone_id == "start":
        return START_COLOR
    if zone_id == "end":
        return END_COLOR
    k = int(zone_id[1:]) if zone_id[1:].isdigit() else 1
    return MIDDLE_COLORS[(k - 1) % len(MIDDLE_COLORS)]


@dataclass(frozen=True)
class ZoneSpec:
    """How to split one section's path. Lengths in mm along the path; split_points (k, 2) layer-local mm."""

    start_length: float = 0.0
    end_length: float = 0.0
    split_points: tuple[tuple[float, float], ...] = field(default=())


@dataclass(frozen=True)
class ZoneLayout:
    """Zones of one path: ids in path order and their [from, to) arc-length intervals (mm)."""

    ids: tuple[str, ...]
    bounds: tuple[tuple[float, float], ...]
    total_length: float

    def length(self, zone_id: str) -> float:
        i = self.ids.index(zone_id)
        return self.bounds[i][1] - self.bounds[i][0]


def cumulative_length(points: np.ndarray) -> np.ndarray:
    """(n, 3) points → (n,) arc length at each point, mm."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(seg)])


def project_onto_path(points: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Arc length (mm) of the nearest point of the polyline `points` (n, 3) to each query (m, 3).

    A path that passes a point several times (weave strokes, parallel passes) projects it onto
    the nearest pass; on equal distance, the earliest along the path.
    """
    a, d = points[:-1], np.diff(points, axis=0)  # (k, 3)
    dd = np.einsum("ij,ij->i", d, d)
    q = np.asarray(query, dtype=float)[:, None, :]  # (m, 1, 3)
    t = np.clip(np.einsum("mkj,kj->mk", q - a[None], d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    foot = a[None] + t[..., None] * d[None]  # (m, k, 3)
    dist = np.einsum("mkj,mkj->mk", foot - q, foot - q)
    i = np.argmin(dist, axis=1)
    return cumulative_length(points)[i] + t[np.arange(len(i)), i] * np.sqrt(dd[i])


def path_axis(points: np.ndarray) -> np.ndarray:
    """(3,) unit vector: the principal direction of a path's points (its advance: the guide of an
    oscillated or parallel section), from the largest singular vector of the centred points."""
    pts = np.asarray(points, dtype=float)
    c = pts - pts.mean(axis=0)
    if not np.any(np.abs(c) > TOL.min_segment):
        return np.array([1.0, 0.0, 0.0])
    _, _, vt = np.linalg.svd(c, full_matrices=False)
    return vt[0] / np.linalg.norm(vt[0])


def split_arclength(points: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Arc length (mm) where the path `points` (n, 3) crosses the plane through each query (m, 3)
    normal to the path's axis (`path_axis`): the split point's projection along the section's
    guide, so a weave is cut exactly at the split point's station and not at its nearest weave
    vertex (issue #22: ±6 mm asked, −7.2/+4.8 mm got). Of several crossings (parallel passes)
    the one nearest the query wins, on ties the earliest. A query beyond the path's extent (no
    crossing) falls back to `project_onto_path`.
    """
    pts = np.asarray(points, dtype=float)
    q = np.asarray(query, dtype=float).reshape(-1, 3)
    axis = path_axis(pts)
    s = cumulative_length(pts)
    out = project_onto_path(pts, q) if len(q) else np.zeros(0)
    eps = TOL.min_segment
    for m, qq in enumerate(q):
        f = (pts - qq) @ axis  # signed station of each vertex past the query, mm
        fa, fb = f[:-1], f[1:]
        best = None
        for k in np.flatnonzero((np.minimum(fa, fb) <= eps) & (np.maximum(fa, fb) >= -eps)):
            a, b = pts[k], pts[k + 1]
            seg = s[k + 1] - s[k]
            if abs(fa[k]) <= eps and abs(fb[k]) <= eps:  # the segment lies in the plane
                d = b - a
                t = float(np.clip((qq - a) @ d / max(d @ d, 1e-18), 0.0, 1.0))
            else:
                t = float(np.clip(fa[k] / (fa[k] - fb[k]), 0.0, 1.0))
            p = a + t * (b - a)
            dist = float(np.linalg.norm(p - qq))
            if best is None or dist < best[0] - 1e-9:
                best = (dist, s[k] + t * seg)
        if best is not None:
            out[m] = best[1]
    return out


def zone_layout(path_length: float, spec: ZoneSpec, split_s: np.ndarray) -> ZoneLayout:
    """Zone ids and arc-length intervals of a path of length `path_length` (mm).

    split_s: arc lengths (mm) of the projected split points.
    """
    L = float(path_length)
    ls, le = max(spec.start_length, 0.0), max(spec.end_length, 0.0)
    if ls + le > L and ls + le > 0:
        scale = L / (ls + le)
        ls, le = ls * scale, le * scale
    lo, hi = ls, L - le
    cuts = [lo] + [float(np.clip(s, lo, hi)) for s in np.sort(np.asarray(split_s, dtype=float))] + [hi]
    ids: list[str] = []
    bounds: list[tuple[float, float]] = []
    if ls > 0:
        ids.append("start")
        bounds.append((0.0, lo))
    for k in range(len(cuts) - 1):
        if cuts[k + 1] - cuts[k] > TOL.min_segment:
            ids.append(f"z{k + 1}")
            bounds.append((cuts[k], cuts[k + 1]))
    if le > 0:
        ids.append("end")
        bounds.append((hi, L))
    return ZoneLayout(tuple(ids), tuple(bounds), L)


def insert_points(path: SectionPath, cut_s: list[float]) -> SectionPath:
    """A copy of `path` with a vertex at each arc length in cut_s (segments split, attributes copied)."""
    pts = np.asarray(path.points, dtype=float)
    s = cumulative_length(pts)
    new_s = np.array(
        sorted(
            c
            for c in cut_s
            if TOL.min_segment < c < s[-1] - TOL.min_segment and np.min(np.abs(s - c)) > TOL.min_segment
        )
    )
    if not len(new_s):
        return path
    seg = np.clip(np.searchsorted(s, new_s, side="right") - 1, 0, len(pts) - 2)
    t = (new_s - s[seg]) / np.where(s[seg + 1] > s[seg], s[seg + 1] - s[seg], 1.0)
    new_pts = pts[seg] + t[:, None] * (pts[seg + 1] - pts[seg])
    # new points lie strictly inside their segments, so sorting by arc length interleaves them
    all_s = np.concatenate([s, new_s])
    order = np.argsort(all_s, kind="stable")
    points = np.vstack([pts, new_pts])[order]
    mid = 0.5 * (all_s[order][:-1] + all_s[order][1:])
    parent = np.clip(np.searchsorted(s, mid, side="right") - 1, 0, len(pts) - 2)
    axis = None
    if path.tool_axis is not None:
        ax = np.asarray(path.tool_axis, dtype=float)
        new_ax = ax[seg] + t[:, None] * (ax[seg + 1] - ax[seg])
        new_ax /= np.maximum(np.linalg.norm(new_ax, axis=1, keepdims=True), 1e-12)
        axis = np.vstack([ax, new_ax])[order]
    return dataclasses.replace(
        path,
        points=points,
        arc=np.asarray(path.arc)[parent],
        inside=np.asarray(path.inside)[parent],
        speed=np.asarray(path.speed, dtype=float)[parent],
        zone=tuple(path.zone[i] for i in parent) if path.zone else (),
        tool_axis=axis,
    )


def zone_path(path: SectionPath, spec: ZoneSpec, split_points_world: np.ndarray | None = None) -> SectionPath:
    """Split `path` into zones per `spec`: vertices inserted at zone boundaries, per-segment zone ids
    and `zone_colors` set. split_points_world: (k, 3) world mm positions of spec.split_points (the
    caller maps layer-local points to world); None → spec.split_points at each path point's height.
    """
    pts = np.asarray(path.points, dtype=float)
    if len(pts) < 2:
        return dataclasses.replace(path, zone=(), zone_colors={})
    if split_points_world is None:
        sp = np.asarray(spec.split_points, dtype=float).reshape(-1, 2)
        split_points_world = np.column_stack([sp, np.full(len(sp), pts[:, 2].mean())])
    split_s = (
        split_arclength(pts, np.asarray(split_points_world, float).reshape(-1, 3))
        if len(split_points_world)
        else np.zeros(0)
    )
    layout = zone_layout(cumulative_length(pts)[-1], spec, split_s)
    cuts = [b[0] for b in layout.bounds[1:]]
    out = insert_points(path, cuts)
    s = cumulative_length(np.asarray(out.points))
    mid = 0.5 * (s[:-1] + s[1:])
    starts = np.asarray([b[0] for b in layout.bounds])
    zi = np.clip(np.searchsorted(starts, mid, side="right") - 1, 0, len(layout.ids) - 1)
    zones = tuple(layout.ids[i] for i in zi)
    colors = {z: zone_color(z) for z in layout.ids if z in set(zones)}
    return dataclasses.replace(out, zone=zones, zone_colors=colors, zone_params={})


_insert_points = insert_points


def zone_lengths(path: SectionPath) -> dict[str, float]:
    """Length (mm) of each zone of a zoned path, in path order."""
    out: dict[str, float] = {}
    for z, l in zip(path.zone, path.segment_lengths):
        out[z] = out.get(z, 0.0) + float(l)
    return out


def apply_zone_params(path: SectionPath, params: dict[str, dict[str, float]]) -> SectionPath:
    """Attach process parameters per zone (from the XML) and set the programmed speed.

    params: zone id → {parameter name: value} (names of core.process.ZONE_PARAMETERS). Each arc-ON
    segment of a zone with a `travel_speed` (mm/s) gets that speed; arc-OFF links inside a section
    are not deposition and keep the strategy's speed, as do zones with no travel speed given.
    """
    zp = {z: dict(v) for z, v in params.items() if z in path.zone_colors and v}
    speed = np.asarray(path.speed, dtype=float).copy()
    arc = np.asarray(path.arc, dtype=bool)
    for z, vals in zp.items():
        ts = vals.get("travel_speed")
        if ts is not None:
            sel = np.fromiter((zz == z for zz in path.zone), bool, len(path.zone)) & arc
            speed[sel] = ts
    return dataclasses.replace(path, zone_params=zp, speed=speed)


def with_weld_defaults(path: SectionPath, values: dict[str, float]) -> SectionPath:
    """The path with `values` (zone parameter → value) in every welded zone that does not state
    them: the process a recipe or a model holds at, never over what a zone says. A path without an
    arc-ON segment is returned as it is."""
    arc = np.asarray(path.arc, bool)
    zones = {path.zone[i] if i < len(path.zone) else "" for i in np.flatnonzero(arc)}
    if not zones:
        return path
    params = {z: dict(v) for z, v in path.zone_params.items()}
    for z in zones:
        for name, value in values.items():
            params.setdefault(z, {}).setdefault(name, float(value))
    return dataclasses.replace(path, zone_params=params)
