"""Fan slicing in sections, each with its own axis (Rauch et al. 2021, parts too curved for the bead
range), always ending on the part's end face.

Section k starts on a *start half-plane* (the part's start plane, then the top plane of the
previous section's last layer). Its axis lies in that half-plane — so the start plane is one of
its fan planes and no layer is left open or off level between sections.

Rauch's iteration, N = 1, 2, … up to `max_sections`: the first N − 1 sections are greedy — axis at
the projection of the part's own curvature axis (the given axis) moved outward, away from the
part, by an offset d (multiples of `step` up to `max_offset`), Δθ tried across the first layer's
admissible window [H_min/r_min, H_max/r_max], layers added while each layer's heights r·Δθ stay in
[H_min, H_max], its overhang over the previous layer (boundary projected onto the previous cut
plane, distance outside its region) within `max_overhang`, its cross-section closed (same holes
as the part's start section) and its top plane inside the part; the longest sweep (then smallest
d) wins. The section before the last stops on the layer from whose top the closing fan fits
best. The last section *closes*: its axis is the line where its start plane meets the part's end
face (`end_plane`), so the end face is its last fan plane, with n layers of Δθ = α/n (n balancing
the excess at both ends of the height range). N = 1 is the one fan through the start plane and
the end face: about the bend axis when both faces contain it.

A plan's cost is its worst layer's excess (mm) of heights over [H_min, H_max] or overhang over
`max_overhang`; the first N with cost 0 wins, otherwise the cheapest, and the search stops once
one more section does not help (each greedy section lags the part's turn further, and the
closing fan only gets worse) — judged first from the vertices alone (`estimate`), so a part no
section helps costs one fan's slicing. The caller decides whether the cost is tolerable.

Why a bent wall may have no plan in range: its layers' heights at the outer and inner wall add
up to the outer and inner wall lengths, so some layer needs at least their ratio
(R + w/2)/(R − w/2) where the bead gives H_max/H_min; no choice of sections beats that, sections
only move the excess around — greedy ones into the last section, which the best closed plan
spreads over every layer instead.

All lengths mm, angles rad unless named _deg. Cross-sections come from `fan.FanSections`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

from ..core.model import Layer, MeshData, region_polygons
from .fan import MAX_FAN_LAYERS, FanAxis, FanSections, angular_range, make_axis


DTHETA_TRIES = 5  # Δθ values tried across the first layer's admissible window, per offset


@dataclass(frozen=True)
class FanSection:
    """axis: the section's axis (its θ = 0 is the section's start half-plane); offset: how far it
    was moved outward from the part's curvature axis (mm, negative: towards the part); dtheta
    (rad); layers: count; fits: whether every layer's heights and overhang were within bounds and
    every layer closed. excess: how far (mm) its worst layer's heights r·Δθ (or overhang) leave
    their bounds, at layer `worst_layer`; open_layer: the first layer whose cross-section is open
    (the plane crosses an end face), None when all are closed. Layer indices count from the part's
    first layer."""

    axis: FanAxis
    offset: float
    dtheta: float
    layers: int
    fits: bool
    excess: float = 0.0
    worst_layer: int | None = None
    open_layer: int | None = None

    def to_json(self) -> dict:
        return {
            "axis_point": np.round(self.axis.point, 6).tolist(),
            "offset_mm": round(self.offset, 6),
            "dtheta_deg": round(math.degrees(self.dtheta), 6),
            "layers": self.layers,
            "fits": self.fits,
            "excess_mm": round(self.excess, 6),
            "worst_layer": self.worst_layer,
            "open_layer": self.open_layer,
        }


@dataclass(frozen=True)
class _Cut:
    region: Any  # MultiPolygon in the cut plane's half-plane coordinates
    frame: np.ndarray  # (4, 4) mid (cut) plane frame
    top: np.ndarray  # (4, 4) top plane frame


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


def topology(region) -> tuple[int, ...]:
    """Shape signature of a cross-section: the hole counts of its polygons, sorted. A slicing plane
    that crosses the part's end (or start) face leaves an *open* layer: a ring cut into a C, one
    hole fewer than the part's own cross-section."""
    return tuple(sorted(len(p.interiors) for p in region_polygons(region)))


