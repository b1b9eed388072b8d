"""Modular path planning nodes (Michel et al. 2019): mask → guide → [strategy] → zone → sequence.

Thin adapters over waamflow.sections, waamflow.zoning and waamflow.sequencing. mask, guide and zone
map over layers; `layer_params` returns only what affects one layer (its governing mask, the
guides/zone specs of the sections it has), so editing mask bs2 never recomputes a layer governed by
bs1. sequence chains layers (each starts where the previous ended) and runs on the whole part.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from ..core import serialize
from ..core.errors import PlanningError, RecipeError, layer_ranges
from ..core.model import LayerPaths, LayerSections, Layered
from ..engine.node import FileRef, LayerNode, Node, NodeParams, register, unit
from ..engine.ports import Port
from ..sections import Mask, apply_guide, segment_layer
from ..sections.guide import guide_line
from ..sections.mask import governing_mask, uncovered_percent
from ..sequencing import sequence_part
from ..sequencing.layer_path import chunk_seconds, part_travel, sequence_ahead
from ..sequencing.seams import DEFAULT_CLEARANCE, SeamSpec, ignition_points, nearest_distances
from ..sequencing.tour import submitted_seconds
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


# ------------------------------------------------------------------------------------------------
# sequence
# ------------------------------------------------------------------------------------------------
@register
class SequenceNode(Node):
    """MPP layer path: join a layer's section paths into one program with arc-OFF travel between them.

    Order: `mask` (the mask's section order), `nearest` (shortest travel from the previous layer's
    end, keeping the MPP order rule: `precedence` keys, then oscillated sections, then the parallel
    ones they feed; exact up to 6 sections, else nearest neighbour + 2-opt/Or-opt) or an explicit
    list of section keys (a mask/explicit order that breaks the rule is warned). `seam`: where each
    section ignites — `auto` (the entry farthest from the layer below's ignitions; loops move on by
    `seam_shift`), `alternate` (odd layers reversed), `stagger`, `scattered`, `aligned` (as
    planned) or an [x, y] point; a path may be reversed, a serpentine of passes re-threaded from its
    other end, a loop rotated; never at a junction with another section (within `bead_width`) unless
    `seam_at_junctions`; machining stock (segments outside the section) first. Arc-ON runs shorter
    than `min_arc_run_mm` are bridged across an inside gap or dropped, warned and counted in the
    report. Travel: retract by `retract_height` along the build direction, travel, plunge.
    `alternate` also reverses the section order on odd layers. `dwell` adds an interlayer dwell.
    Writes `toolpath.json` and `travel.json` (travel length per layer).
    """

    # Not a LayerNode on purpose: layer i starts where layer i-1 ended (approach, the nearest order
    # and the seams, chosen away from the ignitions below), so a per-layer signature would miss a
    # change below. As a whole-part node its output signatures change with any input layer.
    type = "sequence"
    version = "2"
    title = "Sequence (layer path)"
    category = "mpp"
    inputs = (Port("toolpath", "toolpath", "Zoned section paths"),)
    outputs = (Port("toolpath", "toolpath", "Layer programs in deposition order"),)

    class Params(NodeParams):
        order: Literal["mask", "nearest"] | list[str] = Field(
            "mask",
            description="`mask`, `nearest` (shortest travel within the MPP order rule) or a list of section keys",
            title="Section order",
        )
        precedence: list[str] = Field(
            default_factory=list,
            description="Section keys deposited first on every "
            "layer, in this order, before the oscillated and then the other sections "
            "(the order rule `nearest` keeps)",
            title="Sections first",
        )
        retract_height: float = Field(
            10.0,
            ge=0,
            le=500,
            description="Clearance of arc-OFF travel above the higher end point",
            json_schema_extra=unit("mm"),
            title="Retract height",
        )
        alternate: bool = Field(
            False,
            description="Reverse open sections and the section order on odd layers (seam `alternate`)",
            title="Alternate odd layers",
        )
        seam: Literal["auto", "alternate", "stagger", "scattered", "aligned"] | Point2 = Field(
            "auto",
            description="Where sections ignite: auto (farthest from the ignitions of the layer below), "
            "alternate, stagger, scattered, aligned (as planned) or an [x, y] point (layer-local, mm)",
            title="Seam placement",
        )
        seam_shift: float = Field(
            0.0,
            ge=0,
            le=1000,
            description="Distance a closed loop's seam moves per layer (stagger/auto); 0 = 2 bead widths",
            json_schema_extra=unit("mm"),
            title="Seam shift per layer",
        )
        seam_at_junctions: bool = Field(
            False, description="Allow ignition at a junction with another section", title="Seams at junctions"
        )
        bead_width: float = Field(
            0.0,
            ge=0,
            le=100,
            description="Bead width: junction clearance and the "
            "defaults of seam_shift and min_arc_run_mm; 0 = unknown (6 mm clearance, "
            "12 mm minimum run)",
            json_schema_extra=unit("mm"),
            title="Bead width",
        )
        min_arc_run_mm: float | None = Field(
            None,
            ge=0,
            le=1000,
            description="Shortest arc-ON run; shorter "
            "ones are bridged or dropped (0 = off; empty = 2 bead widths, "
            "12 mm without a bead width)",
            json_schema_extra=unit("mm"),
            title="Shortest arc-on run",
        )
        dwell: float = Field(
            0.0,
            ge=0,
            le=3600,
            description="Interlayer dwell after each layer",
            json_schema_extra=unit("s"),
            title="Interlayer dwell",
        )

    def run(self, ctx, params, inputs):
        tp = inputs["toolpath"]
        if not isinstance(params.order, str) and all(lp is not None for lp in tp):
            seen = {sp.key for lp in tp for sp in lp.sections}
            for key in params.order:
                if key not in seen:
                    ctx.warn(f"order lists {key!r}, which matches no section", section=key)

        def in_workers(fn, items):  # in the workers if up and paid by what is sent (ctx.ahead may leave a few)
            return ctx.map_in_workers(fn, items, seconds=chunk_seconds(items))

        def on_layer(k: int, n: int) -> None:  # a sketch of 3,000 walls a layer takes seconds a layer
            ctx.check_cancelled()
            ctx.progress(k / n, f"layer {k} of {n} sequenced")

        if params.order == "nearest":  # a large layer's second seed goes to a worker (tour.nearest_order)
            ctx.start_workers(sum(submitted_seconds(len(lp.sections)) for lp in tp if lp is not None))
        layers, notes = sequence_with_notes(list(tp), params, in_workers, on_layer, ctx.submit, ctx.ahead())
        _report(ctx, params, layers, notes)
        return {"toolpath": Layered(tuple(layers))}

    ahead_input = "toolpath"  # zoned layers sequenced in the chain tasks that made them

    def run_ahead(self, params, items):
        """A run of consecutive zoned layers sequenced from nothing where a chain task made them
        (`layer_path.sequence_ahead`); `run` takes a layer's result only when it was made from the
        very layer it is given, with the torch position and ignitions the serial chain reaches."""
        return sequence_ahead(items, **_kernel_kw(params))

    def artifacts(self, ctx, params, outputs):
        travel = [
            {"index": lp.index, "travel_mm": round(t, 3), "order": [sp.key for sp in lp.sections]}
            for lp, t in zip(outputs["toolpath"], part_travel(outputs["toolpath"]))
            if lp is not None
        ]
        total = round(sum(t["travel_mm"] for t in travel), 3)
        return {
            "toolpath.json": serialize.dumps(serialize.toolpath_json(outputs["toolpath"])),
            "travel.json": serialize.dumps({"units": "mm", "total_travel_mm": total, "layers": travel}),
        }


def _kernel_kw(params) -> dict:
    """The sequencing kernel's keywords for the node's params (`sequence_layer`)."""
    bw = params.bead_width
    clearance = bw if bw > 0 else DEFAULT_CLEARANCE
    shift = params.seam_shift if params.seam_shift > 0 else 2.0 * clearance
    min_run = params.min_arc_run_mm if params.min_arc_run_mm is not None else (2.0 * bw if bw > 0 else 12.0)
    policy = "alternate" if params.alternate and params.seam == "auto" else params.seam
    return {
        "order": params.order,
        "retract_height": params.retract_height,
        "alternate": params.alternate,
        "dwell_after_s": params.dwell,
        "min_run": min_run,
        "precedence": tuple(params.precedence),
        "seam": SeamSpec(
            policy if isinstance(policy, str) else tuple(policy), clearance, shift, params.seam_at_junctions
        ),
    }


def sequence_with_notes(
    layers: list, params, map_chunks=None, on_layer=None, submit=None, ahead=None
) -> tuple[list, list[dict]]:
    """Run `sequence_part` with the node's params (`map_chunks`, `on_layer`, `submit`, `ahead`:
    see there); returns the layers and the kernel's notes."""
    notes: list[dict] = []
    seq, _ = sequence_part(
        layers, map_chunks=map_chunks, on_layer=on_layer, ahead=ahead, notes=notes, submit=submit, **_kernel_kw(params)
    )
    return seq, notes


