"""Generates bracket.stl: a tall WAAM bracket (300 × 90 × 450 mm, 300 layers of 1.5 mm), in mm.

    foot   z   0 ..  30   x 0..300, y  0..90   a base plate (layers 0-19)
    web    z  30 .. 450   x 0..300, y 35..55   a 20 mm web standing on the foot's middle
    window z 150 .. 330   a diamond through the web (y), centred x = 150, z = 240, half-diagonals
                          90 mm: its flanks lean 45°, so it builds without support; it opens at
                          layer 100 (cut at z = 150.75) and closes after layer 219

So the sections change along the height: one wide plate, then one narrow web, then two webs left
and right of the window (whose widths shrink then grow), then one web again. Every feature lies on
a multiple of the 1.5 mm layer height, so the slicer's mid-layer planes never graze one.

    .venv/bin/python graphs/parts/bracket.py   # rewrites graphs/parts/bracket.stl
"""

from pathlib import Path

import numpy as np
import trimesh
from shapely.geometry import Polygon

LENGTH, DEPTH, HEIGHT = 300.0, 90.0, 450.0
FOOT = 30.0
WEB_Y = (35.0, 55.0)
WINDOW = (150.0, 240.0, 90.0)  # centre x, centre z, half-diagonal (mm)


def bracket() -> trimesh.Trimesh:
    foot = trimesh.creation.box(bounds=[[0, 0, 0], [LENGTH, DEPTH, FOOT]])
    web = trimesh.creation.box(bounds=[[0, WEB_Y[0], FOOT - 1.0], [LENGTH, WEB_Y[1], HEIGHT]])
    cx, cz, h = WINDOW
    diamond = Polygon([(cx - h, cz), (cx, cz - h), (cx + h, cz), (cx, cz + h)])
    # extruded along +z in (x, z) then turned so the extrusion runs along y through the web
    window = trimesh.creation.extrude_polygon(diamond, height=DEPTH + 20.0)
    turn = np.array([[1, 0, 0, 0], [0, 0, 1, -10.0], [0, 1, 0, 0], [0, 0, 0, 1]], float)  # (x, y, z) ← (x, z', y')
    turn[1] = [0, 0, 1, -10.0]
    turn[2] = [0, 1, 0, 0]
    window.apply_transform(turn)
    if window.volume < 0:
        window.invert()
    part = trimesh.boolean.union([foot, web], engine="manifold")
    return trimesh.boolean.difference([part, window], engine="manifold")


if __name__ == "__main__":
    m = bracket()
    assert m.is_watertight and m.volume > 0, "bracket mesh is not a closed, outward-facing solid"
    out = Path(__file__).with_name("bracket.stl")
    m.export(out)
    print(f"bracket.stl: {len(m.faces)} faces, volume {m.volume:.0f} mm³, bounds {m.bounds.tolist()}, {out.stat().st_size} bytes")
