"""Segmentation by Building-Strategy masks: section areas, overlap rule, failure layer index."""

import pytest
import shapely
from shapely.geometry import box

from waamflow.core.errors import PlanningError, RecipeError
from waamflow.core.model import Layer, as_multipolygon
from waamflow.sections import Mask, connected_sections, governing_mask, segment_layer
from waamflow.sections.mask import uncovered_percent


def layer(i, geom, dz=1.5):
    return Layer(index=i, z=dz * (i + 1), thickness=dz, region=as_multipolygon(shapely.normalize(geom)))


def cross():
    """Cross test piece section: arms 12 mm wide, 120 mm tip to tip → area 2·1440 − 144 = 2736 mm²."""
    return shapely.union(box(-60, -6, 60, 6), box(-6, -60, 6, 60))


def rect(x0, y0, x1, y1):
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


CROSS_MASK = {
    "id": "bs1",
    "from_layer": 0,
    "sections": [
        {"id": "A", "curve": rect(-6, -61, 6, 61)},
        {"id": "B", "curve": rect(-61, -7, -6, 7)},
        {"id": "C", "curve": rect(6, -7, 61, 7)},
    ],
}


def test_cross_sections_areas_cover_the_layer():
    ls = segment_layer(layer(0, cross()), Mask.from_json(CROSS_MASK))
    assert [s.key for s in ls.sections] == ["bs1/A", "bs1/B", "bs1/C"]
    assert [s.order for s in ls.sections] == [0, 1, 2]
    assert [round(s.region.area, 6) for s in ls.sections] == [1440.0, 648.0, 648.0]
    assert ls.uncovered_area == 0.0


def test_earlier_section_owns_the_overlap():
    m = {
        "id": "bs1",
        "sections": [{"id": "A", "curve": rect(-6, -61, 6, 61)}, {"id": "B", "curve": rect(-61, -7, 0, 7)}],
    }  # B drawn over the centre
    ls = segment_layer(layer(0, cross()), Mask.from_json(m))
    a, b = ls.sections
    assert b.region.area == pytest.approx(648.0)  # 54 × 12, centre excluded
    assert a.region.intersection(b.region).area == pytest.approx(0.0, abs=1e-9)
    assert ls.uncovered_area == pytest.approx(648.0)  # right arm not covered
    assert uncovered_percent(ls) == pytest.approx(100 * 648 / 2736)


def test_later_section_cut_in_two_by_an_earlier_one_fails():
    m = {
        "id": "bs1",
        "sections": [{"id": "A", "curve": rect(-6, -61, 6, 61)}, {"id": "B", "curve": rect(-61, -7, 61, 7)}],
    }
    with pytest.raises(PlanningError) as e:
        segment_layer(layer(3, cross()), Mask.from_json(m))
    assert e.value.layer == 3 and e.value.section == "bs1/B"
    assert "2 separate regions" in e.value.message


def test_no_mask_each_connected_region_is_a_section_largest_first():
    ls = segment_layer(layer(0, shapely.union(box(0, 0, 10, 10), box(20, 0, 50, 10))), None)
    assert [s.key for s in ls.sections] == ["region0", "region1"]
    assert [s.region.area for s in ls.sections] == [300.0, 100.0]
    assert connected_sections(layer(0, box(0, 0, 1, 1))).sections[0].region.area == 1.0


def test_curve_outside_the_layer_fails_naming_layer_and_section():
    m = {"id": "m", "sections": [{"id": "far", "curve": rect(200, 200, 210, 210)}]}
    with pytest.raises(PlanningError) as e:
        segment_layer(layer(7, cross()), Mask.from_json(m))
    assert (e.value.layer, e.value.section, e.value.exit_code) == (7, "m/far", 3)


def test_invalid_curve_is_a_recipe_error():
    with pytest.raises(RecipeError) as e:
        Mask.from_json({"id": "m", "sections": [{"id": "bow", "curve": [[0, 0], [10, 10], [10, 0], [0, 10]]}]})
    assert e.value.section == "m/bow" and e.value.exit_code == 2


def test_governing_mask_runs_until_the_next_mask():
    m1 = Mask.from_json({"id": "bs1", "from_layer": 0, "sections": CROSS_MASK["sections"]})
    m2 = Mask.from_json({"id": "bs2", "from_layer": 5, "sections": CROSS_MASK["sections"]})
    late = Mask.from_json({"id": "bs3", "from_layer": 2, "sections": CROSS_MASK["sections"]})
    assert [governing_mask([m2, m1], i).id for i in (0, 4, 5, 9)] == ["bs1", "bs1", "bs2", "bs2"]
    assert governing_mask([late], 1) is None and governing_mask([late], 2).id == "bs3"


def plan_stack(layers, masks):
    """Segment each layer with its governing mask; returns the per-layer sections (raises on failure)."""
    ms = [Mask.from_json(m) for m in masks]
    return [segment_layer(l, governing_mask(ms, l.index)) for l in layers]


def test_topology_change_fails_at_the_first_changed_layer_then_succeeds_with_a_second_mask():
    # A 100 mm wall that opens a 20 mm window from layer 5 up: two separate regions from there.
    wall = [layer(i, box(0, 0, 100, 6)) for i in range(5)]
    window = [layer(i, shapely.union(box(0, 0, 40, 6), box(60, 0, 100, 6))) for i in range(5, 10)]
    stack = wall + window
    bs1 = {"id": "bs1", "from_layer": 0, "sections": [{"id": "A", "curve": rect(-1, -1, 101, 7)}]}
    with pytest.raises(PlanningError) as e:
        plan_stack(stack, [bs1])
    assert e.value.layer == 5 and e.value.section == "bs1/A"

    bs2 = {
        "id": "bs2",
        "from_layer": 5,
        "sections": [{"id": "L", "curve": rect(-1, -1, 50, 7)}, {"id": "R", "curve": rect(50, -1, 101, 7)}],
    }
    planned = plan_stack(stack, [bs1, bs2])
    assert [len(ls.sections) for ls in planned] == [1] * 5 + [2] * 5
    assert planned[4].sections[0].key == "bs1/A" and planned[4].sections[0].region.area == pytest.approx(600.0)
    assert [s.key for s in planned[5].sections] == ["bs2/L", "bs2/R"]
    assert [s.region.area for s in planned[9].sections] == pytest.approx([240.0, 240.0])


def test_a_surface_layer_is_named_as_such_not_blamed_on_the_mask():
    """An open mesh is read as a single-wall surface: its layers are curves with no area. A mask on
    it said 'mask curve yields no region on this layer; start a new mask here' (a mesh with 5 faces
    dropped, found by a mesh fuzz), sending the user to the mask. It names the surface and what to do."""
    from shapely.geometry import LineString

    surface = Layer(
        index=3, z=6.0, thickness=1.5, curves=(LineString([(-50, 0), (50, 0)]), LineString([(0, 5), (0, 40)]))
    )
    with pytest.raises(
        PlanningError, match=r"no area to segment: the part is a single-wall surface, its layer is 2 curve"
    ) as e:
        segment_layer(surface, Mask.from_json(CROSS_MASK))
    assert (e.value.layer, e.value.section) == (3, "bs1/A")
    with pytest.raises(PlanningError, match=r"mask curve yields no region"):  # an empty solid layer: as before
        segment_layer(layer(3, box(100, 100, 110, 110)), Mask.from_json(CROSS_MASK))
