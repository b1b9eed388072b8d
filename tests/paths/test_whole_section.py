"""Issue #22 item 3, "the whole section gets a path": a part with no mask (each connected region of a
layer is one section) must be covered by its default path, and a masked section its path leaves
uncovered is reported with its size, layer and section.

The covered share is measured here independently of the kernels: the arc-ON path buffered by half
the 6 mm bead width (round caps, the weld pool), intersected with the layer polygon. A weave
(oscillate) lays one wide bead: between two consecutive strokes whose outer vertices on the same
side are at most a bead width apart the pool bridges the gap, so the triangle of three consecutive
weave vertices counts as deposited there (`weave=True`); without that bridge the default weave
(step 3 mm, 6 mm bead) would leave scallops of 3 mm depth between its vertices along every edge
(92 % of a 120 × 16 mm box), which is the weave's edge, not an unbuilt area.
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
import trimesh
from shapely.geometry import LineString, MultiLineString, Point, Polygon, box

from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe

W = 6.0  # bead width, mm (the strategy's default)

L_SHAPE = box(0, 0, 120, 16).union(box(0, 0, 16, 64))  # 120 × 16 arm + 64 × 16 arm
T_SHAPE = box(0, 0, 120, 16).union(box(52, 0, 68, 64))
U_SHAPE = shapely.union_all([box(0, 0, 120, 16), box(0, 0, 16, 64), box(104, 0, 120, 64)])
FRAME = box(0, 0, 80, 60).difference(box(16, 16, 64, 44))  # annulus-like, square
RING = Point(0, 0).buffer(40, quad_segs=32).difference(Point(0, 0).buffer(24, quad_segs=32))
CONVEX = box(0, 0, 120, 16)


def _runs(points: np.ndarray, arc: np.ndarray) -> list[np.ndarray]:
    runs, start = [], None
    for i, on in enumerate(np.concatenate([np.asarray(arc, bool), [False]])):
        if on and start is None:
            start = i
        elif not on and start is not None:
            runs.append(points[start : i + 1, :2])
            start = None
    return runs


def deposited(points, arc, width=W, weave=False):
    """Footprint of the arc-ON runs (see module doc)."""
    runs = [r for r in _runs(np.asarray(points, float), arc) if len(r) >= 2]
    if not runs:
        return Polygon()
    parts = [MultiLineString([LineString(r) for r in runs]).buffer(width / 2, quad_segs=16)]
    if weave:
        tri = [
            Polygon(r[k - 1 : k + 2])
            for r in runs
            for k in range(1, len(r) - 1)
            if np.hypot(*(r[k + 1] - r[k - 1])) <= width * (1 + 1e-9)
        ]
        parts += [t.buffer(width / 2, quad_segs=16) for t in tri if t.area > 0]
    return shapely.union_all(parts)


def covered_share(region, section_paths) -> float:
    foot = shapely.union_all([deposited(sp.points, sp.arc, weave=sp.strategy == "oscillate") for sp in section_paths])
    return float(foot.intersection(region).area / region.area)


def _stl(tmp_path, region, height=10.0, name="part.stl"):
    mesh = trimesh.creation.extrude_polygon(region, height)
    path = tmp_path / name
    mesh.export(path)
    return path


def run_part(tmp_path, region, strategy=None, masks=None, guides=None, layers=None):
    """mesh → slice → mask → guide → strategy with default params unless given (as graphs/*.json)."""
    stl = _stl(tmp_path, region)
    nodes = [
        {"id": "part", "type": "mesh", "params": {"path": str(stl)}},
        {
            "id": "layers",
            "type": "slice",
            "params": {"layer_height": 1.5, **({"layer_count": layers} if layers else {})},
        },
        {"id": "mask", "type": "mask", "params": {"masks": masks or []}},
        {"id": "guide", "type": "guide", "params": {"guides": guides or {}}},
        {"id": "strategy", "type": "strategy", "params": strategy or {}},
    ]
    edges = [
        ("part.mesh", "layers.mesh"),
        ("layers.layers", "mask.layers"),
        ("mask.sections", "guide.sections"),
        ("guide.sections", "strategy.sections"),
    ]
    data = {
        "format": "waamflow/1",
        "name": "t",
        "inputs": {},
        "nodes": nodes,
        "edges": [{"from": a, "to": b} for a, b in edges],
    }
    return execute(build_graph(parse_recipe(data)), resolver=FileResolver(str(tmp_path)))


@pytest.mark.parametrize(
    "name, region",
    [("L", L_SHAPE), ("T", T_SHAPE), ("U", U_SHAPE), ("frame", FRAME), ("ring", RING), ("convex", CONVEX)],
)
def test_default_path_covers_every_layer(tmp_path, name, region):
    res = run_part(tmp_path, region, layers=2)
    tp = res.outputs["strategy"]["toolpath"]
    assert len(tp) == 2
    for lp in tp:
        assert lp.layer.area == pytest.approx(region.area, rel=1e-3)
        assert covered_share(lp.layer.region, lp.sections) >= 0.98, name


def test_l_report_names_the_split_and_the_toolpath_keeps_one_section(tmp_path):
    res = run_part(tmp_path, L_SHAPE, layers=2)
    tp = res.outputs["strategy"]["toolpath"]
    assert [[(sp.key, sp.strategy) for sp in lp.sections] for lp in tp] == [[("region0", "oscillate")]] * 2
    sp = tp[0].sections[0]
    assert int(np.count_nonzero(np.diff(np.r_[0, sp.arc.astype(int), 0]))) == 4  # two arc-ON runs
    assert not [w for w in res.warnings if w["node"] == "strategy"]
    cover = res.stats["strategy"].report["cover"]
    assert cover["sections_split"] == 2 and cover["sections_as_planned"] == 0 and cover["sections_contour"] == 0
    assert cover["changed"] == [
        {
            "section": "region0",
            "how": "split",
            "pattern": "oscillate",
            "pieces": 2,
            "layers": "0-1",
            "max_uncovered_share": pytest.approx(0.00287, abs=5e-5),
        }
    ]


def test_ring_falls_back_to_contour_named_in_the_toolpath(tmp_path):
    res = run_part(tmp_path, RING, layers=1)
    sp = res.outputs["strategy"]["toolpath"][0].sections[0]
    assert sp.strategy == "contour"
    assert json_sections(res)[0]["strategy"] == "contour"
    assert res.stats["strategy"].report["cover"]["sections_contour"] == 1


def json_sections(res):
    import json

    return json.loads(res.artifacts["strategy.toolpath.json"])["layers"][0]["sections"]


def test_masked_section_left_uncovered_is_warned_not_replanned(tmp_path):
    """A drawn mask section is the user's: its path stays as planned, its uncovered area is warned
    with its size, layer and section."""
    curve = [[-1, -1], [121, -1], [121, 17], [17, 17], [17, 65], [-1, 65]]
    res = run_part(
        tmp_path, L_SHAPE, layers=2, masks=[{"id": "bs1", "from_layer": 0, "sections": [{"id": "A", "curve": curve}]}]
    )
    lp = res.outputs["strategy"]["toolpath"][1]
    share = covered_share(lp.layer.region, lp.sections)
    assert share == pytest.approx(0.3957, abs=1e-3)  # the default weave along the long axis
    warns = [w for w in res.warnings if w["node"] == "strategy"]
    assert [(w["layer"], w["section"]) for w in warns] == [(0, "bs1/A"), (1, "bs1/A")]
    uncovered = (1 - share) * L_SHAPE.area
    msg = warns[1]["message"]
    assert msg.startswith(
        f"{uncovered:.1f} mm² (60.4 %) of section bs1/A on layer 1 gets no bead (oscillate): "
        "add a mask section there or choose a filling pattern"
    )
    assert res.stats["strategy"].report["cover"]["sections_as_planned"] == 2


def test_whole_regions_off_keeps_the_path_and_warns(tmp_path):
    res = run_part(tmp_path, L_SHAPE, layers=1, strategy={"whole_regions": "off"})
    lp = res.outputs["strategy"]["toolpath"][0]
    assert covered_share(lp.layer.region, lp.sections) == pytest.approx(0.3957, abs=1e-3)
    assert [w["section"] for w in res.warnings if w["node"] == "strategy"] == ["region0"]


def test_masked_sections_that_are_covered_give_no_warning(tmp_path):
    """The L drawn as two mask sections (the corner division by hand): both covered, no warning."""
    masks = [
        {
            "id": "bs1",
            "from_layer": 0,
            "sections": [
                {"id": "A", "curve": [[-1, -1], [121, -1], [121, 16], [-1, 16]]},
                {"id": "B", "curve": [[-1, 16], [17, 16], [17, 65], [-1, 65]]},
            ],
        }
    ]
    res = run_part(tmp_path, L_SHAPE, layers=1, masks=masks)
    lp = res.outputs["strategy"]["toolpath"][0]
    assert [sp.key for sp in lp.sections] == ["bs1/A", "bs1/B"]
    assert covered_share(lp.layer.region, lp.sections) >= 0.98
    assert not [w for w in res.warnings if w["node"] == "strategy"]


def test_cross_without_mask_is_never_welded_off_the_part(tmp_path):
    """mpp-cross's layer with no mask and a parallel fill (arc_outside 'on', the default): the
    passes as planned crossed the notches between the arms arc ON, up to 26 mm off the part (the
    preflight then failed the program). The node splits the region at its corners: every arc-ON
    point lies within a bead width of the part, the layer is covered, nothing is warned."""
    cross = box(-60, -6, 60, 6).union(box(-6, -60, 6, 60))
    res = run_part(tmp_path, cross, layers=2, strategy={"default": {"pattern": "parallel", "spacing": 5.0}})
    for lp in res.outputs["strategy"]["toolpath"]:
        (sp,) = lp.sections
        on = np.flatnonzero(sp.arc)
        mids = shapely.points(0.5 * (sp.points[on, :2] + sp.points[on + 1, :2]))
        assert float(shapely.distance(lp.layer.region, mids).max()) <= W
        assert covered_share(lp.layer.region, lp.sections) >= 0.99
    assert res.stats["strategy"].report["cover"]["sections_split"] == 2
    assert not [w for w in res.warnings if w["node"] == "strategy"]


def test_a_whole_region_still_welded_off_is_warned(tmp_path, monkeypatch):
    """When no plan keeps the arc on the part (stood in for here: every plan is said to weld 7.5 mm
    off it), the node warns the layer and section with the length and what to do."""
    import dataclasses

    from waamflow.nodes import strategy as node

    real = node.plan_whole
    monkeypatch.setattr(node, "plan_whole", lambda *a, **k: dataclasses.replace(real(*a, **k), outside=7.5))
    res = run_part(tmp_path, CONVEX, layers=1)
    (w,) = [w for w in res.warnings if w["node"] == "strategy"]
    assert (w["layer"], w["section"]) == (0, "region0")
    assert w["message"].startswith("7.5 mm of arc-ON path of section region0 on layer 0 runs off the part")


@pytest.mark.parametrize("pattern", ["parallel", "raster", "oscillate"])
def test_passes_across_a_hole_of_the_section_fly_arc_off(pattern):
    """A mask section holding a hole of the part (planned as given: adapt off) kept the arc on across
    the hole, `arc_outside: on` being meant for run-ups into the neighbouring sections: 377 mm of
    weld in the hole of a 57.6/28.9 mm ring (parallel, 5.8 mm beads). The arc is off over the
    section's holes; outside its outline `arc_outside` decides as before."""
    from shapely.geometry import LineString, Point

    from waamflow.paths import StrategySpec
    from waamflow.paths.whole import plan_whole

    region = Point(0, 0).buffer(57.6, quad_segs=16).difference(Point(1.8, 0).buffer(28.9, quad_segs=16))
    path = plan_whole(region, None, StrategySpec(pattern=pattern, bead_width=5.8), adapt=False).path
    hole = Point(1.8, 0).buffer(28.9 - 0.5)
    on = [LineString(path.points[i : i + 2]) for i in range(len(path.arc)) if path.arc[i]]
    assert sum(s.intersection(hole).length for s in on) == pytest.approx(0.0, abs=1e-6)
    assert sum(s.length for s in on) > 1000.0  # the ring is still welded: ~2 × its area / bead width


def test_a_section_planned_as_given_that_welds_off_the_part_is_warned(tmp_path):
    """A section planned as given (a drawn mask's, or `whole_regions: off`) was never measured for
    weld off the part: a U's parallel passes crossed its notch arc-on (arc_outside 'on', 135 mm more
    than a bead off the part a layer) with no word from the node; only the preflight failed the
    program at the end. The node now measures such a section against the layer's part, as it does
    a whole region, and warns the layer and section."""
    res = run_part(
        tmp_path,
        U_SHAPE,
        layers=1,
        strategy={"whole_regions": "off", "default": {"pattern": "parallel", "spacing": 5.0}},
    )
    (w,) = [w for w in res.warnings if w["node"] == "strategy" and "runs off the part" in w["message"]]
    assert (w["layer"], w["section"]) == (0, "region0")
    assert float(w["message"].split(" mm of arc-ON")[0]) > 20.0
