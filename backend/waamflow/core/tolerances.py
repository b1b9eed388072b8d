"""Central tolerances (one place, with why). All lengths in mm, angles in degrees.

Modelled on trimesh.constants.tol: kernels import `TOL` instead of sprinkling literals.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Tolerances:
    # Two points closer than this are the same point. Feature recognition (thin-walls study)
    # merges points within 1e-6 mm; we keep that for topology, and a looser `snap` for drawing.
    merge: float = 1e-6
    # Distance under which a slice loop is considered closed / segments are joined (mm).
    # STL exports round vertices to ~1e-5 relative; 1e-4 mm on parts of 1 m is still safe.
    join: float = 1e-4
    # Regions smaller than this area (mm²) are slicing noise (sliver triangles, coplanar faces).
    min_area: float = 1e-3
    # Polygon simplification tolerance for display / offsets (mm); well under a bead width.
    simplify: float = 1e-3
    # A path segment shorter than this is dropped (mm): robots cannot resolve it anyway.
    min_segment: float = 1e-3
    # A vertex this close to a section plane (mm) lies on it: a face meant to be flat whose
    # corners a float32 exporter scattered by ~1e-4 mm around a mid-layer plane is cut just below,
    # as an exact one is (slicing/planar.py), not through its noise.
    plane_snap: float = 1e-3
    # Mesh input: vertices on open edges closer than `weld` (mm) are one vertex (exporters that
    # round each triangle's corners differently leave cracks of ~1e-5 relative).
    weld: float = 1e-3
    # Mesh input: cracks up to `crack` (mm) between a solid's faces are closed by merging the
    # vertices on open edges, accepted only when that leaves no open edge at all. 0.1 mm is a
    # twentieth of a WAAM layer (1.5-3 mm) and of a bead (3-10 mm wide): no deposit can tell.
    crack: float = 0.1


TOL = Tolerances()