def _excess(region, dtheta: float, h_min: float, h_max: float) -> float:
    """How far (mm) the layer's heights r·Δθ leave [h_min, h_max] (0 inside)."""
    minx, _y0, maxx, _y1 = region.bounds
    return max(h_min - minx * dtheta, maxx * dtheta - h_max, 0.0)


def _sweep(
    section: FanSections,
    axis: FanAxis,
    dtheta: float,
    h_min: float,
    h_max: float,
    max_over: float,
    prev: _Cut | None,
    limit: int,
    shape: tuple[int, ...] | None,
) -> list[_Cut]:
    """Layers of Δθ about `axis` from its θ = 0. With `shape` (strict): only while each layer's
    heights and overhang fit, its cross-section is closed (topology `shape`) and its top plane
    stays within the part (a layer reaching past the last vertex is left to the closing fan, which
    ends on the end face exactly); without: up to `limit` layers or the part's end."""
    cuts: list[_Cut] = []
    if shape is not None:
        limit = min(limit, int(math.floor((axis.polar(section.vertices)[1].max() + ANGLE_TOL) / dtheta)))
    for j in range(limit):
        mid = (j + 0.5) * dtheta
        region = section(axis, mid)
        if region.is_empty:
            return cuts
        cut = _Cut(region, axis.frame(mid), axis.frame((j + 1) * dtheta))
        if shape is not None:
            minx, _y0, maxx, _y1 = region.bounds
            ok = minx > 0 and minx * dtheta >= h_min * (1 - 1e-9) and maxx * dtheta <= h_max * (1 + 1e-9)
            last = cuts[-1] if cuts else prev
            if not ok or topology(region) != shape or (last is not None and _overhang(last, cut) > max_over):
                return cuts
        cuts.append(cut)
    return cuts


ANGLE_TOL = 1e-6  # rad: vertices this close to a plane lie on it (float32 STL rounding ~1e-7 rad at 300 mm)


def end_plane(mesh: MeshData, axis0: FanAxis, theta_max: float) -> FanAxis:
    """The part's end face as a fan half-plane (its θ = 0): the plane of the largest mesh face at
    the part's last vertex about `axis0` (angle θ_max) facing the build direction; its axis line is
    that plane's line through the projection of axis0's point. Raises ValueError when that face is
    not parallel to the slicing axis (no fan of half-planes about a parallel axis can end on it)."""
    verts = np.asarray(mesh.vertices, float)
    faces = np.asarray(mesh.faces)
    _r, th, _a = axis0.polar(verts)
    top = int(np.argmax(th))
    at = faces[(faces == top).any(axis=1)]
    n = np.cross(verts[at[:, 1]] - verts[at[:, 0]], verts[at[:, 2]] - verts[at[:, 0]])
    area = np.linalg.norm(n, axis=1)
    fwd = axis0.tangential(theta_max)
    ok = (area > 0) & ((n @ fwd) > 0.5 * np.maximum(area, 1e-300))
    if not ok.any():
        raise ValueError("the part's end has no face facing the build direction at its last vertex")
    k = int(np.argmax(np.where(ok, area, -1.0)))
    normal = n[k] / area[k]
    u = axis0.direction
    if abs(normal @ u) > 1e-3:
        raise ValueError(
            f"the part's end face is {math.degrees(math.asin(min(1.0, abs(normal @ u)))):.2f}° off "
            "parallel to the slicing axis: no fan about an axis of that direction can end on it; "
            "set axis_direction parallel to the end face (and to the start face)"
        )
    normal = normal - (normal @ u) * u
    normal /= np.linalg.norm(normal)
    # one triangle of a float32 STL tilts by ~1e-5 rad: fit the plane to every vertex within
    # 0.01 mm of it (least squares across the face, the axial direction left out)
    t = np.cross(u, normal)
    d = verts - verts[top]
    near = np.abs(d @ normal) < 1e-2
    a, b = d[near] @ normal, d[near] @ t
    if len(a) >= 3 and np.ptp(b) > 0:
        k, m = np.polyfit(b, a, 1)
        normal = (normal - k * t) / math.hypot(1.0, k)
        origin = verts[top] + m * normal
    else:
        origin = verts[top]
    p = axis0.point - ((axis0.point - origin) @ normal) * normal
    er = np.cross(normal, u)  # e_θ = u × e_r ⇒ e_r = e_θ × u
    return FanAxis(p, u, er / np.linalg.norm(er))


