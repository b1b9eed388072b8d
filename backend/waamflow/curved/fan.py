"""Fan slicing: layers cut by half-planes that all contain one rotation axis (Rauch et al. 2021).

Geometry. The axis passes through `point` (mm) along unit `direction` u. Angles θ are measured
about u (right-hand rule) from the reference radial direction e0 ⟂ u, pointing from the axis to
the part's centroid; e_r(θ) = cos θ·e0 + sin θ·e1 with e1 = u × e0, and the build direction is
e_θ = u × e_r. Layers grow with θ: reverse `direction` to build from the other end.

Layer convention (see `core.model.Layer`). Layer j spans θ ∈ [θ_j − Δθ, θ_j]; its region is the
part's cross-section by the half-plane at mid-layer θ_j − Δθ/2, in *half-plane coordinates*:
local x = distance from the axis r (mm, > 0), local y = −(position along u) (mm). Its `frame`
maps those coordinates onto the *top* half-plane θ_j (origin on the axis, x = e_r(θ_j), y = −u,
z = e_θ(θ_j), the build direction), so `layer.to_world` lifts paths onto the deposition plane.
A fan layer is a wedge: its local height at a point is r·Δθ (Δθ in rad), i.e. x·Δθ.
`thickness` stores the height at the region's centroid, r̄·Δθ, so downstream nodes recover
Δθ = thickness / r̄ from the layer alone (`fan_dtheta`), and the height anywhere from x.
`z` is a monotonic layer coordinate: the running sum of the layers' thicknesses (mm, the height
along the part's centroid line); world positions come from `frame`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from shapely.geometry import MultiPolygon, box

from ..core.model import Layer, MeshData, as_multipolygon, region_polygons
from ..slicing.planar import MeshSections
from ..slicing.rings import loops_to_regions

MAX_FAN_LAYERS = 20_000
SNAP = 1e-5  # mm: vertices this close to a slicing plane lie on it (float32 STL rounding)


@dataclass(frozen=True)
class FanAxis:
    """point: (3,) mm on the axis. direction: (3,) unit u. e0: (3,) unit reference radial
    direction ⟂ u (θ = 0). All world coordinates."""

    point: np.ndarray
    direction: np.ndarray
    e0: np.ndarray

    @cached_property
    def e1(self) -> np.ndarray:
        return _cross(self.direction, self.e0)

    def radial(self, theta: float) -> np.ndarray:
        return math.cos(theta) * self.e0 + math.sin(theta) * self.e1

    def tangential(self, theta: float) -> np.ndarray:
        return _cross(self.direction, self.radial(theta))

    def frame(self, theta: float) -> np.ndarray:
        """(4, 4) half-plane frame at θ (rad): columns x = e_r, y = −u, z = e_θ, origin."""
        f = np.eye(4)
        f[:3, 0] = self.radial(theta)
        f[:3, 1] = -self.direction
        f[:3, 2] = self.tangential(theta)
        f[:3, 3] = self.point
        return f

    def polar(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(n, 3) world points → r (mm, distance from the axis), θ (rad in (−π, π]), axial (mm)."""
        d = np.asarray(pts, float) - self.point
        ax = d @ self.direction
        a, b = d @ self.e0, d @ self.e1
        return np.hypot(a, b), np.arctan2(b, a), ax


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b of two 3-vectors: np.cross's formula without its ~20 µs of set-up per call (fan
    slicing asks for thousands of frames)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _reference(point: np.ndarray, u: np.ndarray, part_vertices: np.ndarray) -> np.ndarray:
    c = np.asarray(part_vertices, float).mean(axis=0) - point
    e0 = c - (c @ u) * u
    if np.linalg.norm(e0) < 1e-9:
        raise ValueError("the part's centroid lies on the slicing axis: no fan direction")
    return e0 / np.linalg.norm(e0)


