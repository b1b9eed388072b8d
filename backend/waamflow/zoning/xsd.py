"""XML Schema (XSD 1.0) of the zone-parameter file, and validation against it with lxml.

The schema ships as `data/schemas/zone-params.xsd` (served at `GET /api/schemas/zone-params.xsd`)
for editors and other tools; `render_xsd()` generates it from `core.process.ZONE_PARAMETERS` (the
one table of names, units and bounds), and a test keeps the shipped file equal to it.

What it states: root `<parameters format?>` → `<layer index z?>`* (index an integer, unique) →
`<section id>`* (id unique in its layer) → `<zone id color?>`* (id unique in its section) → each
parameter element at most once, in any order (`xs:all`), its text empty (= not set) or a number
within the parameter's bounds, its `unit` attribute, when present, the parameter's unit.

`validate(doc)` checks a parsed lxml tree and raises `InputFileError` naming the line, the element
and the layer/section/zone it sits in.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from ..core.errors import InputFileError
from ..core.process import ZONE_PARAMETERS

XSD_PATH = Path(__file__).resolve().parents[1] / "data" / "schemas" / "zone-params.xsd"


def _num(v: float) -> str:
    return f"{v:.10g}"


def render_xsd() -> str:
    """The schema text (see module doc)."""
    units = ", ".join(f"{p.name} [{p.unit or '-'}]" for p in ZONE_PARAMETERS)
    out = [
        '<?xml version="1.0" encoding="utf-8"?>',
        '<xs:schema xmlns:xs="http://www.w3.org/2001/XMLSchema" elementFormDefault="unqualified">',
        "  <xs:annotation><xs:documentation>",
        "    waamflow zone-parameter file (format waamflow/1): deposition parameters per",
        "    layer &gt; section &gt; zone, as written by the zone node (&lt;node&gt;.params.xml).",
        f"    Empty text = not set. Units: {units}.",
        "    Generated from waamflow.core.process.ZONE_PARAMETERS by waamflow.zoning.xsd.render_xsd().",
        "  </xs:documentation></xs:annotation>",
        "",
        '  <xs:simpleType name="empty">',
        '    <xs:restriction base="xs:token"><xs:length value="0"/></xs:restriction>',
        "  </xs:simpleType>",
        '  <xs:simpleType name="optionalNumber">',
        '    <xs:union memberTypes="empty xs:double"/>',
        "  </xs:simpleType>",
    ]
    for p in ZONE_PARAMETERS:
        out += [
            "",
            f'  <xs:simpleType name="{p.name}Value">',
            f"    <xs:annotation><xs:documentation>{p.label} [{p.unit or '-'}]: {p.description}</xs:documentation></xs:annotation>",
            '    <xs:union memberTypes="empty">',
            "      <xs:simpleType>",
            '        <xs:restriction base="xs:double">',
            f'          <xs:minInclusive value="{_num(p.minimum)}"/>',
            f'          <xs:maxInclusive value="{_num(p.maximum)}"/>',
            "        </xs:restriction>",
            "      </xs:simpleType>",
            "    </xs:union>",
            "  </xs:simpleType>",
            f'  <xs:complexType name="{p.name}Type">',
            "    <xs:simpleContent>",
            f'      <xs:extension base="{p.name}Value">',
            f'        <xs:attribute name="unit" type="xs:token" fixed="{p.unit}"/>',
            "      </xs:extension>",
            "    </xs:simpleContent>",
            "  </xs:complexType>",
        ]
    out += [
        "",
        '  <xs:complexType name="zoneType">',
        "    <xs:all>",
        *[f'      <xs:element name="{p.name}" type="{p.name}Type" minOccurs="0"/>' for p in ZONE_PARAMETERS],
        "    </xs:all>",
        '    <xs:attribute name="id" use="required">',
        '      <xs:simpleType><xs:restriction base="xs:string"><xs:minLength value="1"/></xs:restriction></xs:simpleType>',
        "    </xs:attribute>",
        '    <xs:attribute name="color" type="xs:string"/>',
        '    <xs:attribute name="bead_mm3_per_mm" type="optionalNumber">',
        "      <xs:annotation><xs:documentation>Metal the layer needs per mm of path at this zone [mm3/mm] "
        "(layer height x pass step, or k*w*h for a single bead), written by waamflow with a feed comment; "
        "informational.</xs:documentation></xs:annotation>",
        "    </xs:attribute>",
        "  </xs:complexType>",
        "",
        '  <xs:complexType name="sectionType">',
        "    <xs:sequence>",
        '      <xs:element name="zone" type="zoneType" minOccurs="0" maxOccurs="unbounded"/>',
        "    </xs:sequence>",
        '    <xs:attribute name="id" use="required">',
        '      <xs:simpleType><xs:restriction base="xs:string"><xs:minLength value="1"/></xs:restriction></xs:simpleType>',
        "    </xs:attribute>",
        "  </xs:complexType>",
        "",
        '  <xs:complexType name="layerType">',
        "    <xs:sequence>",
        '      <xs:element name="section" type="sectionType" minOccurs="0" maxOccurs="unbounded">',
        '        <xs:unique name="zoneIdUnique"><xs:selector xpath="zone"/><xs:field xpath="@id"/></xs:unique>',
        "      </xs:element>",
        "    </xs:sequence>",
        '    <xs:attribute name="index" type="xs:integer" use="required"/>',
        '    <xs:attribute name="z" type="optionalNumber"/>',
        "  </xs:complexType>",
        "",
        '  <xs:element name="parameters">',
        "    <xs:complexType>",
        "      <xs:sequence>",
        '        <xs:element name="layer" type="layerType" minOccurs="0" maxOccurs="unbounded">',
        '          <xs:unique name="sectionIdUnique"><xs:selector xpath="section"/><xs:field xpath="@id"/></xs:unique>',
        "        </xs:element>",
        "      </xs:sequence>",
        '      <xs:attribute name="format" type="xs:string"/>',
        "    </xs:complexType>",
        '    <xs:unique name="layerIndexUnique"><xs:selector xpath="layer"/><xs:field xpath="@index"/></xs:unique>',
        "  </xs:element>",
        "</xs:schema>",
    ]
    return "\n".join(out) + "\n"


@lru_cache(maxsize=1)
def schema():
    """The shipped schema as an `lxml.etree.XMLSchema` (lxml imported here, on first use)."""
    from lxml import etree

    return etree.XMLSchema(etree.parse(str(XSD_PATH), etree.XMLParser(resolve_entities=False, no_network=True)))


def parse_lxml(raw: bytes):
    """A parsed lxml tree of an (already defusedxml-checked) file: no entities, no network, no
    comments or processing instructions; line numbers kept."""
    from lxml import etree

    parser = etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, remove_comments=True, remove_pis=True, huge_tree=False
    )
    return etree.fromstring(raw, parser)


def _where(el) -> tuple[int | None, str | None, str | None]:
    """(layer index, section id, zone id) of the layer/section/zone an element sits in."""
    li = sk = zid = None
    e = el
    while e is not None:
        if e.tag == "zone":
            zid = e.get("id")
        elif e.tag == "section":
            sk = e.get("id")
        elif e.tag == "layer":
            try:
                li = int(e.get("index", ""))
            except ValueError:
                li = None
        e = e.getparent()
    return li, sk, zid


def validate(root) -> None:
    """Validate a parsed tree against the schema; InputFileError on the first violation, naming
    line, element and layer/section/zone."""
    xs = schema()
    if xs.validate(root.getroottree()):
        return
    err = xs.error_log[0]
    found = root.getroottree().xpath(err.path) if err.path else []
    el = found[0] if found else None
    li, sk, zid = _where(el) if el is not None else (None, None, None)
    name = el.tag if el is not None else None
    msg = err.message.replace("{http://www.w3.org/2001/XMLSchema}", "xs:")
    where = f" (zone '{zid}')" if zid is not None else ""
    raise InputFileError(
        f"parameter file line {err.line}, element <{name}>: {msg} [schema zone-params.xsd]{where}",
        layer=li,
        section=sk,
        field=name if name not in (None, "parameters", "layer", "section", "zone") else None,
    )
