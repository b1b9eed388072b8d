"""Closed test meshes (mm) built with trimesh, as MeshData through the same welding as files."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import trimesh

from waamflow.core.model import MeshData
from waamflow.geometry.mesh_io import mesh_from_triangles

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
from bench_slice import ribbed_tube  # noqa: E402, F401  (the bench's generator: one definition; re-exported)

SECTIONS = 256


def ngon_area(r: float, n: int = SECTIONS) -> float:
    """Area (mm²) of the regular n-gon inscribed in a circle of radius r — what a faceted cylinder cuts to."""
    return 0.5 * n * r * r * np.sin(2 * np.pi / n)


def as_mesh(tm: trimesh.Trimesh, name: str = "part") -> MeshData:
    return mesh_from_triangles(np.asarray(tm.triangles), name=name)


def tube(r_in=20.0, r_out=30.0, h=30.0, z0=0.0) -> trimesh.Trimesh:
    t = trimesh.creation.annulus(r_min=r_in, r_max=r_out, height=h, sections=SECTIONS)
    t.apply_translation([0, 0, z0 - t.bounds[0][2]])
    return t


def cylinder(r: float, h: float, z0=0.0, xy=(0.0, 0.0)) -> trimesh.Trimesh:
    c = trimesh.creation.cylinder(radius=r, height=h, sections=SECTIONS)
    c.apply_translation([xy[0], xy[1], z0 - c.bounds[0][2]])
    return c


def box(size, corner=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    b = trimesh.creation.box(extents=size)
    b.apply_translation(np.asarray(corner) - b.bounds[0])
    return b


def frustum(r_bottom: float, r_top: float, h: float) -> trimesh.Trimesh:
    """Solid cone frustum of revolution about +Z, SECTIONS facets."""
    profile = np.array([[0.0, 0.0], [r_bottom, 0.0], [r_top, h], [0.0, h]])
    return trimesh.creation.revolve(profile, sections=SECTIONS)


def union(*parts: trimesh.Trimesh) -> trimesh.Trimesh:
    """Disjoint bodies concatenated into one mesh (no boolean: they must not touch)."""
    return trimesh.util.concatenate(parts)
