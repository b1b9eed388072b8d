"""Fan slicing in sections, each with its own axis (Rauch et al. 2021, parts too curved for the bead
range): a greedy sweep that cuts the part into consecutive fan sections.

Section k starts on a *start half-plane* (the part's start plane, then the top plane of the
previous section's last layer). Its axis lies in that half-plane — so the start plane is one of
its fan planes and no layer is left open or off level — at the projection of the part's own
curvature axis (the given axis) moved outward, away from the part, by an offset d (multiples of
`step` up to `max_offset`). For each d, Δθ is set from the first layer (middle of its admissible
window [H_min/r_min, H_max/r_max]) and layers are added while each layer's heights r·Δθ stay in
[H_min, H_max] and its overhang over the previous layer (boundary projected onto the previous cut
plane, distance outside its region) stays within `max_overhang`. The offset that reaches the
part's end wins at once (smallest such d); otherwise the one building the most layers, and the
next section starts on its last layer's top plane. With `max_sections` reached, the last section
builds the rest with its axis even where heights leave the range (the caller warns).

All lengths mm, angles rad unless named _deg. Cross-sections come from `fan.FanSections`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely

from ..core.model import Layer, MeshData
from .fan import MAX_FAN_LAYERS, FanAxis, FanSections, angular_range, make_axis


DTHETA_TRIES = 5  # Δθ values tried across the first layer's admissible window, per offset


@dataclass(frozen=True)
class FanSection:
    """axis: the section's axis (its θ = 0 is the section's start half-plane); offset: how far it
    was moved outward from the part's curvature axis (mm); dtheta (rad); layers: count; fits:
    whether every layer's heights and overhang were within bounds."""

    axis: FanAxis
    offset: float
    dtheta: float
    layers: int
    fits: bool

    def to_json(self) -> dict:
        return {"axis_point": np.round(self.axis.point, 6).tolist(), "offset_mm": round(self.offset, 6),
                "dtheta_deg": round(math.degrees(self.dtheta), 6), "layers": self.layers, "fits": self.fits}


@dataclass(frozen=True)
class _Cut:
    region: object          # MultiPolygon in the cut plane's half-plane coordinates
    frame: np.ndarray       # (4, 4) mid (cut) plane frame
    top: np.ndarray         # (4, 4) top plane frame


def _overhang(prev: _Cut, cur: _Cut, samples_per_mm: float = 1.0) -> float:
    """Largest distance (mm) of `cur`'s boundary, projected onto `prev`'s cut plane, outside
    `prev`'s region (generic 3D form of `feasibility.max_overhang`)."""
    if prev.region.is_empty or cur.region.is_empty:
        return 0.0
    # the boundary's vertices (its corners: where an overhang peaks) and points ≤ 1/samples_per_mm
    # apart between them (GEOS segmentize: ~100x faster than interpolating equidistant points)
    xy = shapely.get_coordinates(shapely.segmentize(cur.region.boundary, 1.0 / samples_per_mm))
    world = (np.column_stack([xy, np.zeros(len(xy)), np.ones(len(xy))]) @ cur.frame.T)[:, :3]
    d = world - prev.frame[:3, 3]
    local = np.column_stack([d @ prev.frame[:3, 0], d @ prev.frame[:3, 1]])
    # most of the boundary lies over the layer below: measure only the points outside it
    shapely.prepare(prev.region)
    out = ~shapely.contains_xy(prev.region, local[:, 0], local[:, 1])
    if not out.any():
        return 0.0
    return float(shapely.distance(prev.region, shapely.points(local[out])).max())


def _axis_in_plane(start: FanAxis, theta: float, base_point: np.ndarray, offset: float) -> FanAxis:
    """Axis in the half-plane θ of `start`: the projection of `base_point` onto that plane, moved
    by `offset` away from the part; its θ = 0 is that half-plane."""
    normal = start.tangential(theta)
    er = start.radial(theta)
    q = base_point - ((base_point - start.point) @ normal) * normal
    return FanAxis(q - offset * er, start.direction, er)


def _window(section: FanSections, axis: FanAxis, h_min: float, h_max: float) -> tuple[float, float] | None:
    """Admissible Δθ (rad) for the first layer about `axis`: [H_min/r_min, H_max/r_max] of the
    part's cross-section just past the start plane; None when the part has ended or the axis is
    inside it."""
    probe = section(axis, 1e-3)
    if probe.is_empty:
        return None
    minx, _y0, maxx, _y1 = probe.bounds
    if minx <= 0:
        return None
    return h_min / minx, h_max / maxx


