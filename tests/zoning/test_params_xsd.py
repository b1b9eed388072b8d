"""The XSD of the zone-parameter XML: shipped = generated from the parameter table, valid files
pass (shipped, generated, filled, sub-zones), broken ones fail with line + element, in parse(),
in the zone node and served by the API."""

import json
import re
import shutil
from pathlib import Path

import pytest
from lxml import etree
from test_params_xml import fill, toolpath

from waamflow.core.errors import RecipeError
from waamflow.core.process import ZONE_PARAMETERS
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.zoning import parse, template
from waamflow.zoning.params_xml import _write
from waamflow.zoning.xsd import XSD_PATH, render_xsd

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


@pytest.fixture(scope="module")
def xsd():
    return etree.XMLSchema(etree.parse(str(XSD_PATH)))


def test_shipped_xsd_is_the_generated_one_with_every_parameter_bound(xsd):
    assert XSD_PATH.read_text() == render_xsd()
    doc = etree.parse(str(XSD_PATH))
    ns = {"xs": "http://www.w3.org/2001/XMLSchema"}
    for p in ZONE_PARAMETERS:
        lo = doc.xpath(f"//xs:simpleType[@name='{p.name}Value']//xs:minInclusive/@value", namespaces=ns)
        hi = doc.xpath(f"//xs:simpleType[@name='{p.name}Value']//xs:maxInclusive/@value", namespaces=ns)
        unit = doc.xpath(f"//xs:complexType[@name='{p.name}Type']//xs:attribute/@fixed", namespaces=ns)
        assert (float(lo[0]), float(hi[0]), unit[0]) == (p.minimum, p.maximum, p.unit)


def _valid(xsd, text: str) -> bool:
    return xsd.validate(etree.fromstring(text.encode()))


def test_shipped_and_generated_files_are_valid(xsd):
    shipped = sorted(GRAPHS.glob("*.params.xml"))
    assert shipped
    for p in shipped:
        assert xsd.validate(etree.parse(str(p))), (p, xsd.error_log)
        parse(p.read_bytes())
    tpl = template(toolpath(3))
    assert _valid(xsd, tpl)
    filled = fill(fill(tpl, 1, "bs1/B", "z1", "current", 205.5), 2, "bs1/A", "end", "dwell", 0.5)
    assert _valid(xsd, filled) and parse(filled).values[(1, "bs1/B", "z1")] == {"current": 205.5}
    # compensate-deposit's feed sub-zones and a layer without z
    sub = _write([(0, None, "bs1/A", "z1@87", "#ff0000")], {(0, "bs1/A", "z1@87"): {"wire_feed_speed": 9.5}})
    assert _valid(xsd, sub) and parse(sub).values == {(0, "bs1/A", "z1@87"): {"wire_feed_speed": 9.5}}


def _line_of(text: str, needle: str) -> int:
    return text[: text.index(needle)].count("\n") + 1


@pytest.mark.parametrize(
    "edit, element, words",
    [
        # caught by our own checks (messages name the parameter and its bounds), now with line numbers
        (lambda t: fill(t, 1, "bs1/B", "z1", "current", "5000"), "current", "outside"),
        (lambda t: fill(t, 1, "bs1/B", "z1", "travel_speed", "fast"), "travel_speed", "not a number"),
        # caught only by the schema
        (lambda t: t.replace('<zone id="z1" color=', '<zone id="z1" colour="#123456" color=', 1), "zone", "colour"),
        (
            lambda t: t.replace('<current unit="A"></current>', '<current unit="A"><b>1</b></current>', 1),
            "current",
            "current",
        ),
        (lambda t: t.replace('<layer index="1"', '<layer index="1" thickness="2"', 1), "layer", "thickness"),
    ],
)
def test_broken_files_name_line_and_element(xsd, edit, element, words):
    bad = edit(template(toolpath(2)))
    assert not _valid(xsd, bad)
    with pytest.raises(RecipeError) as e:
        parse(bad)
    msg = e.value.message
    m = re.search(r"line (\d+), element <(\w+)>", msg)
    assert m and m.group(2) == element and words in msg, msg
    line = int(m.group(1))
    assert f"<{element}" in bad.splitlines()[line - 1]
    assert e.value.exit_code == 2


def test_schema_violation_names_layer_section_zone():
    bad = template(toolpath(2)).replace('<zone id="z1" color=', '<zone id="z1" colour="x" color=', 1)
    with pytest.raises(RecipeError) as e:
        parse(bad)
    assert (e.value.layer, e.value.section) == (0, "bs1/A") and "zone 'z1'" in e.value.message
    assert _line_of(bad, 'colour="x"') == int(re.search(r"line (\d+)", e.value.message).group(1))


def test_zone_node_refuses_a_broken_file_with_line_and_element(tmp_path):
    shutil.copytree(GRAPHS / "parts", tmp_path / "parts")
    recipe = json.loads((GRAPHS / "mpp-cross.json").read_text())
    xml = (GRAPHS / "mpp-cross.params.xml").read_text()
    bad = xml.replace('<zone id="z1" color="#2ca02c">', '<zone id="z1" color="#2ca02c" job="3">', 1)
    (tmp_path / "mpp-cross.params.xml").write_text(bad)
    with pytest.raises(RecipeError) as e:
        execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    err = e.value
    assert err.node == "zone" and err.layer == 0 and err.section == "bs1/A"
    line = _line_of(bad, 'job="3"')
    assert f"line {line}, element <zone>" in err.message and "job" in err.message


def test_api_serves_the_xsd():
    from fastapi.testclient import TestClient

    from waamflow.api.app import create_app

    r = TestClient(create_app()).get("/api/schemas/zone-params.xsd")
    assert r.status_code == 200 and r.headers["content-type"].startswith("application/xml")
    assert r.content == XSD_PATH.read_bytes()
