"""The part's own volume in each slab (geometry.topology.volume_below) bounds what a layer's
beads can cover there. PrusaSlicer's tests/data/test_3mf/Prusa.stl (a 1.5 mm plate with 1.5 mm
letters on it, 5 mm beads, 2 mm layers): the mid-plane at z 1.0 sees the whole plate, so slab 0
counted 2 mm of plate as covered where the part has 1.5 mm of plate and a few letters; that
surplus hid layer 1, 57 % of whose letters got no bead: "uncovered 1.1 %" (it was 11 %). The
preflight measured covered metal on the slabs' mid-plane sections and weighed it against the
mesh's volume: a slab whose section is larger than the part's volume in it hid what other slabs
miss."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from waamflow.geometry.topology import volume_below
from waamflow.preflight.check import Part, check_program
from waamflow.preflight.read import read_gcode
from waamflow.preflight.settings import PreflightSettings


def _capped_below(mesh: trimesh.Trimesh, z: float) -> float:
    """trimesh's own figure: the mesh cut at z with the cut capped, its volume."""
    if z <= mesh.bounds[0][2]:
        return 0.0
    if z >= mesh.bounds[1][2]:
        return float(mesh.volume)
    return float(mesh.slice_plane([0, 0, z], [0, 0, -1], cap=True).volume)


@pytest.mark.parametrize(
    "mesh",
    [
        trimesh.creation.box(extents=(40, 20, 30)),
        trimesh.creation.icosphere(subdivisions=3, radius=25),
        trimesh.creation.cone(radius=30, height=50),
        trimesh.creation.torus(major_radius=30, minor_radius=8),
        trimesh.creation.cylinder(
            radius=10, height=40, transform=trimesh.transformations.rotation_matrix(0.7, [1, 0, 0])
        ),
    ],
    ids=["box", "sphere", "cone", "torus", "tilted-cylinder"],
)
def test_volume_below_each_plane_is_the_capped_cut_volume(mesh):
    mesh = mesh.copy()
    mesh.apply_translation([103.0, -57.0, 11.0])  # far from the origin, as parts on a plate are
    lo, hi = mesh.bounds[:, 2]
    zs = np.concatenate([[lo - 1, lo], np.linspace(lo, hi, 23)[1:-1], [hi, hi + 5]])
    got = volume_below(mesh.vertices, mesh.faces, zs)
    want = [_capped_below(mesh, z) for z in zs]
    assert got == pytest.approx(want, rel=1e-9, abs=1e-6 * mesh.volume)
    # a plane through vertices and faces lying in it (the box's bottom and top)
    assert got[1] == pytest.approx(0.0, abs=1e-9) and got[-2] == pytest.approx(mesh.volume, rel=1e-12)


def test_volume_below_random_hulls_and_unions():
    """Random convex hulls and unions of random boxes (manifold3d), planes through their vertices too."""
    rng = np.random.default_rng(7)
    for k in range(6):
        if k % 2:
            mesh = trimesh.convex.convex_hull(rng.normal(size=(60, 3)) * [40, 25, 30])
        else:
            boxes = []
            for _ in range(4):
                b = trimesh.creation.box(extents=rng.uniform(5, 40, 3))
                b.apply_translation(rng.uniform(-20, 20, 3))
                boxes.append(b)
            mesh = trimesh.boolean.union(boxes, engine="manifold")
        lo, hi = mesh.bounds[:, 2]
        zs = np.concatenate([rng.uniform(lo, hi, 15), rng.choice(mesh.vertices[:, 2], 5)])
        got = volume_below(mesh.vertices, mesh.faces, zs)
        want = [_capped_below(mesh, z) for z in zs]
        assert got == pytest.approx(want, rel=1e-7, abs=1e-6 * mesh.volume), k


def test_volume_below_takes_planes_in_any_order():
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=10)
    zs = np.array([5.0, -3.0, 0.0, 9.9, -9.9])
    got = volume_below(mesh.vertices, mesh.faces, zs)
    assert got == pytest.approx([_capped_below(mesh, z) for z in zs], rel=1e-9)


# ---- a step inside a slab ------------------------------------------------------------------------
PLATE, BOSS = 1.2, 4.0  # plate 60 x 60 x 1.2 mm; boss 20 x 20 from the plate's top to z 4


def _stepped() -> Part:
    plate = trimesh.creation.box(extents=(60, 60, PLATE))
    plate.apply_translation((0, 0, PLATE / 2))
    boss = trimesh.creation.box(extents=(20, 20, BOSS - PLATE + 0.5))
    boss.apply_translation((0, 0, PLATE - 0.5 + (BOSS - PLATE + 0.5) / 2))
    m = trimesh.boolean.union([plate, boss], engine="manifold")
    return Part("solid", "part", vertices=np.asarray(m.vertices), faces=np.asarray(m.faces))


def _program() -> str:
    """Layer 0 (top z 2) rasters the whole plate; layer 1 (top z 4) only the boss's half x < 0."""
    out = ["; waamflow-post: arc_on=M3 arc_off=M5 dwell_units=s feed_units=mm/min end=M30"]
    out.append('; waamflow-weld: wire_feed_speed[m/min]="M67 E0 Q{value:.2f}"')
    out += ["G21", "G90"]
    layers = [
        (2.0, [((-30.0, y), (30.0, y)) for y in np.arange(-27.5, 28.0, 5.0)]),
        (4.0, [((-10.0, y), (-3.0, y)) for y in (-7.5, -2.5, 2.5, 7.5)]),
    ]
    for i, (z, lines) in enumerate(layers):
        out.append(f"; layer {i} z={z:.3f}")
        for (x0, y0), (x1, y1) in lines:
            out += [f"G0 X{x0:.3f} Y{y0:.3f} Z{z:.3f}", "M67 E0 Q4.00", "M3"]
            out += [f"G1 X{x1:.3f} Y{y1:.3f} Z{z:.3f} F480", "M5"]
    out.append("M30")
    return "\n".join(out)


def test_a_slab_whose_section_outweighs_its_volume_hides_no_other_slab():
    part = _stepped()
    volume = 60 * 60 * PLATE + 20 * 20 * (BOSS - PLATE)  # 5440 mm³
    rep = check_program(part, read_gcode(_program()), "post", PreflightSettings(), 6.0)
    assert rep["part_volume_mm3"] == pytest.approx(volume, rel=1e-6)
    # slab 0 (z 0-2) holds 4640 mm³, all under layer 0's beads (its mid-plane section, the
    # plate, 3600 mm² x 2 mm = 7200 mm³, had counted as covered); slab 1 (z 2-4): the boss's
    # half x > 0 gets no bead, 10 x 20 x 2 = 400 mm³
    assert rep["uncovered_share"] == pytest.approx(400 / volume, abs=0.004)
    (unc,) = [p for p in rep["problems"] if p["check"] == "uncovered"]
    assert unc["severity"] == "fail" and unc["layer"] == 1
