"""Display geometry for the 3D preview: pure functions from the project's values to arrays.

No viser here: every function takes model values (numpy / shapely) and returns plain arrays the
scene adapters hand to viser unchanged. All coordinates are world millimetres.

Shapes used throughout:
- segments: (m, 2, 3) float32 — start and end point of each of m line segments.
- vertices: (v, 3) float32, faces: (f, 3) uint32 — a triangle mesh.

Decimation is for display only: it returns new, smaller arrays and never touches the data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon

from ..core.model import Layer, LayerPaths, MeshData, Midsurface, region_polygons

# Outlines are simplified for display by this chord error (mm): well under a bead width
# (3-8 mm in WAAM), well over STL facet noise.
OUTLINE_SIMPLIFY_MM = 0.02


# --------------------------------------------------------------------------------------------
# Meshes
# --------------------------------------------------------------------------------------------
def mesh_arrays(mesh: MeshData) -> tuple[np.ndarray, np.ndarray]:
    """A MeshData as display arrays: (v, 3) float32 vertices, (f, 3) uint32 faces."""
    return (np.ascontiguousarray(mesh.vertices, dtype=np.float32), np.ascontiguousarray(mesh.faces, dtype=np.uint32))


def midsurface_arrays(mid: Midsurface) -> tuple[np.ndarray, np.ndarray]:
    """The midsurface's curves extruded from z0 to z0 + height as a two-sided strip mesh.

    Each curve of k points gives 2k vertices and 2(k - 1) triangles.
    """
    verts: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    base = 0
    for curve in mid.curves:
        c = np.asarray(curve, dtype=float).reshape(-1, 2)
        k = len(c)
        if k < 2:
            continue
        lo = np.column_stack([c, np.full(k, mid.z0)])
        hi = np.column_stack([c, np.full(k, mid.z0 + mid.height)])
        verts.append(np.vstack([lo, hi]))
        i = np.arange(k - 1) + base
        faces.append(np.column_stack([i, i + 1, i + k]))
        faces.append(np.column_stack([i + 1, i + 1 + k, i + k]))
        base += 2 * k
    if not verts:
        return np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint32)
    return np.vstack(verts).astype(np.float32), np.vstack(faces).astype(np.uint32)


# --------------------------------------------------------------------------------------------
# Polylines → segments
# --------------------------------------------------------------------------------------------
def polyline_segments(points: np.ndarray) -> np.ndarray:
    """(n, 3) polyline → (n - 1, 2, 3) float32 segments (empty for n < 2)."""
    p = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    if len(p) < 2:
        return np.zeros((0, 2, 3), np.float32)
    return np.stack([p[:-1], p[1:]], axis=1)


def _ring_world(layer: Layer, coords) -> np.ndarray:
    return layer.to_world(np.asarray(coords, dtype=float)[:, :2])


def layer_outline_segments(layer: Layer, simplify_mm: float = OUTLINE_SIMPLIFY_MM) -> tuple[np.ndarray, np.ndarray]:
    """Outlines of one layer at its deposition height.

    Returns (region segments (m, 2, 3), curve segments (k, 2, 3)): the exteriors and holes of the
    layer's region, and its open/closed midsurface curves. Rings are simplified by `simplify_mm`
    (display only).
    """
    rings: list[np.ndarray] = []
    for poly in region_polygons(layer.region):
        if simplify_mm > 0:
            simple = shapely.simplify(poly, simplify_mm, preserve_topology=True)
            poly = simple if isinstance(simple, Polygon) and not simple.is_empty else poly
        rings.append(polyline_segments(_ring_world(layer, poly.exterior.coords)))
        rings.extend(polyline_segments(_ring_world(layer, h.coords)) for h in poly.interiors)
    curves = [polyline_segments(_ring_world(layer, c.coords)) for c in layer.curves if len(c.coords) >= 2]
    empty = np.zeros((0, 2, 3), np.float32)
    return (np.concatenate(rings) if rings else empty), (np.concatenate(curves) if curves else empty)


# --------------------------------------------------------------------------------------------
# Section fills
# --------------------------------------------------------------------------------------------
def polygon_triangles(poly: Polygon) -> tuple[np.ndarray, np.ndarray]:
    """Constrained Delaunay triangulation of a polygon with holes (layer-local).

    Returns (v, 2) float64 vertices and (f, 3) uint32 faces; the triangles' total area equals the
    polygon's area.
    """
    if poly.is_empty:
        return np.zeros((0, 2)), np.zeros((0, 3), np.uint32)
    tris = shapely.get_parts(shapely.constrained_delaunay_triangles(poly))
    if len(tris) == 0:
        return np.zeros((0, 2)), np.zeros((0, 3), np.uint32)
    corners = shapely.get_coordinates(shapely.get_exterior_ring(tris)).reshape(len(tris), 4, 2)[:, :3]
    verts, inverse = np.unique(corners.reshape(-1, 2), axis=0, return_inverse=True)
    return verts, inverse.reshape(-1, 3).astype(np.uint32)


def section_fill(layer: Layer, region: Polygon) -> tuple[np.ndarray, np.ndarray]:
    """A section's region as a flat mesh at mid-layer (z - thickness/2), so the layer's toolpath
    (drawn at z) stays visible on top. Returns (v, 3) float32, (f, 3) uint32."""
    verts2, faces = polygon_triangles(region)
    world = layer.to_world(verts2) - layer.normal * (0.5 * layer.thickness)
    return world.astype(np.float32), faces


def guide_segments(layer: Layer, guide: LineString | None) -> np.ndarray:
    """A section guide polyline at the layer's height, (m, 2, 3)."""
    if guide is None or guide.is_empty:
        return np.zeros((0, 2, 3), np.float32)
    return polyline_segments(_ring_world(layer, guide.coords))


