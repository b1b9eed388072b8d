"""Slicing: parts (solid meshes, midsurfaces) → layers, vectorised over all planes at once.

`planes` decides where layers are, `planar` cuts a mesh into loops, `rings` nests loops into
polygons with holes, `slicer` ties them into `core.model.Layer`s.
"""

from .planar import Loops, section_loops
from .planes import LayerSchedule, TopFit, layer_schedule
from .rings import loops_to_regions
from .slicer import empty_layers_inside, part_z_range, slice_mesh, slice_midsurface, slice_part, slice_part_scheduled

__all__ = [
    "LayerSchedule",
    "Loops",
    "empty_layers_inside",
    "layer_schedule",
    "loops_to_regions",
    "part_z_range",
    "section_loops",
    "slice_mesh",
    "slice_midsurface",
    "slice_part",
    "slice_part_scheduled",
    "TopFit",
]
