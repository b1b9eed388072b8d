"""A part of overlapping shells (ros-industrial/abb's IRB 4400 link_1.stl: six closed shells, each
facing outwards) is one solid to the preflight, as it is to the slicer. The preflight cut its
sections even-odd, where the overlap of two shells is a hole, and failed the programs with weld
"outside the part" in the overlaps (300 stretches, up to 17.5 mm off, on link_1)."""

import json

import numpy as np
import pytest
import trimesh

from waamflow.cli import main
from waamflow.geometry.topology import signed_volume
from waamflow.preflight.bodies import united

from tests.preflight.solid_recipe import solid_recipe


def _shells() -> trimesh.Trimesh:
    base = trimesh.creation.box((60, 40, 20))
    base.apply_translation((30, 20, 10))
    post = trimesh.creation.box((20, 20, 30))  # through the base's middle and 10 mm above it
    post.apply_translation((30, 20, 15))
    return trimesh.util.concatenate([base, post])


def test_overlapping_shells_unite_to_their_solid():
    m = _shells()
    v, f, n, note = united(np.asarray(m.vertices), np.asarray(m.faces))
    assert n == 2 and note is None
    assert signed_volume(v, f) == pytest.approx(60 * 40 * 20 + 20 * 20 * 10, rel=1e-9)  # 52,000 mm³
    one = trimesh.creation.box((10, 10, 10))
    v1, f1, n1, _ = united(np.asarray(one.vertices), np.asarray(one.faces))
    assert n1 == 1 and v1 is not None and len(f1) == 12


def test_a_void_inside_overlapping_shells_stays_a_void():
    m = _shells()
    void = trimesh.creation.box((10, 10, 6))
    void.apply_translation((8, 8, 10))
    void.invert()  # facing inwards: a cavity in the base, clear of the post
    both = trimesh.util.concatenate([m, void])
    v, f, n, _ = united(np.asarray(both.vertices), np.asarray(both.faces))
    assert n == 3
    assert signed_volume(v, f) == pytest.approx(52_000 - 600, rel=1e-9)


def test_a_program_on_overlapping_shells_passes(tmp_path):
    _shells().export(tmp_path / "shells.stl")
    path = solid_recipe(tmp_path, "shells", "shells.stl", {"pattern": "parallel", "bead_width": 5, "spacing": 4})
    out = tmp_path / "out"
    code = main(["run", path, "--out", str(out), "--no-cache", "--accept-preflight"])
    rep = json.loads((out / "preflight.json").read_text())
    checks = {p["check"]: p["severity"] for p in rep["problems"]}
    assert "outside" not in checks and "uncovered" not in checks, rep["problems"]
    assert code == 0


def test_bodies_manifold3d_refuses_are_checked_as_they_are_and_said():
    """A body manifold3d does not take as a closed manifold (here a box with one face dropped
    beside a whole one): the mesh is checked as it is, and the report's notes say so."""
    box = trimesh.creation.box((10, 10, 10))
    other = trimesh.creation.box((10, 10, 10))
    other.apply_translation((30, 0, 0))
    open_box = trimesh.Trimesh(other.vertices, other.faces[1:], process=False)
    both = trimesh.util.concatenate([box, open_box])
    v, f, n, note = united(np.asarray(both.vertices), np.asarray(both.faces))
    assert n == 2 and len(f) == 23
    assert note is not None and "not united" in note and "manifold3d" in note