# --------------------------------------------------------------------------------------------
# Toolpaths
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class PathLayerDisplay:
    """The moves of one layer as display segments with per-segment attributes (length m).

    segments: (m, 2, 3) float32 mm. travel: bool, arc-OFF move (drawn faint) — approach moves,
    links between sections and arc-OFF segments of a path. arc: bool arc ON. speed: float mm/s
    programmed (NaN for travel). section: int index into `section_keys`. zone: int index into
    `zone_ids` (-1 for travel). zone_rgb: (m, 3) uint8 zone colour. n_source: segments before
    decimation.
    """

    segments: np.ndarray
    travel: np.ndarray
    arc: np.ndarray
    speed: np.ndarray
    section: np.ndarray
    zone: np.ndarray
    zone_rgb: np.ndarray
    section_keys: tuple[str, ...]
    zone_ids: tuple[str, ...]
    n_source: int

    def __len__(self) -> int:
        return len(self.segments)


@dataclass(frozen=True, eq=False)
class PathLayerPolyline:
    """One layer's moves as a single polyline (the data, not decimated): points (n, 3) mm and
    per-segment attributes of length n - 1, as in `PathLayerDisplay`."""

    points: np.ndarray
    travel: np.ndarray
    arc: np.ndarray
    speed: np.ndarray
    section: np.ndarray
    zone: np.ndarray
    zone_rgb: np.ndarray
    section_keys: tuple[str, ...]
    zone_ids: tuple[str, ...]


