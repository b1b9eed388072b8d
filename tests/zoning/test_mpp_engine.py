"""The MPP nodes through the engine: failure location, per-layer caching, XML values in the toolpath."""

import json
import re

import pytest

import mpp_toys  # noqa: F401  (registers the toy node types)
from waamflow.core.errors import PlanningError
from waamflow.engine.cache import MemoryCache
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.zoning import parse


def rect(x0, y0, x1, y1):
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


BS1 = {"id": "bs1", "from_layer": 0, "sections": [{"id": "A", "curve": rect(-1, -1, 101, 7)}]}
BS2 = {
    "id": "bs2",
    "from_layer": 5,
    "sections": [{"id": "L", "curve": rect(-1, -1, 50, 7)}, {"id": "R", "curve": rect(50, -1, 101, 7)}],
}


def recipe(masks, zone=None, count=10, window_from=5, parameters=None, order="mask"):
    zone = dict(zone or {"default": {"start_length": 10, "end_length": 10}})
    if parameters:
        zone["parameters"] = parameters
    return parse_recipe(
        {
            "format": "waamflow/1",
            "name": "walls",
            "nodes": [
                {"id": "stack", "type": "toy-mpp-walls", "params": {"count": count, "window_from": window_from}},
                {"id": "mask", "type": "mask", "params": {"masks": masks}},
                {"id": "guide", "type": "guide", "params": {"guides": {"bs1/A": [[-5, 3], [105, 3]]}}},
                {"id": "paths", "type": "toy-mpp-pass", "params": {}},
                {"id": "zone", "type": "zone", "params": zone},
                {"id": "seq", "type": "sequence", "params": {"order": order, "retract_height": 5}},
            ],
            "edges": [
                {"from": "stack.layers", "to": "mask.layers"},
                {"from": "mask.sections", "to": "guide.sections"},
                {"from": "guide.sections", "to": "paths.sections"},
                {"from": "paths.toolpath", "to": "zone.toolpath"},
                {"from": "zone.toolpath", "to": "seq.toolpath"},
            ],
        }
    )


def run(rec, tmp_path, cache=None, **kw):
    return execute(build_graph(rec), resolver=FileResolver(tmp_path), cache=cache, **kw)


def test_topology_change_fails_at_first_changed_layer_and_a_second_mask_fixes_it(tmp_path):
    with pytest.raises(PlanningError) as e:
        run(recipe([BS1]), tmp_path)
    assert (e.value.node, e.value.layer, e.value.section) == ("mask", 5, "bs1/A")
    assert str(e.value).startswith("node 'mask', layer 5, section 'bs1/A'")
    res = run(recipe([BS1, BS2]), tmp_path)
    tp = res.outputs["seq"]["toolpath"]
    assert [[s.key for s in lp.sections] for lp in tp][4:6] == [["bs1/A"], ["bs2/L", "bs2/R"]]
    assert [s.length for s in tp[7].sections] == pytest.approx([40.0, 40.0])  # default guides, long axis


def test_editing_one_mask_recomputes_only_the_layers_it_governs(tmp_path):
    cache = MemoryCache()
    run(recipe([BS1, BS2]), tmp_path, cache)
    bs2b = dict(BS2, sections=[BS2["sections"][0], {"id": "R", "curve": rect(50, -1, 102, 8)}])
    res = run(recipe([BS1, bs2b]), tmp_path, cache)
    st = res.stats["mask"]
    assert (st.layers_cached, st.layers_computed) == (5, 5)
    # downstream, too, only bs2's layers are recomputed; bs1's five stay cached
    for node in ("guide", "paths", "zone"):
        assert (res.stats[node].layers_cached, res.stats[node].layers_computed) == (5, 5)


def test_editing_one_sections_zoning_recomputes_only_its_layers(tmp_path):
    cache = MemoryCache()
    zone = {"default": {"start_length": 10, "end_length": 10}}
    run(recipe([BS1, BS2], zone), tmp_path, cache)
    zone2 = dict(zone, sections={"bs2/L": {"start_length": 5, "split_points": [[20, 3]]}})
    res = run(recipe([BS1, BS2], zone2), tmp_path, cache)
    assert (res.stats["zone"].layers_computed, res.stats["paths"].layers_computed) == (5, 0)
    lp = res.outputs["zone"]["toolpath"][6]
    left = lp.sections[0]
    assert left.key == "bs2/L" and left.zone == ("start", "z1", "z2")
    # one layer only (what the GUI previews): the executor's layer restriction
    one = run(recipe([BS1, BS2], dict(zone2, sections={"bs2/L": {"start_length": 7}})), tmp_path, cache, layers=[6])
    assert one.stats["zone"].layers_computed == 1
    assert one.outputs["zone"]["toolpath"][5] is None
    assert [round(x, 6) for x in (one.outputs["zone"]["toolpath"][6].sections[0].segment_lengths)] == [7.0, 33.0]


