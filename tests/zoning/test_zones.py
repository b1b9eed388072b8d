"""Zoning of section paths: zone ids, lengths, 3D zoning across layers, segment splitting."""

import numpy as np
import pytest

from waamflow.core.model import SectionPath
from waamflow.zoning import ZoneSpec, apply_zone_params, zone_color, zone_lengths, zone_path
from waamflow.zoning.zones import project_onto_path, with_weld_defaults


def path(points, z=1.5, speed=5.0, arc=None, key="bs1/A"):
    pts = np.column_stack([np.asarray(points, float), np.full(len(points), z)])
    n = len(pts) - 1
    return SectionPath(
        key,
        "parallel",
        pts,
        np.ones(n, bool) if arc is None else np.asarray(arc, bool),
        np.ones(n, bool),
        np.full(n, speed),
    )


def test_one_zone_without_splits():
    zp = zone_path(path([(0, 0), (100, 0)]), ZoneSpec())
    assert zp.zone == ("z1",) and zone_lengths(zp) == {"z1": 100.0}


def test_start_end_lengths_and_a_split_point():
    zp = zone_path(path([(0, 5), (100, 5)]), ZoneSpec(10, 15, ((40, 3),)))
    assert list(zone_lengths(zp).items()) == [("start", 10.0), ("z1", 30.0), ("z2", 45.0), ("end", 15.0)]
    assert zp.points[:, 0].tolist() == [0, 10, 40, 85, 100]
    assert zp.zone_colors == {z: zone_color(z) for z in ("start", "z1", "z2", "end")}
    assert len(set(zp.zone_colors.values())) == 4


def test_3d_zoning_length_zones_keep_length_point_zones_stay_put():
    # Layer 0: section path 100 mm long; layer 5: the section shrank to 80 mm (x 10 → 90).
    spec = ZoneSpec(start_length=10, end_length=10, split_points=((50, 0),))
    lower = zone_lengths(zone_path(path([(0, 0), (100, 0)]), spec))
    upper_path = zone_path(path([(10, 0), (90, 0)], z=9.0), spec)
    upper = zone_lengths(upper_path)
    assert lower == {"start": 10.0, "z1": 40.0, "z2": 40.0, "end": 10.0}
    assert upper == {"start": 10.0, "z1": 30.0, "z2": 30.0, "end": 10.0}
    # the split point boundary is at x = 50 on both layers
    split_vertex = upper_path.points[[i for i, z in enumerate(upper_path.zone) if z == "z2"][0]]
    assert split_vertex[0] == pytest.approx(50.0)


def test_zigzag_path_is_split_inside_segments_with_attributes_copied():
    # weave: 5 strokes of 10 mm across, advancing 2 mm: total = 5·10 + 4·2 = 58 mm
    pts = [(0, 0), (0, 10), (2, 10), (2, 0), (4, 0), (4, 10), (6, 10), (6, 0), (8, 0), (8, 10)]
    arc = [True, True, True, True, False, True, True, True, True]
    sp = path(pts, arc=arc, speed=7.0)
    zp = zone_path(sp, ZoneSpec(start_length=5, end_length=5))
    assert zp.length == pytest.approx(58.0)
    assert zone_lengths(zp) == pytest.approx({"start": 5.0, "z1": 48.0, "end": 5.0})
    assert len(zp.points) == len(pts) + 2  # two vertices inserted mid-stroke
    assert zp.points[1].tolist() == [0.0, 5.0, 1.5] and zp.points[-2].tolist() == [8.0, 5.0, 1.5]
    assert len(zp.arc) == len(zp.zone) == len(zp.speed) == len(zp.points) - 1
    assert int((~zp.arc).sum()) == 1 and np.all(zp.speed == 7.0)


def test_tool_axis_is_interpolated_for_inserted_points():
    sp = path([(0, 0), (10, 0)])
    tilt = np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    import dataclasses

    zp = zone_path(dataclasses.replace(sp, tool_axis=tilt), ZoneSpec(start_length=5))
    assert zp.tool_axis.shape == (3, 3)
    assert np.linalg.norm(zp.tool_axis[1]) == pytest.approx(1.0)
    assert zp.tool_axis[1] == pytest.approx(np.array([0.5, 0, -0.5]) / np.sqrt(0.5))


def test_start_and_end_longer_than_the_path_are_scaled_to_meet():
    zp = zone_path(path([(0, 0), (30, 0)]), ZoneSpec(start_length=20, end_length=40))
    assert zone_lengths(zp) == pytest.approx({"start": 10.0, "end": 20.0})