def layer_polyline(lp: LayerPaths) -> PathLayerPolyline:
    """Walk one layer's section paths in deposition order into a single polyline: each section's
    approach (arc-OFF travel from the previous section's end, through `approach`, to its first
    point), then its path. Colours come from the section's own `zone_colors` (the zone node's,
    as in the parameter XML); a path not zoned yet takes its section's palette colour."""
    from .colors import TRAVEL_RGB, categorical, zone_rgb

    pts: list[np.ndarray] = []
    attrs: dict[str, list[np.ndarray]] = {k: [] for k in ("travel", "arc", "speed", "section", "zone", "rgb")}
    keys: list[str] = []
    zone_ids: list[str] = []
    zone_index: dict[str, int] = {}

    def add(n, travel, arc, speed, section, zone, rgb):
        attrs["travel"].append(np.broadcast_to(np.asarray(travel, bool), (n,)))
        attrs["arc"].append(np.broadcast_to(np.asarray(arc, bool), (n,)))
        attrs["speed"].append(np.broadcast_to(np.asarray(speed, float), (n,)))
        attrs["section"].append(np.full(n, section, np.int32))
        attrs["zone"].append(np.broadcast_to(np.asarray(zone, np.int32), (n,)))
        attrs["rgb"].append(np.broadcast_to(np.asarray(rgb, np.uint8), (n, 3)))

    for sp in lp.sections:
        p = np.asarray(sp.points, dtype=float).reshape(-1, 3)
        if len(p) == 0:
            continue
        s_idx = len(keys)
        keys.append(sp.key)
        lead = [] if sp.approach is None else list(np.asarray(sp.approach, float).reshape(-1, 3))
        lead.append(p[0])
        if pts:
            add(len(lead), True, False, np.nan, s_idx, -1, TRAVEL_RGB)
            pts.append(np.asarray(lead))
        else:
            pts.append(np.asarray(lead))
            if len(lead) > 1:
                add(len(lead) - 1, True, False, np.nan, s_idx, -1, TRAVEL_RGB)
        n = len(p) - 1
        if n <= 0:
            continue
        zones = sp.zone if sp.zone else ("",) * n
        z_idx = np.empty(n, np.int32)
        rgb = np.empty((n, 3), np.uint8)
        for z in set(zones):
            if z not in zone_index:
                zone_index[z] = len(zone_ids)
                zone_ids.append(z)
        zarr = np.asarray(zones, dtype=object)
        for z, zi in zone_index.items():
            m = zarr == z
            if m.any():
                z_idx[m] = zi
                # before zoning (zone "") a path takes its section's colour instead of one grey
                rgb[m] = zone_rgb(z, sp.zone_colors) if z or z in sp.zone_colors else categorical(sp.key)
        arc = np.asarray(sp.arc, bool)
        add(n, ~arc, arc, np.asarray(sp.speed, float), s_idx, z_idx, rgb)
        pts.append(p[1:])

    if not pts:
        e = np.zeros(0)
        return PathLayerPolyline(
            np.zeros((0, 3)),
            e.astype(bool),
            e.astype(bool),
            e,
            e.astype(np.int32),
            e.astype(np.int32),
            np.zeros((0, 3), np.uint8),
            (),
            (),
        )
    cat = {k: (np.concatenate(v) if v else np.zeros(0)) for k, v in attrs.items()}
    return PathLayerPolyline(
        points=np.vstack(pts),
        travel=cat["travel"].astype(bool),
        arc=cat["arc"].astype(bool),
        speed=cat["speed"].astype(float),
        section=cat["section"].astype(np.int32),
        zone=cat["zone"].astype(np.int32),
        zone_rgb=cat["rgb"].reshape(-1, 3).astype(np.uint8),
        section_keys=tuple(keys),
        zone_ids=tuple(zone_ids),
    )


