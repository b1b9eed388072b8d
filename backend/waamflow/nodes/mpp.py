"""Modular path planning nodes (Michel et al. 2019): mask → guide → [strategy] → zone → sequence
(sequence.py).

Thin adapters over waamflow.sections and waamflow.zoning. mask, guide and zone map over layers;
`layer_params` returns only what affects one layer (its governing mask, the guides/zone specs of
the sections it has), so editing mask bs2 never recomputes a layer governed by bs1.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from typing import Annotated, Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from ..core import serialize
from ..core.errors import PlanningError, RecipeError, layer_ranges
from ..core.model import LayerPaths, LayerSections, Layered
from ..engine.node import FileRef, LayerNode, NodeParams, register, unit
from ..engine.ports import Port
from ..sections import Mask, apply_guide, segment_layer
from ..sections.guide import guide_line
from ..sections.mask import governing_mask, uncovered_percent
from ..zoning import ZoneSpec, apply_zone_params, merge, parse, template, zone_path
from ..zoning.params_xml import orphan_label

Point2 = tuple[float, float]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


# ------------------------------------------------------------------------------------------------
# mask
# ------------------------------------------------------------------------------------------------
class MaskSectionParams(_Strict):
    id: str = Field(min_length=1, max_length=64, description="Section id, unique in the mask", title="Section id")
    curve: list[Point2] = Field(
        min_length=3,
        description="Closed planar curve over the layer (layer-local x, y)",
        json_schema_extra=unit("mm"),
        title="Section curve",
    )


class MaskParams(_Strict):
    id: str = Field(
        min_length=1, max_length=64, pattern=r"^[^/]+$", description="Mask id (Building Strategy)", title="Mask id"
    )
    from_layer: int = Field(
        0, ge=0, description="First layer this mask governs (until the next mask's from_layer)", title="From layer"
    )
    sections: list[MaskSectionParams] = Field(
        min_length=1, description="Sections in default deposition order", title="Sections"
    )

    @model_validator(mode="after")
    def _curves(self) -> "MaskParams":
        # bad curves and duplicate ids fail the recipe up front (exit 2), not at the first layer
        try:
            Mask.from_json(self.model_dump(mode="json"))
        except RecipeError as e:
            raise ValueError(f"section {e.section}: {e.message}") from None
        return self


@register
class MaskNode(LayerNode):
    """MPP segmentation: cut each layer into sections, section = layer ∩ closed curve of its mask.

    A mask governs layers from its `from_layer` up to the next mask's. Where a curve yields no
    region or several, the run fails naming the layer and section: start a new mask there. An
    earlier section owns any overlap with a later one. No masks: each connected region of a layer
    is one section (`region<k>`, largest first). Warns with the % of layer area left uncovered.
    """

    type = "mask"
    version = "2"  # 2: a layer of curves only (an open surface, a sketch) stops the run
    combine_keeps_items = True  # combine only warns
    title = "Mask (segmentation)"
    category = "mpp"
    inputs = (Port("layers", "layers", "Sliced layers"),)
    outputs = (Port("sections", "sections", "Sections per layer"),)
    over = "layers"

    class Params(NodeParams):
        masks: list[MaskParams] = Field(default_factory=list, description="Building-Strategy masks", title="Masks")

        @field_validator("masks")
        @classmethod
        def _unique(cls, masks: list[MaskParams]) -> list[MaskParams]:
            ids = [m.id for m in masks]
            starts = [m.from_layer for m in masks]
            if len(set(ids)) != len(ids):
                raise ValueError("mask ids must be unique")
            if len(set(starts)) != len(starts):
                raise ValueError("two masks start at the same from_layer")
            return masks

    def _governing(self, params, index: int) -> MaskParams | None:
        return governing_mask(params.masks, index)

    def layer_params(self, params, index, items):
        m = self._governing(params, index)
        return None if m is None else m.model_dump(mode="json")

    def run_layer(self, ctx, params, index, items):
        layer = items["layers"]
        if layer.region.is_empty and layer.curves:
            raise PlanningError(_no_area(len(layer.curves)))
        m = self._governing(params, index)
        mask = None if m is None else Mask.from_json(m.model_dump(mode="json"))
        ls = segment_layer(layer, mask)
        pct = uncovered_percent(ls)
        if ls.uncovered_area > 0:
            ctx.warn(
                f"{pct:.1f} % of the layer area ({ls.uncovered_area:.1f} mm²) is not covered by any section",
                layer=index,
            )
        return {"sections": ls}

    def combine(self, ctx, params, outputs, inputs):
        n = len(outputs["sections"])
        for m in params.masks:
            if m.from_layer >= n:
                ctx.warn(f"mask {m.id!r} starts at layer {m.from_layer} but the part has {n} layers: it governs none")
        return super().combine(ctx, params, outputs, inputs)


def _no_area(curves: int) -> str:
    """A layer of curves only reached the mask (an open mesh read as a surface, a sketch): the mask
    and the strategy fill areas, and had planned nothing without a word; the run then stopped at
    the post's preflight ("program post has no arc-ON motion"), which named neither the cause nor
    a layer (stanford-bunny.obj, teapot.obj, lego.ply and 5 more open meshes)."""
    return (
        f"the layer has no area to segment, only {curves} curve(s): the part reached the slice as an open "
        "surface or a sketch (see the mesh node's warning), and mask → strategy fill areas. Close the mesh "
        "(a watertight, consistently wound solid: the mesh node's 'as': 'solid' names what is open) or plan "
        "single-bead walls with features → wall-path"
    )


# ------------------------------------------------------------------------------------------------
# guide
# ------------------------------------------------------------------------------------------------
@register
class GuideNode(LayerNode):
    """MPP guides: per section an open polyline giving the deposition direction.

    A guide must cross its section's boundary exactly twice on every layer (else the run fails
    naming layer and section); the crossings are where deposition starts and stops. Sections without
    a guide get the long axis of their minimum rotated rectangle.
    """

    type = "guide"
    combine_keeps_items = True  # combine only warns
    title = "Guide"
    category = "mpp"
    inputs = (Port("sections", "sections", "Sections per layer"),)
    outputs = (Port("sections", "sections", "Sections with guides, start and stop"),)
    over = "sections"

    class Params(NodeParams):
        guides: dict[str, Annotated[list[Point2], Field(min_length=2)]] = Field(
            default_factory=dict,
            description='Section key ("bs1/A") → guide polyline (layer-local x, y)',
            json_schema_extra=unit("mm"),
            title="Guides by section",
        )

    def layer_params(self, params, index, items):
        ls: LayerSections = items["sections"]
        return {s.key: params.guides.get(s.key) for s in ls.sections}

    def run_layer(self, ctx, params, index, items):
        ls: LayerSections = items["sections"]
        out = []
        for s in ls.sections:
            pts = params.guides.get(s.key)
            line = None if pts is None else guide_line(pts, s.key)
            out.append(apply_guide(s, line, layer=index))
        return {"sections": LayerSections(ls.layer, tuple(out), ls.uncovered_area)}

    def combine(self, ctx, params, outputs, inputs):
        seen = {s.key for ls in outputs["sections"] if ls is not None for s in ls.sections}
        full = all(ls is not None for ls in outputs["sections"])
        for key in params.guides:
            if full and key not in seen:
                ctx.warn(f"guide for {key!r} matches no section", section=key)
        return super().combine(ctx, params, outputs, inputs)


# ------------------------------------------------------------------------------------------------
# zone
# ------------------------------------------------------------------------------------------------
class ZoneSpecParams(_Strict):
    start_length: float = Field(
        0.0,
        ge=0,
        le=1e5,
        description="Length of the ignition zone `start`, measured along the path from its start",
        json_schema_extra=unit("mm"),
        title="Start zone length",
    )
    end_length: float = Field(
        0.0,
        ge=0,
        le=1e5,
        description="Length of the termination zone `end`, measured back from the path's end",
        json_schema_extra=unit("mm"),
        title="End zone length",
    )
    split_points: list[Point2] = Field(
        default_factory=list,
        description="Points (layer-local x, y) projected onto the path; each starts a new middle zone",
        json_schema_extra=unit("mm"),
        title="Split points",
    )

    def spec(self) -> ZoneSpec:
        return ZoneSpec(self.start_length, self.end_length, tuple((p[0], p[1]) for p in self.split_points))


_PARAM_CACHE: "OrderedDict[str, Any]" = OrderedDict()
_PARAM_LOCK = threading.Lock()


def _parse_cached(text: str):
    """parse() memoised on content (last 8 files): the zone node's combine runs on every execution."""
    h = hashlib.sha256(text.encode("utf-8")).hexdigest()
    with _PARAM_LOCK:
        hit = _PARAM_CACHE.get(h)
        if hit is not None:
            _PARAM_CACHE.move_to_end(h)
            return hit
    table = parse(text)
    with _PARAM_LOCK:
        _PARAM_CACHE[h] = table
        while len(_PARAM_CACHE) > 8:
            _PARAM_CACHE.popitem(last=False)
    return table


