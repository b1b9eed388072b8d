"""Pure display kernels: triangulation, outlines, toolpath polylines, decimation, picking, colours."""

import numpy as np
import pytest
from shapely.geometry import LineString, MultiPolygon, Polygon, box

from waamflow.core.model import Layer, LayerPaths, Layered, Midsurface, SectionPath
from waamflow.viewer import colors as C
from waamflow.viewer import geometry as G
from waamflow.viewer.signature import digest, layer_signatures

from viewer_fixtures import ZONE_COLORS, make_layers, make_toolpath


def test_polygon_triangles_cover_area_with_hole():
    poly = box(0, 0, 40, 20).difference(box(10, 5, 20, 15))
    verts, faces = G.polygon_triangles(poly)
    tri = verts[faces]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    assert area == pytest.approx(800 - 100, rel=1e-9)
    assert faces.max() < len(verts)


def test_section_fill_sits_at_mid_layer():
    layer = Layer(3, 6.0, 1.5, MultiPolygon([box(0, 0, 10, 10)]))
    verts, faces = G.section_fill(layer, box(0, 0, 10, 10))
    assert np.allclose(verts[:, 2], 6.0 - 0.75)
    assert len(faces) == 2


def test_layer_outline_lengths_equal_perimeters():
    region = MultiPolygon([box(0, 0, 40, 20).difference(box(10, 5, 20, 15)), box(50, 0, 60, 10)])
    layer = Layer(0, 1.5, 1.5, region, curves=(LineString([(0, 30), (10, 30), (10, 40)]),))
    outline, curves = G.layer_outline_segments(layer)
    length = np.linalg.norm(outline[:, 1] - outline[:, 0], axis=1).sum()
    assert length == pytest.approx(120 + 40 + 40, rel=1e-6)
    assert len(outline) == 12 and len(curves) == 2
    assert np.allclose(outline[..., 2], 1.5)