def _sweep(section: FanSections, axis: FanAxis, dtheta: float, h_min: float, h_max: float, max_over: float, prev: _Cut | None,
           limit: int, strict: bool) -> tuple[list[_Cut], bool]:
    """Layers of Δθ about `axis` from its θ = 0, while (strict) heights and overhang fit.
    Returns (cuts, reached the part's end)."""
    cuts: list[_Cut] = []
    for j in range(limit):
        mid = (j + 0.5) * dtheta
        region = section(axis, mid)
        if region.is_empty:
            return cuts, True
        cut = _Cut(region, axis.frame(mid), axis.frame((j + 1) * dtheta))
        if strict:
            minx, _y0, maxx, _y1 = region.bounds
            ok = minx > 0 and minx * dtheta >= h_min * (1 - 1e-9) and maxx * dtheta <= h_max * (1 + 1e-9)
            last = cuts[-1] if cuts else prev
            if not ok or (last is not None and _overhang(last, cut) > max_over):
                return cuts, False
        cuts.append(cut)
    return cuts, False


def plan_sections(mesh: MeshData, point, direction, h_min: float, h_max: float, *, max_overhang: float,
                  step: float, max_offset: float, max_sections: int) -> tuple[tuple[FanSection, ...], tuple[Layer, ...]]:
    """Sections and their layers (see module doc). Layer conventions as `fan.fan_slice`; `z` is the
    running sum of layer thicknesses (mm)."""
    section = FanSections(mesh)
    axis0 = make_axis(point, direction, mesh.vertices)
    lo, _hi = angular_range(axis0, mesh.vertices, mesh.faces)
    start, theta = axis0, lo
    offsets = [k * step for k in range(int(math.floor(max_offset / step + 1e-9)) + 1)] if step > 0 else [0.0]
    sections: list[FanSection] = []
    cuts_all: list[tuple[_Cut, float]] = []
    prev: _Cut | None = None
    while len(cuts_all) < MAX_FAN_LAYERS:
        final = len(sections) == max_sections - 1
        best = None
        for d in offsets:
            ax = _axis_in_plane(start, theta, axis0.point, d)
            win = _window(section, ax, h_min, h_max)
            if win is None or win[0] > win[1]:
                continue
            # Δθ fixed per section: try across the first layer's window, keep the longest sweep
            for dth in np.linspace(win[0], win[1], DTHETA_TRIES):
                cuts, done = _sweep(section, ax, float(dth), h_min, h_max, max_overhang, prev,
                                    MAX_FAN_LAYERS - len(cuts_all), True)
                cand = (done, len(cuts), -d, ax, float(dth), cuts)
                if best is None or cand[:3] > best[:3]:
                    best = cand
                if done:
                    break
            if best is not None and best[0]:
                break
        fits = best is not None and best[1] > 0 and (best[0] or not final)
        if not fits:
            # last allowed section, or nothing fits: build on with the given axis (offset 0 if none
            # fitted), Δθ for the mean height at the first region's centroid; heights leave the range
            d = -best[2] if best is not None and best[1] > 0 else 0.0
            ax = _axis_in_plane(start, theta, axis0.point, d)
            probe = section(ax, 1e-3)
            if probe.is_empty:
                break
            dth = best[4] if best is not None and best[1] > 0 else (h_min + h_max) / 2.0 / max(probe.centroid.x, 1e-6)
            limit = MAX_FAN_LAYERS - len(cuts_all) if final else 1
            cuts, done = _sweep(section, ax, dth, h_min, h_max, max_overhang, prev, limit, False)
            if not cuts:
                break
        else:
            done, _n, _negd, ax, dth, cuts = best
            d = -_negd
        sections.append(FanSection(ax, d, dth, len(cuts), fits))
        cuts_all.extend((c, dth) for c in cuts)
        prev = cuts[-1]
        if done:
            break
        start, theta = ax, len(cuts) * dth
    layers, z = [], 0.0
    for i, (c, dth) in enumerate(cuts_all):
        thickness = c.region.centroid.x * dth
        z += thickness
        layers.append(Layer(index=i, z=float(z), thickness=float(thickness), region=c.region, frame=c.top))
    return tuple(sections), tuple(layers)