def _closing(start: FanAxis, theta: float, end: FanAxis, theta_end: float, verts: np.ndarray):
    """The fan that closes the part from the half-plane θ of `start` onto its end half-plane
    (θ_end of `end`): its axis is where the two planes meet, so the start plane is its first and the
    end face its last fan plane — no open layer at either side. Returns (axis, wedge angle α rad,
    r_min, r_max of the unbuilt vertices about it), (None, 0, 0, 0) when nothing is left to build,
    or None when no fan closes the part (planes parallel, or meeting in front of / inside it)."""
    _r, th_s, _a = start.polar(verts)
    rest = verts[th_s > theta + ANGLE_TOL]
    if len(rest) == 0:
        return None, 0.0, 0.0, 0.0
    er_s, er_e = start.radial(theta), end.radial(theta_end)
    m = np.array([[er_s @ end.e0, -(er_e @ end.e0)], [er_s @ end.e1, -(er_e @ end.e1)]])
    if abs(np.linalg.det(m)) < 1e-9:
        return None
    dp = end.point - start.point
    a, _b = np.linalg.solve(m, [dp @ end.e0, dp @ end.e1])
    ax = FanAxis(start.point + a * er_s, start.direction, er_s)
    alpha = math.atan2(er_e @ ax.e1, er_e @ er_s)
    r, th, _a = ax.polar(rest)
    if not (0.0 < alpha < math.pi) or r.min() <= 0 or th.min() < -ANGLE_TOL or th.max() > alpha + ANGLE_TOL:
        return None
    return ax, alpha, float(r.min()), float(r.max())


def _layers_for(alpha: float, r_min: float, r_max: float, h_min: float, h_max: float) -> tuple[int, float]:
    """Layer count n for a wedge α (rad) whose heights span r_min..r_max·α/n, with the smallest
    excess over [h_min, h_max] (mm): (n, that excess)."""
    best = None
    n0 = alpha * (r_min + r_max) / (h_min + h_max)  # balances the two ends' excess
    for n in {max(1, math.floor(n0)), max(1, math.ceil(n0))}:
        e = max(h_min - r_min * alpha / n, r_max * alpha / n - h_max, 0.0)
        if best is None or (e, n) < best[::-1]:
            best = (n, e)
    assert best is not None  # the loop runs at least once
    return best


@dataclass
class _Plan:
    sections: list[FanSection]
    cuts: list[tuple[_Cut, float]]
    cost: float  # worst excess of heights (and overhang) over their bounds, mm
    open_layer: int | None = None
    worst_layer: int | None = None
    estimate: float = math.inf  # the closing fan's excess as estimated from the vertices (mm)


