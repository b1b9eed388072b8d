"""The MPP deposition-parameter XML file (Michel et al. 2019, "Deposition parameters: the XML file").

Parameters are kept out of path design: alongside the path we write an XML file mirroring the path
architecture, which the user (or later an algorithm) fills in::

    <parameters format="waamflow/1">
      <layer index="0" z="1.5">
        <section id="bs1/A">
          <zone id="start" color="#d62728">
            <current unit="A">200</current>
            <voltage unit="V"></voltage>
            <wire_feed_speed unit="m/min">10</wire_feed_speed>
            <travel_speed unit="mm/s">6</travel_speed>
            <dwell unit="s"></dwell>
            <job unit=""></job>
          </zone> ...

One element per `core.process.ZONE_PARAMETERS` entry, in that order, with its unit; empty text
means "not set" (the strategy's speed stays). Reading is safe (defusedxml: no DTD, no entities,
size limit) and validated against the names, units and bounds in core/process.py, then against
the XML Schema `data/schemas/zone-params.xsd` (lxml, `zoning/xsd.py`); every error is a
RecipeError naming the line, the element and layer/section/zone.

Feed (issue #22 item 5, mass balance). Each zone may carry `bead_mm3_per_mm`: the metal its layer
needs per mm of path (layer height × the section's pass step, or k·w·h for a single bead; see
process/mass.py), written by waamflow from the path and a bead width. With it, the writer adds a
comment in the zone comparing the wire it is fed, η·WFS·(π d²/4)/TS, with that bead:
`<!-- feed: wire 9.40 mm³/mm vs bead 9.00 mm³/mm = 1.04 -->` (> 1 over-feed, < 1 under-feed).
The attribute is informational: it is rewritten on every run and never read as a parameter.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from functools import cached_property
from typing import Iterable

import defusedxml.ElementTree as DET
import numpy as np
from defusedxml import DefusedXmlException

from ..core.errors import InputFileError, RecipeError
from ..core.model import LayerPaths, Layered
from ..core.process import PARAMETERS_BY_NAME, ZONE_PARAMETERS
from . import xsd

#: Bead width (mm) the zone node's feed comments assume: the MPP study's 6 mm bead (the zone node
#: has no bead width of its own; fill-parameters uses the bead model's).
FEED_BEAD_WIDTH_MM = 6.0
MAX_BYTES = 32 * 1024 * 1024  # ~8 bytes per empty element: room for 10⁴ layers × 10 sections × 5 zones
FORMAT = "waamflow/1"

ZoneKey = tuple[int, str, str]  # (layer index, section key, zone id)


@dataclass(frozen=True)
class ParamTable:
    """Parsed parameter file.

    values: (layer index, section key, zone id) → {parameter name: value} (only filled values).
    zones: every (layer, section, zone) present in the file, in file order (filled or not).
    colors: zone key → colour attribute as written. layer_z: layer index → z attribute (mm) if any.
    """

    values: dict[ZoneKey, dict[str, float]] = field(default_factory=dict)
    zones: tuple[ZoneKey, ...] = ()
    colors: dict[ZoneKey, str] = field(default_factory=dict)
    layer_z: dict[int, float] = field(default_factory=dict)
    beads: dict[ZoneKey, float] = field(default_factory=dict)  # zone → bead_mm3_per_mm attribute

    @cached_property
    def _by_layer(self) -> dict[int, dict[str, dict[str, dict[str, float]]]]:
        out: dict[int, dict[str, dict[str, dict[str, float]]]] = {}
        for (li, sk, zid), v in self.values.items():
            out.setdefault(li, {}).setdefault(sk, {})[zid] = v
        return out

    def layer(self, index: int) -> dict[str, dict[str, dict[str, float]]]:
        """Values of one layer: section key → zone id → {name: value} (copies)."""
        return {sk: {z: dict(v) for z, v in zones.items()} for sk, zones in self._by_layer.get(index, {}).items()}


def _fmt(v: float) -> str:
    return f"{v:.10g}"


FEED_NOTE = (
    " feed: per zone, the wire that ends in the part per mm of path, eta*WFS*(pi d^2/4)/TS (eta 0.95, "
    "d 1.2 mm), against bead_mm3_per_mm, the metal the layer needs per mm of path (layer height x "
    "pass step, or k*w*h for a single bead); ratio > 1 over-feeds, < 1 under-feeds "
)


def _feed_comment(vals: dict[str, float], bead: float) -> str:
    from ..process.mass import wire_per_mm  # lazy: process imports this module

    wfs, ts = vals.get("wire_feed_speed"), vals.get("travel_speed")
    if not wfs or not ts:
        return f" feed: bead {bead:.2f} mm³/mm (set wire_feed_speed and travel_speed to compare) "
    wire = wire_per_mm(wfs, ts)
    return f" feed: wire {wire:.2f} mm³/mm vs bead {bead:.2f} mm³/mm = {wire / bead:.2f} "


def _write(
    zones: Iterable[tuple[int, float | None, str, str, str]],
    values: dict[ZoneKey, dict[str, float]],
    beads: dict[ZoneKey, float] | None = None,
) -> str:
    """zones: (layer index, layer z, section key, zone id, colour) in file order; beads: zone →
    metal needed per mm of path (mm³/mm), written as the zone's `bead_mm3_per_mm` with a feed
    comment. Written line by line (a part has ~10⁵ elements), exactly as ElementTree with
    `ET.indent(space="  ")` and `short_empty_elements=False` writes the same tree (`tests/zoning`
    compares the two)."""
    beads = beads or {}
    comment = (
        " Deposition parameters per layer > section > zone (MPP). Empty = not set. "
        "Units: " + ", ".join(f"{p.name} [{p.unit or '-'}]" for p in ZONE_PARAMETERS) + " "
    )
    params = [(p.name, f'        <{p.name} unit="{_attr(p.unit)}">', f"</{p.name}>") for p in ZONE_PARAMETERS]
    tree: dict[int, tuple[float | None, dict[str, list[tuple[str, str]]]]] = {}  # layer → (z, section → zones)
    for li, z, sk, zid, color in zones:  # grouped as ElementTree would append them
        tree.setdefault(li, (z, {}))[1].setdefault(sk, []).append((zid, color))
    out = ['<?xml version="1.0" encoding="utf-8"?>', f'<parameters format="{_attr(FORMAT)}">', f"  <!--{comment}-->"]
    if beads:
        out.append(f"  <!--{FEED_NOTE}-->")
    for li, (z, sections) in tree.items():
        zattr = "" if z is None else f' z="{_attr(_fmt(round(z, 6)))}"'
        out.append(f'  <layer index="{li}"{zattr}>')
        for sk, zs in sections.items():
            out.append(f'    <section id="{_attr(sk)}">')
            for zid, color in zs:
                vals = values.get((li, sk, zid), {})
                bead = beads.get((li, sk, zid))
                if bead is None:
                    out.append(f'      <zone id="{_attr(zid)}" color="{_attr(color)}">')
                else:
                    out.append(
                        f'      <zone id="{_attr(zid)}" color="{_attr(color)}" '
                        f'bead_mm3_per_mm="{_fmt(round(bead, 4))}">'
                    )
                    out.append(f"        <!--{_feed_comment(vals, bead)}-->")
                for name, head, tail in params:
                    out.append(head + (_cdata(_fmt(vals[name])) if name in vals else "") + tail)
                out.append("      </zone>")
            out.append("    </section>")
        out.append("  </layer>")
    out.append("</parameters>")
    return "\n".join(out) + "\n"


def _attr(text: str) -> str:
    """An attribute value escaped as ElementTree escapes it."""
    for a, b in (
        ("&", "&amp;"),
        ("<", "&lt;"),
        (">", "&gt;"),
        ('"', "&quot;"),
        ("\r", "&#13;"),
        ("\n", "&#10;"),
        ("\t", "&#09;"),
    ):
        if a in text:
            text = text.replace(a, b)
    return text


def _cdata(text: str) -> str:
    for a, b in (("&", "&amp;"), ("<", "&lt;"), (">", "&gt;")):
        if a in text:
            text = text.replace(a, b)
    return text


def _write_etree(
    zones: Iterable[tuple[int, float | None, str, str, str]],
    values: dict[ZoneKey, dict[str, float]],
    beads: dict[ZoneKey, float] | None = None,
) -> str:
    """The same file through ElementTree (reference for the tests of `_write`)."""
    beads = beads or {}
    root = ET.Element("parameters", {"format": FORMAT})
    root.append(
        ET.Comment(
            " Deposition parameters per layer > section > zone (MPP). Empty = not set. "
            "Units: " + ", ".join(f"{p.name} [{p.unit or '-'}]" for p in ZONE_PARAMETERS) + " "
        )
    )
    if beads:
        root.append(ET.Comment(FEED_NOTE))
    layer_el: dict[int, ET.Element] = {}
    section_el: dict[tuple[int, str], ET.Element] = {}
    for li, z, sk, zid, color in zones:
        if li not in layer_el:
            attrs = {"index": str(li)}
            if z is not None:
                attrs["z"] = _fmt(round(z, 6))
            layer_el[li] = ET.SubElement(root, "layer", attrs)
        if (li, sk) not in section_el:
            section_el[(li, sk)] = ET.SubElement(layer_el[li], "section", {"id": sk})
        vals = values.get((li, sk, zid), {})
        bead = beads.get((li, sk, zid))
        zattrs = {"id": zid, "color": color}
        if bead is not None:
            zattrs["bead_mm3_per_mm"] = _fmt(round(bead, 4))
        zel = ET.SubElement(section_el[(li, sk)], "zone", zattrs)
        if bead is not None:
            zel.append(ET.Comment(_feed_comment(vals, bead)))
        for p in ZONE_PARAMETERS:
            e = ET.SubElement(zel, p.name, {"unit": p.unit})
            if p.name in vals:
                e.text = _fmt(vals[p.name])
    ET.indent(root, space="  ")
    return (
        '<?xml version="1.0" encoding="utf-8"?>\n'
        + ET.tostring(root, encoding="unicode", short_empty_elements=False)
        + "\n"
    )


def _toolpath_zones(toolpath: Layered[LayerPaths] | Iterable[LayerPaths]):
    items = toolpath.items if isinstance(toolpath, Layered) else toolpath
    for lp in items:
        if lp is None:
            continue
        for sp in lp.sections:
            seen: list[str] = []
            for z in sp.zone:
                if z and z not in seen:
                    seen.append(z)
            for z in seen:
                yield lp.index, float(lp.layer.z), sp.key, z, sp.zone_colors.get(z, "")


def toolpath_beads(
    toolpath: Layered[LayerPaths] | Iterable[LayerPaths],
    width_mm: float = FEED_BEAD_WIDTH_MM,
    step_mm: float | None = None,
) -> dict[ZoneKey, float]:
    """Zone → metal its layer needs per mm of path (mm³/mm), from each section path's own pass
    step (or k·w·h for a single bead) and the layer height (process/mass.py)."""
    from ..process.mass import section_deposit_per_mm  # lazy: process imports this module

    items = toolpath.items if isinstance(toolpath, Layered) else toolpath
    out: dict[ZoneKey, float] = {}
    for lp in items:
        if lp is None:
            continue
        for sp in lp.sections:
            if not sp.zone or not np.any(sp.arc):
                continue
            bead, _ = section_deposit_per_mm(sp, lp.layer, width_mm, step_mm)
            for z in dict.fromkeys(sp.zone):
                if z:
                    out[(lp.index, sp.key, z)] = bead
    return out


def template(toolpath: Layered[LayerPaths] | Iterable[LayerPaths], feed: bool = True) -> str:
    """An empty parameter file mirroring a zoned toolpath: layer > section > zone (path order);
    with `feed`, each zone's bead_mm3_per_mm for a FEED_BEAD_WIDTH_MM bead."""
    items = list(toolpath.items if isinstance(toolpath, Layered) else toolpath)
    return _write(_toolpath_zones(items), {}, toolpath_beads(items) if feed else None)