def decimate_indices(
    points: np.ndarray, seg_keys: np.ndarray, max_segments: int, corner_deg: float = 30.0
) -> np.ndarray:
    """Vertices of a polyline to keep so that at most about `max_segments` segments remain.

    points: (n, 3). seg_keys: (n - 1,) int codes of the per-segment attributes that must stay
    exact (zone, arc, section, travel): every vertex where the code changes is kept, so a kept
    span never mixes two codes. Also kept: the ends, sharp corners (turn > `corner_deg`), and
    every s-th vertex, s chosen to meet the budget. If the forced vertices alone exceed twice the
    budget, corners and then code changes are thinned by stride as well (display only).
    Returns sorted int indices into `points`.
    """
    n = len(points)
    if n - 1 <= max_segments or n < 3:
        return np.arange(n)
    max_segments = max(int(max_segments), 1)
    change = np.zeros(n, bool)
    change[1:-1] = seg_keys[1:] != seg_keys[:-1]
    d = np.diff(np.asarray(points, float), axis=0)
    L = np.linalg.norm(d, axis=1)
    u = d / np.where(L > 0, L, 1.0)[:, None]
    corner = np.zeros(n, bool)
    corner[1:-1] = np.einsum("ij,ij->i", u[:-1], u[1:]) < np.cos(np.radians(corner_deg))
    ends = np.zeros(n, bool)
    ends[[0, -1]] = True

    def strided(mask: np.ndarray, budget: int) -> np.ndarray:
        idx = np.flatnonzero(mask)
        if len(idx) <= budget:
            return mask
        out = np.zeros(n, bool)
        out[idx[:: int(np.ceil(len(idx) / max(budget, 1)))]] = True
        return out

    forced = ends | change | corner
    if forced.sum() > 2 * max_segments:
        forced = ends | strided(change, max_segments) | strided(corner, max_segments // 2)
    room = max(max_segments - int(forced.sum()), max_segments // 4)
    stride = int(np.ceil((n - 1) / room))
    keep = forced.copy()
    keep[::stride] = True
    return np.flatnonzero(keep)


def path_display(poly: PathLayerPolyline, max_segments: int) -> PathLayerDisplay:
    """Display segments of one layer's polyline, decimated to about `max_segments`.

    A kept span takes the attributes of its first source segment (spans never mix zone, arc,
    section or travel state, see `decimate_indices`).
    """
    n = len(poly.points)
    if n < 2:
        z = np.zeros(0)
        return PathLayerDisplay(
            np.zeros((0, 2, 3), np.float32),
            z.astype(bool),
            z.astype(bool),
            z,
            z.astype(np.int32),
            z.astype(np.int32),
            np.zeros((0, 3), np.uint8),
            poly.section_keys,
            poly.zone_ids,
            0,
        )
    codes = (poly.zone.astype(np.int64) + 1) * 4 + poly.arc * 2 + poly.travel
    codes = codes * (len(poly.section_keys) + 1) + poly.section
    keep = decimate_indices(poly.points, codes, max_segments)
    first = keep[:-1]
    pts = poly.points[keep].astype(np.float32)
    segs = np.stack([pts[:-1], pts[1:]], axis=1)
    return PathLayerDisplay(
        segments=segs,
        travel=poly.travel[first],
        arc=poly.arc[first],
        speed=poly.speed[first],
        section=poly.section[first],
        zone=poly.zone[first],
        zone_rgb=poly.zone_rgb[first],
        section_keys=poly.section_keys,
        zone_ids=poly.zone_ids,
        n_source=n - 1,
    )


# --------------------------------------------------------------------------------------------
# Simulated trajectory
# --------------------------------------------------------------------------------------------
def trace_points(trace: dict[str, np.ndarray]) -> np.ndarray:
    """(n, 3) float world mm of a simulation trace (keys x, y, z)."""
    return np.column_stack([np.asarray(trace[k], float).reshape(-1) for k in ("x", "y", "z")])


def split_by_layer(layer: np.ndarray) -> dict[int, np.ndarray]:
    """Sample indices per layer: {layer index: (k,) int indices}, in sample order.

    A layer's chunk also takes the first sample of the next chunk, so the polyline drawn per
    layer has no gap where one layer hands over to the next.
    """
    layer = np.asarray(layer).astype(np.int64).reshape(-1)
    if len(layer) == 0:
        return {}
    starts = np.flatnonzero(np.r_[True, layer[1:] != layer[:-1]])
    stops = np.r_[starts[1:], len(layer)]
    out: dict[int, list[np.ndarray]] = {}
    for a, b in zip(starts, stops):
        out.setdefault(int(layer[a]), []).append(np.arange(a, min(b + 1, len(layer))))
    return {k: np.concatenate(v) for k, v in out.items()}


def chunk_segments(
    points: np.ndarray, idx: np.ndarray, max_segments: int, keys: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Segments along points[idx] (consecutive runs of idx only), decimated to ~`max_segments`.

    Returns ((m, 2, 3) float32 segments, (m,) int index of each segment's first source sample).
    """
    idx = np.asarray(idx, np.int64)
    if len(idx) < 2:
        return np.zeros((0, 2, 3), np.float32), np.zeros(0, np.int64)
    runs = np.r_[0, np.flatnonzero(np.diff(idx) != 1) + 1, len(idx)]
    segs, firsts = [], []
    budget = max(int(max_segments), 1)
    total = max(len(idx) - 1, 1)
    for a, b in zip(runs[:-1], runs[1:]):
        run = idx[a:b]
        if len(run) < 2:
            continue
        k = np.zeros(len(run) - 1, np.int64) if keys is None else np.asarray(keys)[run[:-1]]
        keep = decimate_indices(points[run], k, max(1, budget * (len(run) - 1) // total))
        p = points[run[keep]].astype(np.float32)
        segs.append(np.stack([p[:-1], p[1:]], axis=1))
        firsts.append(run[keep[:-1]])
    if not segs:
        return np.zeros((0, 2, 3), np.float32), np.zeros(0, np.int64)
    return np.concatenate(segs), np.concatenate(firsts)


def interpolate_trace(trace: dict[str, np.ndarray], t: float) -> tuple[np.ndarray, int]:
    """Position (3,) mm on the trace at time t (s, clipped to the trace), and the index of the
    sample at or before t."""
    times = np.asarray(trace["t"], float).reshape(-1)
    pts = trace_points(trace)
    if len(times) == 0:
        return np.zeros(3), 0
    t = float(np.clip(t, times[0], times[-1]))
    i = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 1))
    if i + 1 >= len(times) or times[i + 1] <= times[i]:
        return pts[i], i
    f = (t - times[i]) / (times[i + 1] - times[i])
    return pts[i] * (1 - f) + pts[i + 1] * f, i


# --------------------------------------------------------------------------------------------
# Picking
# --------------------------------------------------------------------------------------------
def ray_pick(points: np.ndarray, origin, direction, max_distance: float) -> int | None:
    """Index of the point closest to a ray (perpendicular distance, mm), or None if none lies
    within `max_distance` in front of the origin. Among near-equal candidates (within 10 % of
    `max_distance`) the one nearest the origin wins, i.e. the visible one."""
    p = np.asarray(points, float).reshape(-1, 3)
    if len(p) == 0:
        return None
    o = np.asarray(origin, float)
    d = np.asarray(direction, float)
    d = d / np.linalg.norm(d)
    rel = p - o
    along = rel @ d
    perp = np.linalg.norm(rel - along[:, None] * d, axis=1)
    ok = (along > 0) & (perp <= max_distance)
    if not ok.any():
        return None
    cand = np.flatnonzero(ok)
    best = perp[cand].min()
    near = cand[perp[cand] <= best + 0.1 * max_distance]
    return int(near[np.argmin(along[near])])


def layers_bounds(values: list[np.ndarray]) -> np.ndarray | None:
    """(2, 3) min/max corner over arrays of points (any shape ending in 3), or None if empty."""
    arrs = [np.asarray(v, float).reshape(-1, 3) for v in values if np.size(v)]
    if not arrs:
        return None
    allp = np.vstack(arrs)
    allp = allp[np.isfinite(allp).all(axis=1)]
    if not len(allp):
        return None
    return np.array([allp.min(axis=0), allp.max(axis=0)])
