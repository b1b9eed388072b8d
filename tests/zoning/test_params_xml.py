"""The XML deposition-parameter file: template, safe validated parsing, merge keeping values, orphans."""

import re

import numpy as np
import pytest
from shapely.geometry import box

from waamflow.core.errors import RecipeError
from waamflow.core.model import Layer, LayerPaths, SectionPath, as_multipolygon
from waamflow.core.process import ZONE_PARAMETERS
from waamflow.zoning import ZoneSpec, merge, parse, template, validate_xml, zone_path
from waamflow.zoning import params_xml


def zoned(key, x0, x1, z, spec):
    pts = np.array([[x0, 0, z], [x1, 0, z]], float)
    sp = SectionPath(key, "oscillate", pts, np.ones(1, bool), np.ones(1, bool), np.full(1, 5.0))
    return zone_path(sp, spec)


def toolpath(n_layers=2, spec=ZoneSpec(10, 10, ((50, 0),)), keys=("bs1/A", "bs1/B")):
    out = []
    for i in range(n_layers):
        z = 1.5 * (i + 1)
        layer = Layer(i, z, 1.5, as_multipolygon(box(0, -5, 100, 5)))
        out.append(LayerPaths(layer, tuple(zoned(k, 0, 100, z, spec) for k in keys)))
    return out


def fill(xml, layer, section, zone, name, value):
    """Set one value in a parameter file by regex (as a user editing the file would)."""
    pat = (
        rf'(<layer index="{layer}"[^>]*>(?:(?!</layer>).)*?<section id="{re.escape(section)}">'
        rf'(?:(?!</section>).)*?<zone id="{zone}"[^>]*>(?:(?!</zone>).)*?<{name} unit="[^"]*">)(</{name}>)'
    )
    new, n = re.subn(pat, rf"\g<1>{value}\g<2>", xml, count=1, flags=re.S)
    assert n == 1, (layer, section, zone, name)
    return new


def test_template_mirrors_layer_section_zone_with_empty_parameters():
    xml = template(toolpath())
    t = parse(xml)
    assert len(t.zones) == 2 * 2 * 4 and t.values == {}
    assert t.zones[:4] == ((0, "bs1/A", "start"), (0, "bs1/A", "z1"), (0, "bs1/A", "z2"), (0, "bs1/A", "end"))
    assert t.layer_z == {0: 1.5, 1: 3.0}
    assert t.colors[(0, "bs1/A", "start")] == "#d62728"
    assert xml.count('<current unit="A"></current>') == 16
    assert xml.count("<zone ") == 16 and xml.count('<wire_feed_speed unit="m/min">') == 16
    for p in ZONE_PARAMETERS:
        assert f'<{p.name} unit="{p.unit}">' in xml


def test_round_trip_keeps_values_and_merge_keeps_them_on_a_new_template():
    xml = template(toolpath())
    xml = fill(xml, 0, "bs1/A", "start", "travel_speed", 6)
    xml = fill(xml, 0, "bs1/A", "start", "wire_feed_speed", 10)
    xml = fill(xml, 1, "bs1/B", "z2", "current", 210)
    t = parse(xml)
    assert t.values == {
        (0, "bs1/A", "start"): {"travel_speed": 6.0, "wire_feed_speed": 10.0},
        (1, "bs1/B", "z2"): {"current": 210.0},
    }
    merged, orphans = merge(template(toolpath()), xml)
    assert orphans == [] and parse(merged).values == t.values
    again, _ = merge(merged, merged)
    assert again == merged


def test_merge_reports_orphans_when_zones_and_sections_disappear():
    xml = template(toolpath(3))
    xml = fill(xml, 0, "bs1/A", "z2", "current", 200)  # z2 disappears (no split point any more)
    xml = fill(xml, 2, "bs1/B", "start", "current", 190)  # section B disappears
    xml = fill(xml, 1, "bs1/A", "end", "dwell", 0.5)  # survives
    new = template(toolpath(3, spec=ZoneSpec(10, 10), keys=("bs1/A",)))
    merged, orphans = merge(new, xml)
    assert orphans == ["layer 0, section 'bs1/A', zone 'z2'", "layer 2, section 'bs1/B', zone 'start'"]
    assert parse(merged).values == {(1, "bs1/A", "end"): {"dwell": 0.5}}
    assert merge(new, None) == (new, [])


@pytest.mark.parametrize(
    "name, value, where",
    [
        ("current", "5000", "outside"),
        ("travel_speed", "fast", "not a number"),
        ("wire_feed_speed", "nan", "outside"),
    ],
)
def test_bad_values_name_layer_section_and_zone(name, value, where):
    xml = fill(template(toolpath()), 1, "bs1/B", "z1", name, value)
    with pytest.raises(RecipeError) as e:
        parse(xml)
    assert (e.value.layer, e.value.section, e.value.field) == (1, "bs1/B", name)
    assert "zone 'z1'" in e.value.message and where in e.value.message and e.value.exit_code == 2


def test_wrong_unit_and_unknown_parameter_are_rejected():
    xml = template(toolpath(1))
    with pytest.raises(RecipeError, match="unit is 'mm/min'"):
        parse(xml.replace('<travel_speed unit="mm/s">', '<travel_speed unit="mm/min">', 1))
    with pytest.raises(RecipeError, match="unknown parameter <amps>"):
        parse(xml.replace('<current unit="A"></current>', "<amps>3</amps>", 1))
    with pytest.raises(RecipeError, match="root element"):
        parse("<params/>")
    with pytest.raises(RecipeError, match="not well-formed"):
        parse("<parameters><layer index='0'>")
    with pytest.raises(RecipeError, match="layer listed twice"):
        parse("<parameters><layer index='0'/><layer index='0'/></parameters>")


def test_entities_and_dtds_are_refused():
    bomb = (
        '<?xml version="1.0"?><!DOCTYPE p [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;">]>'
        '<parameters><layer index="0"><section id="s"><zone id="z1"><job unit="">&b;</job></zone>'
        "</section></layer></parameters>"
    )
    with pytest.raises(RecipeError, match="no DTDs or entities"):
        validate_xml(bomb)
    external = '<!DOCTYPE p [<!ENTITY x SYSTEM "file:///etc/passwd">]><parameters>&x;</parameters>'
    with pytest.raises(RecipeError):
        validate_xml(external)


def test_size_limit(monkeypatch):
    monkeypatch.setattr(params_xml, "MAX_BYTES", 100)
    with pytest.raises(RecipeError, match="byte limit"):
        parse(template(toolpath(1)))
