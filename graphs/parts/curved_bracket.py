"""Generates curved_bracket.stl: a large curved hollow bracket (single-bead wall 5 mm), in mm.

Cross-section: a stadium (slot) wall — two straight sides 80 mm long joined by half circles of
radius 20 mm about the wall's mid line — whose long axis lies radially, so the wall spans
bend − 52.5 … bend + 52.5 mm about the bend axis. The wall is 5 mm, the width the 316L bead
model's process (8.1 m/min of 1.2 mm wire at its speeds and heights) lays by mass balance: with
3 mm the program fed 1.69× the part's metal. The section is swept by `sweep` degrees about a
horizontal bend axis through (−bend·cos(yaw), −bend·sin(yaw), 0) whose direction is −y turned by
`yaw` about z (a tilted axis: the part leans out of the xz-plane, so the positioner must turn it
with E2 as well as tilt it). The first section lies on the substrate z = 0, centred on the origin.
With bend 250 mm the curvature-size ratio is 250/105 = 2.4 < 2.7: a single fan of planes cannot
keep the wedge heights in the bead range, so the recipe slices it in fan sections (Rauch et al.
2021), each with its own axis.

    .venv/bin/python graphs/parts/curved_bracket.py   # rewrites graphs/parts/curved_bracket.stl
"""

from pathlib import Path

import numpy as np
import trimesh

BEND, SWEEP_DEG, YAW_DEG = 250.0, 90.0, 30.0
HALF_STRAIGHT, RADIUS, WALL = 30.0, 20.0, 5.0


def stadium(offset: float, n_arc: int = 24) -> np.ndarray:
    """(m, 2) closed stadium curve (radial r, axial a) at `offset` from the wall mid line, CCW."""
    r = RADIUS + offset
    t1 = np.linspace(-np.pi / 2, np.pi / 2, n_arc + 1)
    t2 = np.linspace(np.pi / 2, 3 * np.pi / 2, n_arc + 1)
    right = np.column_stack([HALF_STRAIGHT + r * np.cos(t1), r * np.sin(t1)])
    left = np.column_stack([-HALF_STRAIGHT + r * np.cos(t2), r * np.sin(t2)])
    return np.vstack([right, left])


def bracket(n_phi: int = 90) -> trimesh.Trimesh:
    yaw = np.radians(YAW_DEG)
    axis = np.array([np.sin(yaw), -np.cos(yaw), 0.0])          # −y turned by yaw about z
    radial = np.array([np.cos(yaw), np.sin(yaw), 0.0])         # from the axis to the part at φ = 0
    centre = -BEND * radial
    phi = np.radians(np.linspace(0.0, SWEEP_DEG, n_phi + 1))
    rings = []
    for off in (WALL / 2, -WALL / 2):
        prof = stadium(off)
        m = len(prof)
        er = np.cos(phi)[:, None] * radial + np.sin(phi)[:, None] * np.array([0.0, 0.0, 1.0])
        pts = centre + (BEND + prof[None, :, 0, None]) * er[:, None, :] - prof[None, :, 1, None] * axis
        rings.append(pts.reshape(-1, 3))
    m = len(stadium(0.0))
    outer, inner = rings
    off = len(outer)
    i = np.arange(n_phi)[:, None]
    j = np.arange(m)[None, :]
    a, b = i * m + j, (i + 1) * m + j
    c, d = (i + 1) * m + (j + 1) % m, i * m + (j + 1) % m
    quads = np.stack([a, b, c, d], axis=-1).reshape(-1, 4)
    tri_out = np.concatenate([quads[:, [0, 2, 1]], quads[:, [0, 3, 2]]])
    tri_in = off + np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    caps = []
    for row, flip in ((0, True), (n_phi, False)):
        o0 = row * m + np.arange(m)
        o1 = row * m + (np.arange(m) + 1) % m
        t = np.concatenate([np.stack([o0, o1, off + o1], 1), np.stack([o0, off + o1, off + o0], 1)])
        caps.append(t[:, ::-1] if flip else t)
    mesh = trimesh.Trimesh(np.vstack([outer, inner]), np.concatenate([tri_out, tri_in] + caps), process=True)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


if __name__ == "__main__":
    m = bracket()
    assert m.is_watertight and m.volume > 0, "curved bracket mesh is not a closed, outward-facing solid"
    m.export(Path(__file__).with_name("curved_bracket.stl"))
    print(f"curved_bracket.stl: {len(m.faces)} faces, volume {m.volume:.1f} mm³, extents {m.extents.round(1)}")