def _error(
    msg: str, li: int | None = None, sk: str | None = None, zid: str | None = None, name: str | None = None
) -> RecipeError:
    where = f" (zone '{zid}')" if zid is not None else ""
    return InputFileError(f"parameter file: {msg}{where}", layer=li, section=sk, field=name)


def _number(text: str, name: str, li: int, sk: str, zid: str) -> float:
    p = PARAMETERS_BY_NAME[name]
    try:
        v = float(text)
    except ValueError:
        raise _error(f"{name} = {text!r} is not a number", li, sk, zid, name) from None
    if not math.isfinite(v) or not (p.minimum <= v <= p.maximum):
        raise _error(
            f"{name} = {text} {p.unit} is outside [{_fmt(p.minimum)}, {_fmt(p.maximum)}] {p.unit}", li, sk, zid, name
        )
    return v


def parse(text: str | bytes) -> ParamTable:
    """Parse and validate a parameter file. Raises RecipeError (InputFileError) naming layer/section/zone."""
    raw = text.encode("utf-8") if isinstance(text, str) else text
    if len(raw) > MAX_BYTES:
        raise _error(f"{len(raw)} bytes is over the {MAX_BYTES} byte limit")
    try:
        DET.fromstring(raw, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except DefusedXmlException as e:
        raise _error(f"forbidden XML construct ({type(e).__name__}): no DTDs or entities allowed") from None
    except ET.ParseError as e:
        raise _error(f"not well-formed XML ({e})") from None
    try:
        root = xsd.parse_lxml(raw)  # the same document again, with line numbers (no DTD/entities: checked)
    except SyntaxError as e:  # lxml's limits: nesting over 256 levels, a text or attribute over 10 MB
        why = str(e.msg).split(", use XML_PARSE_HUGE")[0].split(", try XML_PARSE_HUGE")[0]
        raise _error(
            f"XML refused at line {e.lineno}: {why} (at most 256 levels of nesting and 10 MB per text or attribute)"
        ) from None
    if root.tag != "parameters":
        raise _error(f"root element is <{root.tag}>, expected <parameters>")
    cur: list = [root]
    try:
        table = _walk(root, cur)
    except InputFileError as e:
        el = cur[0]
        e.message = e.message.replace("parameter file:", f"parameter file line {el.sourceline}, element <{el.tag}>:", 1)
        raise
    xsd.validate(root)  # what the walk does not check (attributes, text in odd places, ...)
    return table


def _walk(root, cur: list) -> ParamTable:
    """The checks with our own messages; `cur[0]` is the element being read (for the line number)."""
    values: dict[ZoneKey, dict[str, float]] = {}
    zones: list[ZoneKey] = []
    colors: dict[ZoneKey, str] = {}
    layer_z: dict[int, float] = {}
    beads: dict[ZoneKey, float] = {}
    seen_layers: set[int] = set()
    for lel in root:
        cur[0] = lel
        if not isinstance(lel.tag, str):
            continue
        if lel.tag != "layer":
            raise _error(f"unexpected <{lel.tag}> in <parameters>")
        try:
            li = int(lel.get("index", ""))
        except ValueError:
            raise _error(f"<layer> index {lel.get('index')!r} is not an integer") from None
        if li in seen_layers:
            raise _error("layer listed twice", li)
        seen_layers.add(li)
        if lel.get("z") not in (None, ""):
            try:
                layer_z[li] = float(lel.get("z"))
            except ValueError:
                raise _error(f"z {lel.get('z')!r} is not a number", li) from None
        seen_sections: set[str] = set()
        for sel in lel:
            cur[0] = sel
            if not isinstance(sel.tag, str):
                continue
            if sel.tag != "section" or not sel.get("id"):
                raise _error(f"expected <section id=...> in <layer>, got <{sel.tag}>", li)
            sk = sel.get("id")
            if sk in seen_sections:
                raise _error("section listed twice", li, sk)
            seen_sections.add(sk)
            seen_zones: set[str] = set()
            for zel in sel:
                cur[0] = zel
                if not isinstance(zel.tag, str):  # comments, processing instructions
                    continue
                if zel.tag != "zone" or not zel.get("id"):
                    raise _error(f"expected <zone id=...> in <section>, got <{zel.tag}>", li, sk)
                zid = zel.get("id")
                if zid in seen_zones:
                    raise _error("zone listed twice", li, sk, zid)
                seen_zones.add(zid)
                key = (li, sk, zid)
                zones.append(key)
                colors[key] = zel.get("color", "")
                if zel.get("bead_mm3_per_mm") not in (None, ""):
                    try:
                        beads[key] = float(zel.get("bead_mm3_per_mm"))
                    except ValueError:
                        raise _error(
                            f"bead_mm3_per_mm {zel.get('bead_mm3_per_mm')!r} is not a number", li, sk, zid
                        ) from None
                vals: dict[str, float] = {}
                for pel in zel:
                    cur[0] = pel
                    if not isinstance(pel.tag, str):  # comments (the feed note), processing instructions
                        continue
                    name = pel.tag
                    if name not in PARAMETERS_BY_NAME:
                        known = ", ".join(PARAMETERS_BY_NAME)
                        raise _error(f"unknown parameter <{name}> (known: {known})", li, sk, zid, name)
                    if name in vals:
                        raise _error(f"{name} given twice", li, sk, zid, name)
                    unit_attr = pel.get("unit")
                    expected = PARAMETERS_BY_NAME[name].unit
                    if unit_attr is not None and unit_attr.strip() != expected:
                        raise _error(f"{name} unit is {unit_attr!r}, expected {expected!r}", li, sk, zid, name)
                    t = (pel.text or "").strip()
                    if t:
                        vals[name] = _number(t, name, li, sk, zid)
                if vals:
                    values[key] = vals
    return ParamTable(values=values, zones=tuple(zones), colors=colors, layer_z=layer_z, beads=beads)


def validate_xml(text: str | bytes) -> None:
    """Raise RecipeError if `text` is not a valid parameter file."""
    parse(text)


def orphan_label(key: ZoneKey) -> str:
    li, sk, zid = key
    return f"layer {li}, section '{sk}', zone '{zid}'"


def merge(template_text: str, old_text: str | bytes | None) -> tuple[str, list[str]]:
    """Fill a fresh template with every value of `old_text` whose layer/section/zone still exists.

    Returns (merged XML text, orphans): one label per zone of the old file that had values but no
    longer exists ("layer 3, section 'bs1/A', zone 'z2'"), in the old file's order. Raises
    RecipeError if either file is invalid.
    """
    if old_text is None or (isinstance(old_text, (str, bytes)) and not old_text.strip()):
        return template_text, []  # nothing to fill in: the template as written (no need to parse it)
    tpl = parse(template_text)
    old = parse(old_text)
    present = set(tpl.zones)
    kept = {k: v for k, v in old.values.items() if k in present}
    orphans = [orphan_label(k) for k in old.zones if k in old.values and k not in present]
    rows = [(li, tpl.layer_z.get(li), sk, zid, tpl.colors.get((li, sk, zid), "")) for (li, sk, zid) in tpl.zones]
    return _write(rows, kept, tpl.beads), orphans
