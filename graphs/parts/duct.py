"""Generates duct.stl: a bent hollow single-bead duct (quarter torus tube, wall 5 mm), in mm.

The duct starts on the substrate: its first cross-section is the ring of mid radius 15 mm in the
plane z = 0 centred on the origin; it bends about the axis through (−100, 0, 0) along −y
(bend radius 100 mm) up to a vertical end face after 90°. Wall: 13.5..16.5 mm from the tube
centre line. Radial extent about the bend axis 82.5..117.5 mm: CSratio = 100/35 = 2.86 ≥ 2.7,
so a single fan section fits the 316L bead model (Rauch et al. 2021). The wall is as thick as the
bead the model's process lays: 8.1 m/min of 1.2 mm wire at the model's speeds and heights puts
η·WFS·A_wire / (Ts·H) ≈ 5.2 mm of wall per layer (mass balance, preflight wire/part 1.04); with
the 3 mm wall of earlier versions the program fed 1.73× the part's metal.

    .venv/bin/python graphs/parts/duct.py   # rewrites graphs/parts/duct.stl
"""

from pathlib import Path

import trimesh

from waamflow.curved.shapes import bent_tube

if __name__ == "__main__":
    part = bent_tube(bend=100.0, mid=15.0, wall=5.0, sweep_deg=90.0, n_phi=72, n_psi=40)
    m = trimesh.Trimesh(part.vertices, part.faces, process=True)
    assert m.is_watertight and m.volume > 0, "duct mesh is not a closed, outward-facing solid"
    m.export(Path(__file__).with_name("duct.stl"))
    print(f"duct.stl: {len(m.faces)} faces, volume {m.volume:.1f} mm³")