def _report(ctx, params, layers, notes: list[dict]) -> None:
    """Warn each event (layer, section) and report the counts and the seam distances."""
    kinds = {"bridged": 0, "dropped": 0, "junction": 0, "order-rule": 0}
    junctions: dict[str, list[dict]] = {}
    for n in notes:
        kinds[n["kind"]] += 1
        if n["kind"] in ("bridged", "dropped"):
            what = (
                "bridged to its neighbour, arc kept on"
                if n["kind"] == "bridged"
                else "dropped (no inside gap to bridge): flown arc-OFF"
            )
            ctx.warn(
                f"arc-ON run of {n['length']:.2f} mm at {n['at'][:2]} is shorter than the minimum arc run: {what}",
                layer=n["layer"],
                section=n["section"],
            )
        elif n["kind"] == "junction":
            junctions.setdefault(n["section"], []).append(n)
    for key, at in junctions.items():  # one warning a section, its layers named
        layers_at = sorted({n["layer"] for n in at})
        where = (
            f"layer {layers_at[0]}" if len(layers_at) == 1 else f"{len(layers_at)} layers ({layer_ranges(layers_at)})"
        )
        fix = (
            "both ends of the wall meet other walls: set `seam_at_junctions` to accept it"
            if at[0].get("strategy") == "wall"
            else "set `seam_at_junctions` to accept it, or change the guide"
        )
        ctx.warn(
            f"ignites at a junction with another section at {at[0]['at'][:2]} on {where}: every entry does ({fix})",
            layer=at[0]["layer"],
            section=key,
        )
    breaks = [n for n in notes if n["kind"] == "order-rule"]
    if breaks:
        first = breaks[0]
        ctx.warn(
            f"order deposits {first['before']!r} before {first['section']!r} against the MPP order rule "
            f"(oscillated sections, then the parallel ones they feed) on {len({n['layer'] for n in breaks})} "
            "layer(s): use order `nearest` or list them in `precedence`",
            layer=first["layer"],
            section=first["section"],
        )
    gaps = []
    below = None
    for lp in layers:
        if lp is None:
            below = None
            continue
        ign = ignition_points(lp.sections)
        if below is not None and len(below):
            gaps += nearest_distances(ign, below).tolist()
        below = ign
    ctx.report(
        {
            "short_runs_bridged": kinds["bridged"],
            "short_runs_dropped": kinds["dropped"],
            "junction_ignitions": kinds["junction"],
            "order_rule_breaks": kinds["order-rule"],
            "ignitions": int(sum(len(ignition_points(lp.sections)) for lp in layers if lp is not None)),
            "min_ignition_gap_to_layer_below_mm": round(min(gaps), 3) if gaps else None,
        }
    )


__all__ = ["GuideNode", "MaskNode", "SequenceNode", "ZoneNode"]
