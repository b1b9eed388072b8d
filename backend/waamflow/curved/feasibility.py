"""Feasibility of a fan-sliced part for a bead-height range, and the slicing-radius search
(Rauch et al. 2021, §§ on the curvature–size ratio and on parts too curved for the bead range).

Heights: a fan plan with increment Δθ needs r·Δθ at distance r from the axis; with the part's
radial extent r_min..r_max about the axis, some Δθ fits [H_min, H_max] iff r_min/r_max ≥
H_min/H_max, i.e. CSratio ≥ (1 + q)/(2(1 − q)) (see `bead.py`).

Overhang: moving the axis outward by `offset` mm (within the part's start plane, see
`fan.make_axis`) flattens the layers relative to the part, so consecutive layers shift sideways. Each boundary point of layer j+1 (half-plane coordinates
x = r, y) is projected onto the previous slicing plane — a rotation by Δθ about the axis puts it
at (x·cos Δθ, y) in that plane's coordinates — and its distance to layer j's region is the
overhang there (0 inside). The plan's overhang is the maximum over all layers.

Search: offsets 0, step, 2·step, … up to `max_offset`; the first one whose heights fit and whose
overhang is at most `max_overhang` wins (Δθ in the middle of the admissible window). When none
does, the part must be cut into more sections, each with its own axis: see `sections.py`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from shapely.geometry import MultiPolygon

from ..core.model import MeshData
from .bead import csratio, dtheta_window, min_csratio
from .fan import FanAxis, fan_slice, make_axis, plan_fan


@dataclass(frozen=True)
class Candidate:
    """One tried slicing radius: offset (mm), radial extent (mm), CSratio, Δθ window (deg),
    chosen Δθ (deg, NaN when heights do not fit), max overhang (mm, NaN when not computed)."""

    offset: float
    r_min: float
    r_max: float
    csratio: float
    dtheta_lo_deg: float
    dtheta_hi_deg: float
    dtheta_deg: float
    overhang: float
    feasible: bool

    def to_json(self) -> dict:
        def f(v):
            return None if (isinstance(v, float) and not math.isfinite(v)) else round(float(v), 6)

        return {
            "offset_mm": f(self.offset),
            "r_min_mm": f(self.r_min),
            "r_max_mm": f(self.r_max),
            "csratio": f(self.csratio),
            "dtheta_window_deg": [f(self.dtheta_lo_deg), f(self.dtheta_hi_deg)],
            "dtheta_deg": f(self.dtheta_deg),
            "max_overhang_mm": f(self.overhang),
            "feasible": self.feasible,
        }


@dataclass(frozen=True)
class SearchResult:
    """min_csratio: the bound for the bead range; candidates tried; best: the first feasible."""

    h_min: float
    h_max: float
    min_csratio: float
    candidates: tuple[Candidate, ...] = ()

    @property
    def best(self) -> Candidate | None:
        return next((c for c in self.candidates if c.feasible), None)

    @property
    def feasible(self) -> bool:
        return self.best is not None

    def to_json(self) -> dict:
        return {
            "h_min_mm": self.h_min,
            "h_max_mm": self.h_max,
            "min_csratio": round(self.min_csratio, 6),
            "feasible": self.feasible,
            "candidates": [c.to_json() for c in self.candidates],
            "best": self.best.to_json() if self.best else None,
        }


def max_overhang(regions: list[MultiPolygon], dtheta: float, samples_per_mm: float = 1.0) -> float:
    """Largest distance (mm) of a layer's boundary, projected onto the previous plane, outside the
    previous layer's region (see module doc). regions: half-plane regions, bottom to top."""
    worst = 0.0
    c = math.cos(dtheta)
    for prev, cur in zip(regions[:-1], regions[1:]):
        if prev.is_empty or cur.is_empty:
            continue
        bound = cur.boundary
        n = max(int(bound.length * samples_per_mm), 16)
        pts = (
            shapely.line_interpolate_point(bound, np.linspace(0, bound.length, n), normalized=False)
            if bound.geom_type == "LineString"
            else np.concatenate(
                [
                    shapely.line_interpolate_point(g, np.linspace(0, g.length, max(int(g.length * samples_per_mm), 16)))
                    for g in shapely.get_parts(bound)
                ]
            )
        )
        xy = shapely.get_coordinates(pts)
        proj = shapely.points(xy[:, 0] * c, xy[:, 1])
        worst = max(worst, float(shapely.distance(prev, proj).max()))
    return worst


