"""The crossing-radius warnings hold a 1 µm tolerance: a sketch's right angle drawn as 89.9992°
had put the influence window at 8.00006 mm, and every such crossing of ezdxf's recover01.dxf
warned "influence_radius 8 mm is below 8.0 mm"."""

from waamflow.features.walls import WallSpec, radius_warnings

CROSS = {"kind": "four_direct_crossing", "point": [0.0, 0.0]}


def test_a_right_angle_drawn_a_hair_narrow_is_no_warning():
    spec = WallSpec(cut_radius=1.6, influence_radius=8.0, bead_width=4.0)
    assert radius_warnings(CROSS, spec, 89.9992) == []


def test_a_narrower_corner_still_warns_with_its_window():
    spec = WallSpec(cut_radius=1.6, influence_radius=8.0, bead_width=4.0)
    (msg,) = radius_warnings(CROSS, spec, 80.0)
    assert "influence_radius 8 mm is below 8.8 mm" in msg and "fillet corner 80°" in msg


def test_walls_leaving_a_crossing_in_one_direction_are_said_to_overlap():
    """A corner of 4.4e-13° (two walls drawn on top of each other, ezdxf's recover01.dxf) gave
    'influence_radius 8 mm is below 1471450727163165.0 mm'."""
    spec = WallSpec(cut_radius=1.6, influence_radius=8.0, bead_width=4.0)
    (msg,) = radius_warnings({"kind": "odd_t_crossing", "point": [-976.5, 1049.586]}, spec, 4.40536e-13)
    assert "two of its walls leave it in the same direction (a corner of 4.4e-13°)" in msg
    assert "duplicate or overlapping line" in msg and "mm is below" not in msg