@dataclass(frozen=True)
class _Search:
    """What every section of one part's plan is searched with (`plan_sections`): the part's
    cross-sections and vertices, its curvature axis, end face and start-section topology, the
    axis offsets tried, the height range and the overhang limit (mm)."""

    section: FanSections
    verts: np.ndarray
    axis0: FanAxis
    end: FanAxis
    shape: tuple[int, ...]
    offsets: list[float]
    h_min: float
    h_max: float
    max_overhang: float

    def candidates(self, start: FanAxis, theta: float, prev: _Cut | None, budget: int):
        """Every strict sweep tried for a section starting on half-plane θ of `start`: (offset,
        axis, Δθ, cuts), and the greedy pick (most layers, then the smallest offset)."""
        out = []
        for d in self.offsets:
            ax = _axis_in_plane(start, theta, self.axis0.point, d)
            win = _window(self.section, ax, self.h_min, self.h_max)
            if win is None or win[0] > win[1]:
                continue
            for dth in np.linspace(win[0], win[1], DTHETA_TRIES):
                cuts = _sweep(
                    self.section, ax, float(dth), self.h_min, self.h_max, self.max_overhang, prev, budget, self.shape
                )
                if cuts:
                    out.append((d, ax, float(dth), cuts))
        best = max(out, key=lambda c: (len(c[3]), -c[0]), default=None)
        return out, best

    def close(self, start: FanAxis, theta: float, prev: _Cut | None, sections, cuts_all) -> _Plan | None:
        """The plan of `sections` then the fan closing the part from half-plane θ of `start` (None
        when no fan closes it or it would take too many layers)."""
        got = _closing(start, theta, self.end, 0.0, self.verts)
        if got is None:
            return None
        ax, alpha, r_min, r_max = got
        if ax is None:
            return _Plan(list(sections), list(cuts_all), 0.0, estimate=0.0)
        n, est = _layers_for(alpha, r_min, r_max, self.h_min, self.h_max)
        if len(cuts_all) + n > MAX_FAN_LAYERS:
            return None
        dth = alpha / n
        cuts = _sweep(self.section, ax, dth, self.h_min, self.h_max, self.max_overhang, prev, n, None)
        cost, worst, opened, last = 0.0, None, None, prev
        for j, c in enumerate(cuts):
            e = _excess(c.region, dth, self.h_min, self.h_max)
            if last is not None:
                e = max(e, _overhang(last, c) - self.max_overhang)
            if e > cost:
                cost, worst = e, len(cuts_all) + j
            if opened is None and topology(c.region) != self.shape:
                opened = len(cuts_all) + j
            last = c
        q = self.axis0.point - ((self.axis0.point - start.point) @ start.tangential(theta)) * start.tangential(theta)
        offset = float((q - ax.point) @ start.radial(theta))
        sec = FanSection(ax, offset, dth, len(cuts), cost <= 1e-9 and opened is None, cost, worst, opened)
        return _Plan(
            list(sections) + [sec],
            list(cuts_all) + [(c, dth) for c in cuts],
            math.inf if opened is not None else cost,
            opened,
            worst,
            est,
        )

    def closing_excess(self, ax: FanAxis, theta: float) -> float | None:
        """The excess (mm) of the fan closing the part from half-plane θ of `ax`, from the
        vertices alone (0 when nothing is left to build), None when no fan closes it."""
        got = _closing(ax, theta, self.end, 0.0, self.verts)
        if got is None:
            return None
        cax, alpha, r0, r1 = got
        return 0.0 if cax is None else _layers_for(alpha, r0, r1, self.h_min, self.h_max)[1]

    def estimate(self, start: FanAxis, theta: float) -> float:
        """Smallest closing excess (mm) over the sections that could start on half-plane θ of
        `start`, from the vertices alone: for each tried offset and Δθ, the layers whose wedge keeps
        the vertices' heights in range (overhang not checked), and the closing fan from about 12 of
        their top planes."""
        h_min, h_max = self.h_min, self.h_max
        out = math.inf
        for d in self.offsets:
            ax = _axis_in_plane(start, theta, self.axis0.point, d)
            win = _window(self.section, ax, h_min, h_max)
            if win is None or win[0] > win[1]:
                continue
            r, th, _a = ax.polar(self.verts)
            keep = th >= -ANGLE_TOL
            order = np.argsort(th[keep])
            ths, rs = th[keep][order], r[keep][order]
            rmin, rmax = np.minimum.accumulate(rs), np.maximum.accumulate(rs)
            for dth in np.linspace(win[0], win[1], DTHETA_TRIES):
                bad = np.flatnonzero((rmin * dth < h_min * (1 - 1e-9)) | (rmax * dth > h_max * (1 + 1e-9)))
                limit = ths[bad[0]] if len(bad) else ths[-1]
                reach = int(math.floor(limit / dth + 1e-9))
                for j in np.unique(np.linspace(1, reach, min(reach, 12)).round().astype(int)) if reach >= 1 else ():
                    e = self.closing_excess(ax, j * dth)
                    if e is not None:
                        out = min(out, e)
        return out

    def stop(self, tried):
        """Where to stop the section before the closing one, among the `tried` sweeps: the layer
        whose top plane the closing fan fits best from (vertex estimate), then the most layers,
        then the smallest offset. ((excess, -layers, offset), offset, axis, Δθ, cuts) or None."""
        pick = None
        for d, ax, dth, cuts in tried:
            for j in range(len(cuts), 0, -1):
                e = self.closing_excess(ax, j * dth)
                if e is None:
                    continue
                key = (e, -j, d)
                if pick is None or key < pick[0]:
                    pick = (key, d, ax, dth, cuts[:j])
        return pick