def evaluate(
    mesh: MeshData,
    axis: FanAxis,
    offset: float,
    h_min: float,
    h_max: float,
    max_over: float,
    vertices: np.ndarray | None = None,
) -> Candidate:
    """Try one slicing radius: heights window, then (if it fits) the overhang of the fan plan."""
    verts = mesh.vertices if vertices is None else vertices
    ax = make_axis(axis.point, axis.direction, verts, offset, mesh.faces if vertices is None else None)
    r, _th, _a = ax.polar(verts)
    r_min, r_max = float(r.min()), float(r.max())
    lo, hi = dtheta_window(r_min, r_max, h_min, h_max)
    cs = csratio(r_min, r_max)
    if lo > hi:
        return Candidate(offset, r_min, r_max, cs, math.degrees(lo), math.degrees(hi), math.nan, math.nan, False)
    dth = (lo + hi) / 2.0
    plan = plan_fan(mesh, ax, math.degrees(dth))
    regions = [l.region for l in fan_slice(mesh, plan)]
    over = max_overhang(regions, dth)
    return Candidate(
        offset, r_min, r_max, cs, math.degrees(lo), math.degrees(hi), math.degrees(dth), over, over <= max_over
    )


def search_radius(
    mesh: MeshData,
    point,
    direction,
    h_min: float,
    h_max: float,
    *,
    max_overhang_mm: float,
    step: float,
    max_offset: float,
) -> SearchResult:
    """Smallest outward axis offset (multiples of `step` mm up to `max_offset`) that fits."""
    axis = make_axis(point, direction, mesh.vertices)
    out: list[Candidate] = []
    n = int(math.floor(max_offset / step + 1e-9)) if step > 0 else 0
    for k in range(n + 1):
        c = evaluate(mesh, axis, k * step, h_min, h_max, max_overhang_mm)
        out.append(c)
        if c.feasible:
            break
    return SearchResult(h_min, h_max, min_csratio(h_min, h_max), tuple(out))


def plan_report(layers, h_min: float, h_max: float) -> dict:
    """Feasibility of fan layers as sliced (from the layers alone): axis (from the frames), Δθ,
    radial extent of the regions, CSratio against its minimum, admissible Δθ window (first
    section), whether every layer's heights r·Δθ fit [h_min, h_max], the sections (consecutive
    layers about one axis) and per layer the local height range (mm)."""
    from .fan import fan_dtheta, height_range

    def dtheta(layer) -> float:
        d = fan_dtheta(layer)
        assert d is not None  # only for `filled` layers: a frame and a region, i.e. fan layers
        return d

    layers = [l for l in layers if l is not None]
    filled = [l for l in layers if not l.region.is_empty and l.frame is not None]
    if not filled:
        return {"layer_count": len(layers), "heights_fit": False}
    dth = dtheta(filled[0])
    bounds = np.array([l.region.bounds for l in filled])
    r_min, r_max = float(bounds[:, 0].min()), float(bounds[:, 2].max())
    lo, hi = dtheta_window(r_min, r_max, h_min, h_max)
    f = filled[0].frame
    sections: list[dict[str, Any]] = []
    fits = True
    for l in filled:  # consecutive layers about the same axis form a section
        origin = tuple(np.round(l.frame[:3, 3], 6))
        lo_h, hi_h = height_range(l)
        ok = lo_h >= h_min * (1 - 1e-9) and hi_h <= h_max * (1 + 1e-9)
        fits = fits and ok
        if not sections or sections[-1]["axis_point"] != list(origin):
            sections.append(
                {
                    "axis_point": list(origin),
                    "direction": (-l.frame[:3, 1]).round(9).tolist(),
                    "dtheta_deg": math.degrees(dtheta(l)),
                    "first_layer": l.index,
                    "layers": 0,
                    "heights_fit": True,
                }
            )
        sections[-1]["layers"] += 1
        sections[-1]["heights_fit"] = sections[-1]["heights_fit"] and ok
    return {
        "axis": {"point": f[:3, 3].round(6).tolist(), "direction": (-f[:3, 1]).round(9).tolist()},
        "dtheta_deg": math.degrees(dth),
        "layer_count": len(layers),
        "r_min_mm": r_min,
        "r_max_mm": r_max,
        "csratio": csratio(r_min, r_max),
        "h_min_mm": h_min,
        "h_max_mm": h_max,
        "min_csratio": min_csratio(h_min, h_max),
        "dtheta_window_deg": [math.degrees(lo), math.degrees(hi)],
        "heights_fit": fits,
        "sections": sections,
        "layers": [
            {
                "index": l.index,
                "thickness_mm": l.thickness,
                "height_min_mm": height_range(l)[0],
                "height_max_mm": height_range(l)[1],
            }
            for l in layers
        ],
    }