def test_xml_values_flow_into_the_toolpath_and_editing_it_recomputes_no_layer(tmp_path):
    cache = MemoryCache()
    rec = recipe([BS1, BS2], parameters="walls.params.xml")
    first = run(rec, tmp_path, cache)
    assert any("not found" in w["message"] for w in first.warnings)
    xml = first.artifacts["zone.params.xml"].decode()
    assert xml.count("<zone ") == 5 * 3 + 5 * 2 * 3
    # the zone line carries bead_mm3_per_mm and a feed comment follows it (issue #22 item 5): matched loosely
    xml, n = re.subn(
        r'(<layer index="2" z="4.5">\n    <section id="bs1/A">\n      <zone id="start" color="#d62728"[^>]*>\n'
        r"(?:        <!--[^>]*-->\n)?)"
        r'        <current unit="A"></current>\n        <voltage unit="V"></voltage>\n'
        r'        <wire_feed_speed unit="m/min"></wire_feed_speed>\n'
        r'        <travel_speed unit="mm/s"></travel_speed>',
        r'\1        <current unit="A">200</current>\n        <voltage unit="V"></voltage>\n'
        r'        <wire_feed_speed unit="m/min">10</wire_feed_speed>\n'
        r'        <travel_speed unit="mm/s">6</travel_speed>',
        xml,
        count=1,
    )
    assert n == 1
    (tmp_path / "walls.params.xml").write_text(xml)
    res = run(rec, tmp_path, cache)
    assert res.stats["zone"].layers_computed == 0 and res.stats["paths"].layers_computed == 0
    sp = res.outputs["zone"]["toolpath"][2].sections[0]
    assert sp.zone == ("start", "z1", "end") and sp.speed.tolist() == [6.0, 5.0, 5.0]
    assert sp.zone_params == {"start": {"current": 200.0, "wire_feed_speed": 10.0, "travel_speed": 6.0}}
    assert res.outputs["seq"]["toolpath"][2].sections[0].speed.tolist() == [6.0, 5.0, 5.0]
    out = json.loads(res.artifacts["zone.toolpath.json"])
    assert out["layers"][2]["sections"][0]["speed"] == [6.0, 5.0, 5.0]
    assert parse(res.artifacts["zone.params.xml"].decode()).values == {
        (2, "bs1/A", "start"): {"current": 200.0, "wire_feed_speed": 10.0, "travel_speed": 6.0}
    }

    # the mask now governs from layer 2: layer 2's bs1/A values become orphans
    later = recipe([BS1, dict(BS2, from_layer=2)], parameters="walls.params.xml", window_from=5)
    res = run(later, tmp_path, cache)
    orphan = [w for w in res.warnings if "no zone any more" in w["message"]]
    assert [w["message"].split(" have")[0] for w in orphan] == [
        "parameter file: values for layer 2, section 'bs1/A', zone 'start'"
    ]
    assert parse(res.artifacts["zone.params.xml"].decode()).values == {}


def test_sequence_travel_artifact(tmp_path):
    res = run(recipe([BS1, BS2], order="nearest"), tmp_path)
    travel = json.loads(res.artifacts["seq.travel.json"])
    # issue #22 seams: the single wall alternates its ends (layer 4 ends at x = 100), so layer 5
    # starts with R reversed right there (it flew 100 mm back to x = 0 before: 141.5 mm)
    assert [t["order"] for t in travel["layers"]][5] == ["bs2/R", "bs2/L"]
    # layer 5: from (100, 3, 7.5) up to z 14 (6.5), no move across, down 5 to (100, 3, 9); then
    # R ends at x 60, L starts at 40: 5 up, 20 across, 5 down
    assert travel["layers"][5]["travel_mm"] == pytest.approx(6.5 + 0 + 5 + 30)
    assert travel["total_travel_mm"] == pytest.approx(sum(t["travel_mm"] for t in travel["layers"]))


def test_uncovered_area_is_warned_per_layer_in_percent(tmp_path):
    part = {"id": "bs1", "from_layer": 0, "sections": [{"id": "A", "curve": rect(-1, -1, 60, 7)}]}
    res = run(recipe([part], count=3, window_from=99), tmp_path)
    ws = [w for w in res.warnings if w["node"] == "mask"]
    assert [w["layer"] for w in ws] == [0, 1, 2]
    assert ws[0]["message"].startswith("40.0 % of the layer area (240.0 mm²)")


def test_params_for_unknown_sections_are_warned(tmp_path):
    rec = recipe([BS1], zone={"sections": {"bs1/Z": {"start_length": 3}}}, count=2, order=["bs1/A", "nope"])
    res = run(rec, tmp_path)
    msgs = sorted((w["node"], w["section"]) for w in res.warnings if "matches no section" in w["message"])
    assert msgs == [("seq", "nope"), ("zone", "bs1/Z")]


def test_sequence_follows_a_change_in_the_layer_below_with_a_warm_cache(tmp_path):
    cache = MemoryCache()
    before = run(recipe([BS1, BS2]), tmp_path, cache).outputs["seq"]["toolpath"]
    assert before[5].sections[0].approach[0][:2].tolist() == [100.0, 3.0]  # layer 4 ended at x = 100
    rec = recipe([BS1, BS2])
    rec.nodes[2].params["guides"]["bs1/A"] = [[105, 3], [-5, 3]]  # bs1 now deposits right → left
    res = run(rec, tmp_path, cache)
    assert res.stats["guide"].layers_computed == 5 and res.stats["zone"].layers_cached == 5
    after = res.outputs["seq"]["toolpath"]
    assert after[5].sections[0].approach[0][:2].tolist() == [0.0, 3.0]  # layer 5 starts from x = 0


def test_a_self_intersecting_mask_curve_is_an_invalid_recipe():
    from waamflow.core.errors import RecipeError

    bow = {"id": "bs1", "sections": [{"id": "A", "curve": [[0, 0], [10, 10], [10, 0], [0, 10]]}]}
    with pytest.raises(RecipeError) as e:
        build_graph(recipe([bow]))
    assert e.value.node == "mask" and e.value.exit_code == 2 and "bs1/A" in e.value.message


def test_a_mask_starting_above_the_part_is_warned(tmp_path):
    res = run(recipe([BS1, dict(BS2, from_layer=40)], count=3, window_from=99), tmp_path)
    assert [w["message"] for w in res.warnings if w["node"] == "mask"] == [
        "mask 'bs2' starts at layer 40 but the part has 3 layers: it governs none"
    ]