def plan_sections(
    mesh: MeshData,
    point,
    direction,
    h_min: float,
    h_max: float,
    *,
    max_overhang: float,
    step: float,
    max_offset: float,
    max_sections: int,
) -> tuple[tuple[FanSection, ...], tuple[Layer, ...]]:
    """Sections and their layers (see module doc). Layer conventions as `fan.fan_slice`; `z` is the
    running sum of layer thicknesses (mm). Every plan ends on the part's end face (its last
    section closes there); `FanSection.excess` says how far a section's heights (or overhang) leave
    their bounds and `open_layer` names a layer whose cross-section is open."""
    section = FanSections(mesh)
    axis0 = make_axis(point, direction, mesh.vertices)
    lo, hi = angular_range(axis0, mesh.vertices, mesh.faces)
    offsets = [k * step for k in range(int(math.floor(max_offset / step + 1e-9)) + 1)] if step > 0 else [0.0]
    search = _Search(
        section,
        section.vertices,
        axis0,
        end_plane(mesh, axis0, hi),
        topology(section(axis0, lo + 1e-3)),
        offsets,
        h_min,
        h_max,
        max_overhang,
    )

    # Rauch's iteration: N = 1, 2, … sections; the first N − 1 greedy (strict: heights, overhang,
    # closed layers), the one before the last stopping where the closing fan fits best
    best: _Plan | None = None
    start, theta, prev = axis0, lo, None
    sections: list[FanSection] = []
    cuts_all: list[tuple[_Cut, float]] = []
    for n_sec in range(1, max_sections + 1):
        if n_sec == 1:
            plan = search.close(start, theta, prev, sections, cuts_all)
            pick = None
        else:
            if best is not None and search.estimate(start, theta) >= best.estimate - 1e-6:
                break  # no stop of one more section closes better (vertex estimate): the slicing is the
                # cost here, so the exact search is skipped
            tried, greedy = search.candidates(start, theta, prev, MAX_FAN_LAYERS - len(cuts_all))
            plan = None
            # where to stop this section: the layer whose top plane the closing fan fits best from
            # (vertex estimate), then sliced exactly
            pick = search.stop(tried)
            if pick is not None:
                _k, d, ax, dth, cuts = pick
                plan = search.close(
                    ax,
                    len(cuts) * dth,
                    cuts[-1],
                    sections + [FanSection(ax, d, dth, len(cuts), True)],
                    cuts_all + [(c, dth) for c in cuts],
                )
        if plan is not None and pick is not None:
            plan.estimate = pick[0][0]
        if plan is not None and (best is None or plan.cost < best.cost - 1e-9):
            best = plan
        elif n_sec > 1:
            # one more section did not help: the greedy sections before the closing one lag the
            # part's turn further with each section, so the closing fan only gets worse
            break
        if best is not None and best.cost <= 1e-9 and best.open_layer is None:
            break
        if n_sec == max_sections:
            break
        # the next N: one more greedy section before the closing one
        if n_sec > 1:
            if greedy is None:
                break
            d, ax, dth, cuts = greedy
            sections.append(FanSection(ax, d, dth, len(cuts), True))
            cuts_all.extend((c, dth) for c in cuts)
            start, theta, prev = ax, len(cuts) * dth, cuts[-1]
    if best is None:
        raise ValueError(
            "no fan closes the part on its end face (the start and end planes meet inside or in "
            "front of it): check axis_point / axis_direction are the part's bend axis"
        )
    layers, z = [], 0.0
    for i, (c, dth) in enumerate(best.cuts):
        thickness = c.region.centroid.x * dth
        z += thickness
        layers.append(Layer(index=i, z=float(z), thickness=float(thickness), region=c.region, frame=c.top))
    return tuple(best.sections), tuple(layers)