def make_axis(
    point, direction, part_vertices: np.ndarray, radius_offset: float = 0.0, part_faces: np.ndarray | None = None
) -> FanAxis:
    """Axis through `point` along `direction`, e0 towards the part's vertex centroid.

    `radius_offset` (mm) moves the axis outward *within the part's start half-plane*, away from
    the part (along −e_r(θ_min)): the slicing radius grows by the offset while the start plane
    stays a fan plane, so layer 0 still sits flat on the substrate."""
    u = np.asarray(direction, float)
    if np.linalg.norm(u) == 0:
        raise ValueError("axis direction is the zero vector")
    u = u / np.linalg.norm(u)
    p = np.asarray(point, float)
    axis = FanAxis(p, u, _reference(p, u, part_vertices))
    if radius_offset == 0.0:
        return axis
    lo, _hi = angular_range(axis, part_vertices, part_faces)
    moved = p - radius_offset * axis.radial(lo)
    return FanAxis(moved, u, _reference(moved, u, part_vertices))


def angular_range(axis: FanAxis, vertices: np.ndarray, faces: np.ndarray | None = None) -> tuple[float, float]:
    """(θ_min, θ_max) rad of the part about the axis. The part must not wrap around the axis:
    the half-plane in the middle of the largest angular gap between vertices must not cut any
    edge (checked when `faces` (m, 3) are given)."""
    d = np.asarray(vertices, float) - axis.point
    a, b = d @ axis.e0, d @ axis.e1
    th = np.arctan2(b, a)
    s = np.sort(th)
    gaps = np.diff(np.concatenate([s, [s[0] + 2 * math.pi]]))
    k = int(np.argmax(gaps))
    # the largest empty gap is where the part is not: the range is its complement
    lo, hi = s[(k + 1) % len(s)], s[k]
    if lo > hi:
        lo -= 2 * math.pi
    mid = hi + gaps[k] / 2.0
    if faces is not None:
        # rotate so the gap's mid half-plane is the +x ray; an edge crossing it has ends on both
        # sides of y = 0 and meets y = 0 at x > 0
        c, sn = math.cos(mid), math.sin(mid)
        x, y = a * c + b * sn, -a * sn + b * c
        e = np.asarray(faces)[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        ya, yb = y[e[:, 0]], y[e[:, 1]]
        cross = ya * yb < 0
        t = ya[cross] / (ya[cross] - yb[cross])
        xc = x[e[cross, 0]] + t * (x[e[cross, 1]] - x[e[cross, 0]])
        if np.any(xc > 0):
            raise ValueError("the part surrounds the slicing axis: a fan of half-planes cannot slice it")
    elif gaps[k] < 1e-3:
        raise ValueError("the part surrounds the slicing axis: a fan of half-planes cannot slice it")
    return float(lo), float(hi)


class FanSections:
    """Half-plane sections of one closed mesh about any axis. The mesh's edge matching is done
    once (`slicing.planar.MeshSections`); each section turns the vertices into the half-plane's
    frame and cuts them by its plane in one vectorised pass, nests the loops into polygons with
    holes (`slicing.rings`) and keeps the half on the part's side of the axis."""

    def __init__(self, mesh: MeshData):
        self.vertices = np.asarray(mesh.vertices, dtype=np.float64)
        self._sections = MeshSections(mesh.faces, len(self.vertices), name=mesh.name)

    def __call__(self, axis: FanAxis, theta: float) -> MultiPolygon:
        """Cross-section by the half-plane at θ (rad), in half-plane coordinates (x = r, y)."""
        # in the half-plane's frame (e_r, −u, e_θ), right-handed: the mesh keeps its winding,
        # outer loops stay CCW
        local = (self.vertices - axis.point) @ axis.frame(theta)[:3, :3]
        # a vertex on the plane up to rounding lies on it: the kernel's symbolic perturbation then
        # treats it exactly like a horizontal plane through a vertex. Rounding here is a float32
        # STL's (~1e-5 mm at 300 mm): a ring of vertices 1e-14..7e-7 mm off the plane, half snapped
        # at 1e-9, cut a bent tube's ring short (area 262 instead of 282 mm², tests/curved)
        local[np.abs(local[:, 2]) < SNAP, 2] = 0.0
        region = loops_to_regions(self._sections.loops(local, np.zeros(1)), 1)[0]
        if region.is_empty or region.bounds[0] >= 0.0:
            return region
        lo, hi = region.bounds[1] - 1.0, region.bounds[3] + 1.0
        half = box(0.0, lo, max(region.bounds[2], 0.0) + 1.0, hi)
        return as_multipolygon(region_polygons(region.intersection(half)))


@dataclass(frozen=True)
class FanPlan:
    """axis, Δθ (rad), θ_start (rad, the part's start plane) and the layers' top angles (rad)."""

    axis: FanAxis
    dtheta: float
    theta_start: float
    tops: np.ndarray
    r_mid: float


def plan_fan(mesh: MeshData, axis: FanAxis, dtheta_deg: float, *, layer_count: int | None = None) -> FanPlan:
    """Layer top angles: layer j tops at θ_start + (j+1)·Δθ while its mid plane lies in the part."""
    if not dtheta_deg > 0:
        raise ValueError("dtheta_deg must be > 0")
    dth = math.radians(dtheta_deg)
    lo, hi = angular_range(axis, mesh.vertices, mesh.faces)
    n = int(math.ceil((hi - lo) / dth - 0.5 - 1e-9))
    n = max(n, 1)
    if layer_count is not None:
        n = min(n, layer_count)
    if n > MAX_FAN_LAYERS:
        raise ValueError(f"{n} fan layers (Δθ {dtheta_deg}° over {math.degrees(hi - lo):.1f}°): too many")
    r, _th, _ax = axis.polar(mesh.vertices)
    tops = lo + dth * np.arange(1, n + 1)
    return FanPlan(axis, dth, lo, tops, float((r.min() + r.max()) / 2.0))


def fan_slice(mesh: MeshData, plan: FanPlan) -> tuple[Layer, ...]:
    """The fan layers of `mesh` (see module doc for the conventions)."""
    section = FanSections(mesh)
    layers = []
    z = 0.0
    for j, top in enumerate(plan.tops):
        region = section(plan.axis, float(top - plan.dtheta / 2.0))
        rbar = region.centroid.x if not region.is_empty else plan.r_mid
        z += rbar * plan.dtheta
        layers.append(
            Layer(
                index=j,
                z=float(z),
                thickness=float(rbar * plan.dtheta),
                region=region,
                frame=plan.axis.frame(float(top)),
            )
        )
    return tuple(layers)


# ------------------------------------------------------------------------------------------
# Reading fan layers downstream
# ------------------------------------------------------------------------------------------
def fan_dtheta(layer: Layer) -> float | None:
    """Δθ (rad) of a fan layer = thickness / r̄ (centroid x); None for a horizontal layer."""
    if layer.frame is None or layer.region.is_empty:
        return None
    return layer.thickness / layer.region.centroid.x


def local_height(layer: Layer, xy: np.ndarray) -> np.ndarray:
    """(n,) local layer height (mm) at layer-local points (n, 2): x·Δθ on a fan layer, else the
    layer thickness."""
    xy = np.asarray(xy, float).reshape(-1, 2)
    dth = fan_dtheta(layer)
    if dth is None:
        return np.full(len(xy), layer.thickness)
    return xy[:, 0] * dth


def to_local(layer: Layer, pts: np.ndarray) -> np.ndarray:
    """(n, 3) world points → (n, 2) layer-local (x, y) (inverse of `layer.to_world`)."""
    pts = np.asarray(pts, float).reshape(-1, 3)
    if layer.frame is None:
        return pts[:, :2].copy()
    d = pts - layer.frame[:3, 3]
    return np.column_stack([d @ layer.frame[:3, 0], d @ layer.frame[:3, 1]])


def height_range(layer: Layer) -> tuple[float, float]:
    """(min, max) local layer height over the layer's region (mm)."""
    dth = fan_dtheta(layer)
    if dth is None:
        return layer.thickness, layer.thickness
    minx, _miny, maxx, _maxy = layer.region.bounds
    return minx * dth, maxx * dth
