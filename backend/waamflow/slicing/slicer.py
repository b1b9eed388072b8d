"""Parts → layers: planar slicing of solids (MeshData) and midsurfaces (Midsurface).

Convention (`core.model.Layer`, `planes.py`): `Layer.z` is the layer's top; its geometry is the
section at mid-layer, z − thickness/2. With a build direction d other than +Z, "z" is the
distance along d: the part is expressed in a frame whose z axis is d, sliced there, and each
layer carries `Layer.frame` (layer-local (x, y, 0) → world) so `Layer.to_world` gives world
points on the layer's top plane.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np
from shapely.geometry import LineString, MultiPolygon

from ..core.model import Layer, MeshData, Midsurface
from .planar import Submit, section_loops
from .planes import TOP_MAX_FACTOR, TOP_MIN_FRACTION, LayerSchedule, TopPolicy, layer_schedule
from .rings import loops_to_regions

if TYPE_CHECKING:  # imported where used: keeps `waamflow nodes` light
    import trimesh


Z_UP = (0.0, 0.0, 1.0)


def build_rotation(direction: Sequence[float]) -> np.ndarray | None:
    """(3, 3) rotation R whose rows are the build frame's x, y, z axes in world coordinates
    (local = R @ world), z along `direction`; None for +Z. The frame's x axis is world X
    projected onto the layer plane (world Y when the direction is near X)."""
    d = np.asarray(direction, dtype=float)
    n = float(np.linalg.norm(d))
    if not (n > 0 and np.isfinite(n)):
        raise ValueError(f"build direction must be a non-zero vector (got {list(direction)})")
    ez = d / n
    if np.allclose(ez, Z_UP, atol=1e-12):
        return None
    ref = np.array([1.0, 0.0, 0.0]) if abs(ez[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    ex = ref - ref.dot(ez) * ez
    ex /= np.linalg.norm(ex)
    return np.array([ex, np.cross(ez, ex), ez])


def _layer_frame(rot: np.ndarray | None, top: float) -> np.ndarray | None:
    if rot is None:
        return None
    frame = np.eye(4)
    frame[:3, :3] = rot.T
    frame[:3, 3] = rot[2] * top
    return frame


def part_z_range(part: MeshData | Midsurface) -> tuple[float, float]:
    """(bottom, top) of a part along +Z, mm."""
    if isinstance(part, Midsurface):
        return float(part.z0), float(part.z0 + part.height)
    vz = np.asarray(part.vertices)[:, 2]
    return float(vz.min()), float(vz.max())


def slice_mesh(
    mesh: MeshData,
    schedule: LayerSchedule,
    rot: np.ndarray | None = None,
    submit: Submit | None = None,
    repairs: list[tuple[int, str, float, float]] | None = None,
) -> tuple[Layer, ...]:
    """Solid layers: region = mid-layer section as a MultiPolygon with holes (mm).

    mesh: in the build frame (rotated by `rot` already, if any); rot sets the layers' frames.
    submit: a node's `Context.submit`, which may cut the upper planes in a worker (planar.py).
    repairs: receives the sections that crossed themselves and were made valid (`rings.repair_regions`).
    """
    loops = section_loops(mesh.vertices, mesh.faces, schedule.cuts, name=mesh.name, submit=submit)
    regions = loops_to_regions(loops, len(schedule), repairs)
    return tuple(
        Layer(index=i, z=float(z), thickness=float(t), region=regions[i], frame=_layer_frame(rot, float(z)))
        for i, (z, t) in enumerate(zip(schedule.tops, schedule.thickness))
    )


def surface_curves(mesh: "MeshData | trimesh.Trimesh", height: float, digits: int = 9) -> tuple[LineString, ...]:
    """Curves of an open single-wall surface cut by the plane z = height: the section segments
    (trimesh.intersections.mesh_plane) joined end to end (shapely linemerge on coordinates rounded
    to `digits` decimals, so a point computed from both faces of an edge is one point), collinear
    points removed (within 1 µm). Closed curves repeat their first point."""
    import shapely.ops
    import trimesh

    tm = mesh if isinstance(mesh, trimesh.Trimesh) else trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    seg = trimesh.intersections.mesh_plane(tm, plane_normal=[0.0, 0.0, 1.0], plane_origin=[0.0, 0.0, height])
    if len(seg) == 0:
        return ()
    seg = np.round(np.asarray(seg)[:, :, :2], digits)
    seg = seg[np.any(seg[:, 0] != seg[:, 1], axis=1)]
    merged = shapely.ops.linemerge(shapely.MultiLineString([s for s in seg]))
    lines = list(merged.geoms) if hasattr(merged, "geoms") else [merged]
    # drop the collinear points where the plane crosses a facet's diagonal (they are no vertices
    # of the wall and would read as kinks between straight pieces)
    lines = [ln.simplify(10.0 ** -min(digits, 6), preserve_topology=False) for ln in lines]
    return tuple(sorted((ln for ln in lines if ln.length > 0), key=lambda ln: -ln.length))


def slice_surface(mesh: MeshData, schedule: LayerSchedule, rot: np.ndarray | None = None) -> tuple[Layer, ...]:
    """Layers of an open single-wall surface: each layer's `curves` are the mid-layer section
    (open or closed polylines, as a sketch gives), its region empty."""
    import trimesh

    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)  # built once for every plane
    return tuple(
        Layer(
            index=i,
            z=float(z),
            thickness=float(t),
            region=MultiPolygon(),
            curves=surface_curves(tm, float(cut)),
            frame=_layer_frame(rot, float(z)),
        )
        for i, (z, t, cut) in enumerate(zip(schedule.tops, schedule.thickness, schedule.cuts))
    )


def slice_midsurface(mid: Midsurface, schedule: LayerSchedule) -> tuple[Layer, ...]:
    """Midsurface layers: every curve on each layer whose cut lies in (z0, z0 + height]."""
    curves = tuple(LineString(c) for c in mid.curves)
    lo, hi = part_z_range(mid)
    layers = []
    for i, (z, t, cut) in enumerate(zip(schedule.tops, schedule.thickness, schedule.cuts)):
        inside = lo < cut <= hi
        layers.append(
            Layer(
                index=i,
                z=float(z),
                thickness=float(t),
                region=MultiPolygon(),
                curves=curves if inside else (),
                joints=tuple(mid.joints) if inside else (),
            )
        )
    return tuple(layers)


def slice_part(
    part: MeshData | Midsurface,
    *,
    layer_height: float,
    thicknesses: Sequence[float] = (),
    start_offset: float = 0.0,
    layer_count: int | None = None,
    z_min: float | None = None,
    z_max: float | None = None,
    direction: Sequence[float] = Z_UP,
    top: TopPolicy = "ceil",
    min_fraction: float = TOP_MIN_FRACTION,
    max_factor: float = TOP_MAX_FACTOR,
) -> tuple[Layer, ...]:
    """Slice a solid or a midsurface with the schedule of `planes.layer_schedule` (all mm).

    direction: build direction (world vector); z_min/z_max are distances along it. Midsurfaces
    are extruded along +Z and can only be sliced along +Z. top, min_fraction, max_factor: how the
    last layer meets the part's top (`planes` docstring). `slice_part_scheduled` also returns
    the schedule (with its `fit`).
    """
    return slice_part_scheduled(
        part,
        layer_height=layer_height,
        thicknesses=thicknesses,
        start_offset=start_offset,
        layer_count=layer_count,
        z_min=z_min,
        z_max=z_max,
        direction=direction,
        top=top,
        min_fraction=min_fraction,
        max_factor=max_factor,
    )[0]


def slice_part_scheduled(
    part: MeshData | Midsurface,
    *,
    layer_height: float,
    thicknesses: Sequence[float] = (),
    start_offset: float = 0.0,
    layer_count: int | None = None,
    z_min: float | None = None,
    z_max: float | None = None,
    direction: Sequence[float] = Z_UP,
    top: TopPolicy = "ceil",
    min_fraction: float = TOP_MIN_FRACTION,
    max_factor: float = TOP_MAX_FACTOR,
    submit: Submit | None = None,
    repairs: list[tuple[int, str, float, float]] | None = None,
) -> tuple[tuple[Layer, ...], LayerSchedule]:
    """`slice_part`, and the layer schedule it used: (layers, schedule). `submit`: a node's
    `Context.submit`, with which a large solid's upper planes are cut in a worker (planar.py).
    `repairs`: receives (layer, reason, area before, area after) of each section made valid."""
    rot = build_rotation(direction)
    if rot is not None:
        if isinstance(part, Midsurface):
            raise ValueError("a sketch (midsurface) is extruded along +Z: slice it with direction [0, 0, 1]")
        part = MeshData(
            vertices=np.asarray(part.vertices) @ rot.T, faces=part.faces, name=part.name, surface=part.surface
        )
    bottom, top_z = part_z_range(part)
    schedule = layer_schedule(
        bottom,
        top_z,
        layer_height=layer_height,
        thicknesses=thicknesses,
        start_offset=start_offset,
        layer_count=layer_count,
        z_min=z_min,
        z_max=z_max,
        top_policy=top,
        min_fraction=min_fraction,
        max_factor=max_factor,
    )
    if isinstance(part, Midsurface):
        return slice_midsurface(part, schedule), schedule
    if part.surface:
        return slice_surface(part, schedule, rot), schedule
    return slice_mesh(part, schedule, rot, submit, repairs), schedule


def empty_layers_inside(
    layers: Sequence[Layer], part: MeshData | Midsurface, direction: Sequence[float] = Z_UP
) -> list[int]:
    """Indices of layers without geometry whose cutting plane lies strictly inside the part."""
    rot = build_rotation(direction)
    if rot is not None and isinstance(part, MeshData):
        part = MeshData(
            vertices=np.asarray(part.vertices) @ rot.T, faces=part.faces, name=part.name, surface=part.surface
        )
    lo, hi = part_z_range(part)
    out = []
    for layer in layers:
        cut = layer.z - layer.thickness / 2.0
        if lo < cut < hi and layer.region.is_empty and not layer.curves:
            out.append(layer.index)
    return out