def test_layer_outline_follows_frame():
    frame = np.eye(4)
    frame[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # layer plane = world xz plane
    frame[:3, 3] = [0, 5, 0]
    layer = Layer(0, 0.0, 1.0, MultiPolygon([box(0, 0, 10, 10)]), frame=frame)
    outline, _ = G.layer_outline_segments(layer)
    assert np.allclose(outline[..., 1], 5.0)
    assert outline[..., 2].max() == pytest.approx(10.0)


def test_midsurface_strip_area():
    mid = Midsurface((np.array([[0, 0], [30, 0], [30, 20]], float),), height=12.0, z0=2.0)
    verts, faces = G.midsurface_arrays(mid)
    assert verts.shape == (6, 3) and faces.shape == (4, 3)
    tri = verts[faces].astype(float)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
    assert area == pytest.approx((30 + 20) * 12.0)
    assert verts[:, 2].min() == 2.0 and verts[:, 2].max() == 14.0


def test_layer_polyline_counts_travel_and_zone_colours():
    layers = make_layers(1)
    lp = make_toolpath(layers, pts_per_pass=10, passes=5)[0]
    poly = G.layer_polyline(lp)
    n_a, n_b = (len(sp.points) for sp in lp.sections)
    # both sections' segments plus one travel link between them
    assert len(poly.points) - 1 == (n_a - 1) + (n_b - 1) + 1
    assert poly.section_keys == ("bs1/A", "bs1/B")
    link = n_a - 1
    assert poly.travel[link] and not poly.arc[link] and np.isnan(poly.speed[link])
    assert poly.travel.sum() == 1 + 2  # the link and each section's arc-OFF segment
    start = poly.zone_ids.index("start")
    assert (poly.zone_rgb[poly.zone == start] == C.hex_to_rgb(ZONE_COLORS["start"])).all()


def test_approach_points_become_travel():
    layer = Layer(0, 1.5, 1.5)
    pts = np.array([[0, 0, 1.5], [10, 0, 1.5], [10, 5, 1.5]])
    sp = SectionPath(
        "a",
        "raster",
        pts,
        np.ones(2, bool),
        np.ones(2, bool),
        np.full(2, 8.0),
        approach=np.array([[-5, 0, 10.0], [-5, 0, 1.5]]),
    )
    poly = G.layer_polyline(LayerPaths(layer, (sp,)))
    assert len(poly.points) == 5
    assert poly.travel.tolist() == [True, True, False, False]


def test_decimation_keeps_budget_ends_and_attribute_changes():
    n = 200_001
    t = np.linspace(0, 400 * np.pi, n)
    pts = np.column_stack([t, np.sin(t), np.zeros(n)])
    keys = (np.arange(n - 1) // 5000).astype(np.int64)  # 40 runs of one attribute each
    keep = G.decimate_indices(pts, keys, 2000)
    assert keep[0] == 0 and keep[-1] == n - 1
    assert len(keep) - 1 <= 2000 + 40 + 2
    changes = np.flatnonzero(np.diff(keys)) + 1
    assert np.isin(changes, keep).all()
    assert (np.diff(keep) > 0).all()


def test_decimation_is_identity_under_budget():
    pts = np.random.default_rng(0).random((50, 3))
    assert G.decimate_indices(pts, np.zeros(49, np.int64), 100).tolist() == list(range(50))


def test_path_display_decimates_display_not_data():
    layers = make_layers(1)
    lp = make_toolpath(layers, pts_per_pass=4000, passes=5)[0]
    before = [sp.points.copy() for sp in lp.sections]
    disp = G.path_display(G.layer_polyline(lp), 500)
    assert disp.n_source == 2 * (5 * 4000 - 1) + 1
    assert len(disp) <= 500 * 1.5
    # straight passes: decimated drawing keeps the deposited length within 0.1 %
    src = sum(sp.length for sp in lp.sections)
    drawn = np.linalg.norm(disp.segments[:, 1] - disp.segments[:, 0], axis=1)[~disp.travel].sum()
    assert drawn == pytest.approx(src, rel=1e-2)
    for sp, b in zip(lp.sections, before):
        assert np.array_equal(sp.points, b)


def test_ray_pick_prefers_nearest_along_ray():
    pts = np.array([[0, 0, 0], [0, 0, 5], [3, 0, 5]], float)
    assert G.ray_pick(pts, [0, 0, 10], [0, 0, -1], 0.5) == 1
    assert G.ray_pick(pts, [3, 0.2, 10], [0, 0, -1], 0.5) == 2
    assert G.ray_pick(pts, [9, 9, 10], [0, 0, -1], 0.5) is None
    assert G.ray_pick(pts, [0, 0, -10], [0, 0, -1], 0.5) is None  # behind the origin


def test_split_by_layer_and_interpolate():
    layer = np.array([0, 0, 0, 1, 1, 2])
    chunks = G.split_by_layer(layer)
    assert chunks[0].tolist() == [0, 1, 2, 3] and chunks[2].tolist() == [5]
    trace = {
        "t": np.array([0.0, 1.0, 2.0]),
        "x": np.array([0.0, 10.0, 10.0]),
        "y": np.array([0.0, 0.0, 4.0]),
        "z": np.zeros(3),
    }
    pos, i = G.interpolate_trace(trace, 1.5)
    assert i == 1 and np.allclose(pos, [10, 2, 0])
    assert np.allclose(G.interpolate_trace(trace, 99)[0], [10, 4, 0])


def test_colormap_ends_and_nan():
    rgb = C.colormap(np.array([0.0, 10.0, 20.0, np.nan]), 0.0, 10.0)
    assert rgb[0].tolist() == [68, 1, 84] and rgb[1].tolist() == [253, 231, 37]
    assert rgb[2].tolist() == rgb[1].tolist() and rgb[3].tolist() == C.NAN_RGB.tolist()
    assert C.hex_to_rgb("#0a0B0c").tolist() == [10, 11, 12]
    assert C.rgb_to_hex([10, 11, 12]) == "#0a0b0c"
    with pytest.raises(ValueError):
        C.hex_to_rgb("blue")


def test_signatures_follow_content_not_identity():
    a, b = make_toolpath(make_layers(4)), make_toolpath(make_layers(4))
    assert layer_signatures(a) == layer_signatures(b)
    items = list(b.items)
    sp = items[2].sections[0]
    moved = SectionPath(
        sp.key, sp.strategy, sp.points + [0, 0.01, 0], sp.arc, sp.inside, sp.speed, sp.zone, sp.zone_colors
    )
    items[2] = LayerPaths(items[2].layer, (moved,) + items[2].sections[1:])
    changed = [x != y for x, y in zip(layer_signatures(a), layer_signatures(Layered(tuple(items))))]
    assert changed == [False, False, True, False]
    engine = Layered(a.items, ("s0", "s1", "s2", "s3"))
    assert layer_signatures(engine) == ["s0", "s1", "s2", "s3"]
    assert digest(Polygon([(0, 0), (1, 0), (1, 1)])) != digest(Polygon([(0, 0), (1, 0), (0, 1)]))


def test_unzoned_paths_take_their_section_colour():
    layer = make_layers(1)[0]
    pts = np.array([[0, 0, 1.5], [10, 0, 1.5], [10, 5, 1.5]])
    a = SectionPath("bs1/A", "raster", pts, np.ones(2, bool), np.ones(2, bool), np.full(2, 8.0))
    b = SectionPath("bs1/B", "raster", pts + [20, 0, 0], np.ones(2, bool), np.ones(2, bool), np.full(2, 8.0))
    poly = G.layer_polyline(LayerPaths(layer, (a, b)))
    assert (poly.zone_rgb[:2] == C.categorical("bs1/A")).all()
    assert (poly.zone_rgb[3:] == C.categorical("bs1/B")).all()


def test_robot_motion_blends_between_samples():
    from waamflow.viewer.robot import RobotMotion

    joints = np.array([[[0, 0, 0], [0, 0, 100.0]], [[0, 0, 0], [10, 0, 100.0]]])
    m = RobotMotion(np.array([0.0, 2.0]), joints, np.zeros(2), "test")
    assert np.allclose(m.at(0.5), [[0, 0, 0], [2.5, 0, 100]])
    assert np.allclose(m.at(-1), joints[0]) and np.allclose(m.at(9), joints[1])
    assert m.segments(1.0).shape == (1, 2, 3)


def test_link_mesh_tubes_have_the_link_radii():
    from waamflow.viewer.robot import LINK_RADIUS_MM, SIDES, TORCH_RADIUS_MM, link_mesh

    chain = np.array([[0, 0, 0], [0, 0, 500.0], [300, 0, 500], [300, 0, 500], [300, 0, 100]])
    v, f = link_mesh(chain)
    assert v.shape == (4 * 2 * SIDES, 3) and f.shape == (4 * 2 * SIDES, 3) and f.max() == len(v) - 1
    first = v[:SIDES]  # base ring of link 0, in the plane z = 0 around the z axis
    assert np.allclose(np.hypot(first[:, 0], first[:, 1]), LINK_RADIUS_MM[0], atol=1e-3)
    assert np.allclose(first[:, 2], 0.0, atol=1e-3)
    link1 = v[2 * SIDES : 4 * SIDES]  # along x at z = 500: radius about that axis
    assert np.allclose(np.hypot(link1[:, 1], link1[:, 2] - 500), LINK_RADIUS_MM[1], atol=1e-3)
    assert np.isfinite(v).all()  # the zero-length link (a wrist offset of 0) collapses to a ring
    torch = v[-SIDES:]
    assert np.allclose(np.hypot(torch[:, 0] - 300, torch[:, 1]), TORCH_RADIUS_MM, atol=1e-3)


def test_zone_order_along_a_path():
    from waamflow.viewer.scene import _zone_order

    assert sorted(["end", "z10", "start", "z2", "x"], key=_zone_order) == ["start", "z2", "z10", "end", "x"]
