"""Part geometry in: triangle meshes (STL/OBJ/PLY/3MF) and 2D sketches extruded to midsurfaces.

Pure kernels (numpy, trimesh, ezdxf); the `mesh` and `sketch` nodes in `waamflow.nodes.inputs`
adapt them to ports. Everything leaves here in millimetres.
"""

from .mesh_io import MeshLimits, load_mesh_bytes
from .sketch import load_sketch_bytes, sketch_from_curves
from .topology import EdgeReport, check_closed, edge_report, merge_vertices
from .transform import Transform

__all__ = [
    "EdgeReport",
    "MeshLimits",
    "Transform",
    "check_closed",
    "edge_report",
    "load_mesh_bytes",
    "load_sketch_bytes",
    "merge_vertices",
    "sketch_from_curves",
]
