"""Parts → layers: planar slicing of solids (MeshData) and midsurfaces (Midsurface).

Convention (`core.model.Layer`, `planes.py`): `Layer.z` is the layer's top; its geometry is the
section at mid-layer, z − thickness/2.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from shapely.geometry import LineString, MultiPolygon

from ..core.model import Layer, MeshData, Midsurface
from .planar import section_loops
from .planes import LayerSchedule, layer_schedule
from .rings import loops_to_regions


def part_z_range(part: MeshData | Midsurface) -> tuple[float, float]:
    """(bottom, top) of a part along +Z, mm."""
    if isinstance(part, Midsurface):
        return float(part.z0), float(part.z0 + part.height)
    vz = np.asarray(part.vertices)[:, 2]
    return float(vz.min()), float(vz.max())


def slice_mesh(mesh: MeshData, schedule: LayerSchedule) -> tuple[Layer, ...]:
    """Solid layers: region = mid-layer section as a MultiPolygon with holes (mm)."""
    loops = section_loops(mesh.vertices, mesh.faces, schedule.cuts, name=mesh.name)
    regions = loops_to_regions(loops, len(schedule))
    return tuple(
        Layer(index=i, z=float(z), thickness=float(t), region=regions[i])
        for i, (z, t) in enumerate(zip(schedule.tops, schedule.thickness))
    )


def slice_midsurface(mid: Midsurface, schedule: LayerSchedule) -> tuple[Layer, ...]:
    """Midsurface layers: every curve on each layer whose cut lies in (z0, z0 + height]."""
    curves = tuple(LineString(c) for c in mid.curves)
    lo, hi = part_z_range(mid)
    layers = []
    for i, (z, t, cut) in enumerate(zip(schedule.tops, schedule.thickness, schedule.cuts)):
        inside = lo < cut <= hi
        layers.append(Layer(index=i, z=float(z), thickness=float(t), region=MultiPolygon(), curves=curves if inside else ()))
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
) -> tuple[Layer, ...]:
    """Slice a solid or a midsurface with the schedule of `planes.layer_schedule` (all mm)."""
    bottom, top = part_z_range(part)
    schedule = layer_schedule(
        bottom, top, layer_height=layer_height, thicknesses=thicknesses, start_offset=start_offset,
        layer_count=layer_count, z_min=z_min, z_max=z_max,
    )
    if isinstance(part, Midsurface):
        return slice_midsurface(part, schedule)
    return slice_mesh(part, schedule)


def empty_layers_inside(layers: Sequence[Layer], part: MeshData | Midsurface) -> list[int]:
    """Indices of layers without geometry whose cutting plane lies strictly inside the part."""
    lo, hi = part_z_range(part)
    out = []
    for layer in layers:
        cut = layer.z - layer.thickness / 2.0
        if lo < cut < hi and layer.region.is_empty and not layer.curves:
            out.append(layer.index)
    return out