def test_split_point_inside_a_length_zone_drops_the_empty_middle_zone_but_keeps_ids():
    spec = ZoneSpec(start_length=20, split_points=((10, 0), (60, 0)))
    zp = zone_path(path([(0, 0), (100, 0)]), spec)
    assert list(zone_lengths(zp)) == ["start", "z2", "z3"]
    assert zone_lengths(zp) == pytest.approx({"start": 20.0, "z2": 40.0, "z3": 40.0})


def test_projection_onto_polyline():
    pts = np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0]], float)
    assert project_onto_path(pts, np.array([[4, -3, 0], [12, 7, 0], [-5, 0, 0]], float)).tolist() == [4, 17, 0]


def test_zone_travel_speed_sets_arc_on_segments_only():
    zp = zone_path(
        path([(0, 0), (10, 0), (10, 1), (20, 1)], arc=[True, False, True], speed=5.0), ZoneSpec(start_length=5)
    )
    out = apply_zone_params(
        zp,
        {"start": {"travel_speed": 6.0, "current": 200.0}, "z1": {"travel_speed": 8.0}, "gone": {"travel_speed": 1.0}},
    )
    assert out.zone == ("start", "z1", "z1", "z1")
    assert out.speed.tolist() == [6.0, 8.0, 5.0, 8.0]
    assert set(out.zone_params) == {"start", "z1"} and out.zone_params["start"]["current"] == 200.0
    assert zp.speed.tolist() == [5.0] * 4  # input not mutated


def test_split_points_cut_a_weave_at_their_station_along_the_guide():
    """Issue #22: split points at y = ±6 on a zigzag weave (±3 mm, 3 mm step along y) landed at the
    nearest weave point (y = −7.2 / +4.8); the boundary must be where the weave crosses y = ±6."""
    ys = np.arange(-30.0, 30.0 + 1e-9, 3.0)
    pts = [(3.0 if k % 2 == 0 else -3.0, y) for k, y in enumerate(ys)]
    zp = zone_path(path(pts), ZoneSpec(start_length=5, end_length=5, split_points=((0, -6), (0, 6))))
    ids = list(zone_lengths(zp))
    assert ids == ["start", "z1", "z2", "z3", "end"]
    z = np.array(zp.zone)
    first = {zid: zp.points[int(np.flatnonzero(z == zid)[0])] for zid in ("z2", "z3")}
    assert first["z2"][1] == pytest.approx(-6.0, abs=0.01)
    assert first["z3"][1] == pytest.approx(6.0, abs=0.01)
    # a split point between weave vertices: the cut is interpolated inside the stroke
    zp = zone_path(path(pts), ZoneSpec(split_points=((0, 1.0),)))
    z = np.array(zp.zone)
    assert zp.points[int(np.flatnonzero(z == "z2")[0])][1] == pytest.approx(1.0, abs=0.01)


def test_split_point_on_a_square_weave_stroke_lying_on_its_station():
    # square weave: strokes across x at y = 0, 2, 4, ...; split point (5, 4) lies on the third stroke
    pts = [(0, 0), (10, 0), (10, 2), (0, 2), (0, 4), (10, 4), (10, 6), (0, 6)]
    zp = zone_path(path(pts), ZoneSpec(split_points=((5, 4),)))
    z = np.array(zp.zone)
    assert zp.points[int(np.flatnonzero(z == "z2")[0])].tolist() == pytest.approx([5.0, 4.0, 1.5])


def test_weld_defaults_fill_only_welded_zones_that_lack_them():
    pts = np.array([[0.0, 0, 1], [10, 0, 1], [20, 0, 1], [30, 0, 1]])
    sp = SectionPath(
        "s",
        "parallel",
        pts,
        arc=np.array([True, True, False]),
        inside=np.ones(3, bool),
        speed=np.full(3, 8.0),
        zone=("start", "z1", "link"),
        zone_params={"start": {"wire_feed_speed": 3.0}},
    )
    out = with_weld_defaults(sp, {"wire_feed_speed": 8.1, "current": 120})
    assert out.zone_params == {
        "start": {"wire_feed_speed": 3.0, "current": 120.0},
        "z1": {"wire_feed_speed": 8.1, "current": 120.0},
    }
    assert sp.zone_params == {"start": {"wire_feed_speed": 3.0}}  # the input is not changed
    off = SectionPath("t", "parallel", pts, arc=np.zeros(3, bool), inside=np.ones(3, bool), speed=np.full(3, 8.0))
    assert with_weld_defaults(off, {"wire_feed_speed": 8.1}) is off