@register
class ZoneNode(LayerNode):
    """MPP zoning: split each section path into zones with their own deposition parameters.

    Zones along a path: `start` (first `start_length` mm), `z1`, `z2`, … (split at the
    `split_points` projected onto the path), `end` (last `end_length` mm); only those that exist.
    Length zones keep their length on every layer, point zones stay at their points, zones between
    stretch. Deposition parameters come from the XML file `parameters` (layer > section > zone):
    a zone's travel_speed becomes the speed of its arc-ON segments; empty values leave the
    strategy's. Writes `toolpath.json` and `params.xml` (the template for the current paths with
    every value of the existing file whose layer/section/zone still exists).
    """

    type = "zone"
    title = "Zone"
    category = "mpp"
    inputs = (Port("toolpath", "toolpath", "Section paths (from strategy)"),)
    outputs = (Port("toolpath", "toolpath", "Zoned section paths with process parameters"),)
    over = "toolpath"

    class Params(NodeParams):
        default: ZoneSpecParams = Field(
            default_factory=ZoneSpecParams, description="Zoning of every section", title="Default zoning"
        )
        sections: dict[str, ZoneSpecParams] = Field(
            default_factory=dict, description="Section key → zoning (replaces the default)", title="Zoning by section"
        )
        parameters: FileRef = Field(
            "",
            description="XML deposition-parameter file (layer > section > zone); empty: none",
            title="Parameter XML file",
        )

    def _spec(self, params, key: str) -> ZoneSpecParams:
        return params.sections.get(key, params.default)

    def layer_params(self, params, index, items):
        lp: LayerPaths = items["toolpath"]
        return {sp.key: self._spec(params, sp.key).model_dump(mode="json") for sp in lp.sections}

    def run_layer(self, ctx, params, index, items):
        lp: LayerPaths = items["toolpath"]
        out = []
        for sp in lp.sections:
            spec = self._spec(params, sp.key).spec()
            world = (
                lp.layer.to_world(np.asarray(spec.split_points, float).reshape(-1, 2)) if spec.split_points else None
            )
            out.append(zone_path(sp, spec, world))
        return {"toolpath": LayerPaths(lp.layer, tuple(out), lp.dwell_after_s)}

    def keeps_items(self, params) -> bool:
        return not params.parameters  # a parameter file's values are applied in combine

    def _read_xml(self, ctx, params, warn: bool = True) -> str | None:
        if not params.parameters:
            return None
        if not ctx.exists(params.parameters):
            if warn:
                ctx.warn(f"parameter file {params.parameters!r} not found: writing an empty template")
            return None
        return ctx.read_text(params.parameters)

    def combine(self, ctx, params, outputs, inputs):
        items = outputs["toolpath"]
        text = self._read_xml(ctx, params)
        table = None if text is None else _parse_cached(text)
        layers = []
        for lp in items:
            if lp is None or table is None:
                layers.append(lp)
                continue
            vals = table.layer(lp.index)
            layers.append(
                LayerPaths(
                    lp.layer, tuple(apply_zone_params(sp, vals.get(sp.key, {})) for sp in lp.sections), lp.dwell_after_s
                )
            )
        toolpath = Layered(tuple(layers))
        full = all(lp is not None for lp in layers)
        if full:
            seen = {sp.key for lp in layers for sp in lp.sections}
            for key in params.sections:
                if key not in seen:
                    ctx.warn(f"zoning for {key!r} matches no section", section=key)
        if table is not None and full and table.values:
            # a layer the file sets nothing for welds on what the machine holds from the layer before
            bare = [lp.index for lp in layers if lp.sections and not table.layer(lp.index)]
            if bare:
                ctx.warn(
                    f"parameter file {params.parameters!r} has no values for layers {layer_ranges(bare)} (of "
                    f"{len(layers)}): their zones set no current or wire feed and weld at the strategy's speed, on "
                    "whatever the machine holds from the layer before; fill them in (the zone node's params.xml "
                    "lists every layer's zones)",
                    layer=bare[0],
                )
        if table is not None and full:
            present = {(lp.index, sp.key, z) for lp in layers for sp in lp.sections for z in sp.zone_colors}
            for key in table.values:
                if key not in present:
                    ctx.warn(
                        f"parameter file: values for {orphan_label(key)} have no zone any more "
                        "(dropped from params.xml)",
                        layer=key[0],
                        section=key[1],
                    )
        return {"toolpath": toolpath}

    def artifacts(self, ctx, params, outputs):
        tp = outputs["toolpath"]
        xml, _ = merge(template(tp), self._read_xml(ctx, params, warn=False))
        return {"toolpath.json": serialize.dumps(serialize.toolpath_json(tp)), "params.xml": xml}


__all__ = ["GuideNode", "MaskNode", "ZoneNode"]
