"""Curved-part nodes (Rauch et al. 2021): `fan-slice` (layers on a fan of half-planes about an
axis) and `bead-model` (per-segment travel speed from the local layer height). Thin adapters over
waamflow.curved."""

from __future__ import annotations

import hashlib
import math
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from ..core import serialize
from ..core.errors import PlanningError, RecipeError
from ..core.model import Layered, MeshData
from ..core.tolerances import TOL
from ..curved.bead import BeadModel, csratio, dtheta_window, min_csratio
from ..curved.fan import fan_slice, height_range, make_axis, plan_fan
from ..curved.feasibility import plan_report, search_radius
from ..curved.sections import plan_sections, topology
from ..curved.speeds import apply_bead_model, layer_report, toolpath_report
from ..engine.node import LayerNode, Node, NodeParams, register, unit
from ..engine.ports import Port

Vec3 = tuple[float, float, float]


@register
class FanSliceNode(Node):
    """Fan slicing: layers cut by half-planes containing one rotation axis (Rauch et al. 2021).

    Angles grow about `axis_direction` (right-hand rule) from the part's start; reverse the
    direction to build from the other end. Each layer is a wedge Δθ wide: its local height at
    distance r from the axis is r·Δθ. Layer-local coordinates are half-plane coordinates
    (x = r, y = −position along the axis); `frame` puts them on the layer's top plane with z the
    build direction. `thickness` = r̄·Δθ at the region centroid (Δθ = thickness / r̄).
    `radius_offset` moves the axis outward within the start plane, away from the part (larger
    slicing radius, layer 0 still on the substrate); leave it empty to search the smallest offset
    (multiples of `search_step`) whose heights fit [h_min, h_max] and whose overhang (each layer
    projected onto the previous plane) stays within `max_overhang`. Leave `dtheta_deg` empty for the middle of the admissible window
    [h_min/r_min, h_max/r_max]. Warns when the plan's heights leave the bead range
    (CSratio below (1 + q)/(2(1 − q)), q = h_min/h_max: 2.7 for 2.2/3.2 mm).
    `mode` = sections (Rauch's iteration): N = 1, 2, … up to `max_sections` sections, each with its
    own axis lying in the section's start plane (the previous section's last top plane: no open
    layer between sections) and its own Δθ; the first N − 1 sections keep heights, overhang and
    closed layers in bounds (smallest offset that builds furthest), and the last one *closes on
    the part's end face* (its axis is where its start plane meets the end face), so every layer is
    a closed cross-section and the last one tops at the end face. The first N whose heights all fit
    wins; otherwise the plan whose worst layer leaves [h_min, h_max] least — warned when within
    `height_tolerance` (bead-model clamps the speeds), a PlanningError naming the layer beyond it.
    A wall longer outside than inside by more than h_max/h_min (CSratio below the minimum) cannot
    be built within the range by any plan that ends on its end face; its best plan is usually the
    one fan about the part's own bend axis, with the excess spread over every layer.
    Both modes refuse an open layer (a plane crossing an end face: a ring cut into a C).
    Writes `<node>.layers.json` and `<node>.fan.json` (axis, Δθ, sections, per-layer heights).
    """

    type = "fan-slice"
    version = "2"  # 2: sections close on the end face (no open layers); open layers refused
    title = "Fan slice (curved parts)"
    category = "curved"
    inputs = (Port("mesh", "mesh", "Solid part (mesh)"),)
    outputs = (Port("layers", "layers", "Fan layers (framed half-plane sections)"),)

    class Params(NodeParams):
        axis_point: Vec3 = Field(
            (0.0, 0.0, 0.0),
            description="A point of the slicing axis",
            json_schema_extra=unit("mm"),
            title="Point on the axis",
        )
        axis_direction: Vec3 = Field(
            (0.0, 1.0, 0.0),
            description="Slicing axis direction (layers grow counter-clockwise about it)",
            title="Axis direction",
        )
        dtheta_deg: float | None = Field(
            None,
            gt=0,
            le=45,
            json_schema_extra=unit("deg"),
            description="Angle increment Δθ; empty: middle of the admissible window",
            title="Angle increment Δθ",
        )
        radius_offset: float | None = Field(
            0.0,
            ge=0,
            le=10_000,
            json_schema_extra=unit("mm"),
            description="Move the axis outward by this much; empty: search",
            title="Axis offset",
        )
        h_min: float = Field(
            2.2,
            gt=0,
            le=50,
            json_schema_extra=unit("mm"),
            description="Smallest bead height the process makes (316L study: 2.2)",
            title="Smallest bead height",
        )
        h_max: float = Field(
            3.2,
            gt=0,
            le=50,
            json_schema_extra=unit("mm"),
            description="Largest bead height the process makes (316L study: 3.2)",
            title="Largest bead height",
        )
        max_overhang: float = Field(
            1.5,
            gt=0,
            le=50,
            json_schema_extra=unit("mm"),
            description="Largest admissible overhang between consecutive layers (search)",
            title="Largest overhang",
        )
        search_step: float = Field(
            5.0,
            gt=0,
            le=1000,
            json_schema_extra=unit("mm"),
            description="Radius search: offset increment",
            title="Offset search step",
        )
        search_max: float = Field(
            100.0,
            ge=0,
            le=10_000,
            json_schema_extra=unit("mm"),
            description="Radius search: largest offset tried",
            title="Largest offset searched",
        )
        max_sections: int = Field(
            4, ge=1, le=32, description="mode = sections: at most this many sections", title="Most sections"
        )
        height_tolerance: float = Field(
            0.1,
            ge=0,
            le=5,
            json_schema_extra=unit("mm"),
            description="mode = sections: how far a layer's heights r·Δθ may leave "
            "[h_min, h_max] when no plan keeps them inside (warned, speeds "
            "clamped; about the bead fit's scatter); beyond: error",
            title="Height tolerance",
        )
        layer_count: int | None = Field(
            None, ge=1, le=20_000, description="At most this many layers", title="Most layers"
        )
        mode: Literal["single", "sections"] = Field(
            "single",
            description="single: one fan (dtheta_deg, radius_offset); sections: cut the part into "
            "consecutive fan sections, each with its own axis and Δθ, searched greedily",
            title="Fan mode",
        )

        @model_validator(mode="after")
        def _check(self):
            if self.h_min >= self.h_max:
                raise ValueError("h_min must be below h_max")
            if not any(self.axis_direction):
                raise ValueError("axis_direction is the zero vector")
            return self

    def run(self, ctx, params, inputs):
        mesh = inputs["mesh"]
        if not isinstance(mesh, MeshData):
            raise RecipeError("fan-slice needs a solid mesh (connect a `mesh` node), not a sketch", field="mesh")
        if params.mode == "sections":
            return {"layers": Layered(self._sections(ctx, params, mesh))}
        search = None
        searched = False
        offset = params.radius_offset
        dtheta = params.dtheta_deg
        if offset is None:
            try:
                search = search_radius(
                    mesh,
                    params.axis_point,
                    params.axis_direction,
                    params.h_min,
                    params.h_max,
                    max_overhang_mm=params.max_overhang,
                    step=params.search_step,
                    max_offset=params.search_max,
                )
            except ValueError as exc:  # the part surrounds the axis, ...: the kernel says what
                raise PlanningError(str(exc)) from exc
            best = search.best
            if best is None:
                searched = True
                ctx.warn(
                    f"no slicing radius up to +{params.search_max} mm fits heights [{params.h_min}, "
                    f"{params.h_max}] mm with overhang ≤ {params.max_overhang} mm in one fan (candidates in "
                    "fan.json): slicing at offset 0; mode = sections cuts the part into sections with their "
                    "own axes"
                )
                offset = 0.0
            else:
                offset = best.offset
                dtheta = dtheta if dtheta is not None else best.dtheta_deg
        try:
            axis = make_axis(params.axis_point, params.axis_direction, mesh.vertices, offset, mesh.faces)
            r, _th, _ax = axis.polar(mesh.vertices)
            r_min, r_max = float(r.min()), float(r.max())
            if r_min <= TOL.merge:  # a point on the axis: a layer would be 0 mm thick there, whatever Δθ
                near = mesh.vertices[int(np.argmin(r))]
                raise PlanningError(
                    f"the fan's axis runs through the part: its point ({near[0]:.3f}, {near[1]:.3f}, {near[2]:.3f}) "
                    f"is {r_min:.3f} mm from the axis, where every layer would be 0 mm thick; a fan turns about an "
                    "axis beside the part (the bend's centre line): move axis_point or change axis_direction, or "
                    "raise radius_offset",
                    field="axis_point",
                )
            lo, hi = dtheta_window(r_min, r_max, params.h_min, params.h_max)
            if dtheta is None:
                if lo > hi:
                    fix = (
                        f"no offset up to search_max = {params.search_max:g} mm fitted: use mode = sections, "
                        "raise search_max, or set dtheta_deg to slice anyway (heights leave the range)"
                        if searched
                        else "set dtheta_deg, or leave radius_offset empty to search a larger radius, or use "
                        "mode = sections"
                    )
                    raise PlanningError(
                        f"no Δθ fits: radial extent {r_min:.1f}..{r_max:.1f} mm needs heights in the "
                        f"ratio {r_min / r_max:.3f} < h_min/h_max = {params.h_min / params.h_max:.3f}; " + fix
                    )
                dtheta = math.degrees((lo + hi) / 2.0)
            plan = plan_fan(mesh, axis, dtheta, layer_count=params.layer_count)
        except ValueError as exc:
            raise PlanningError(str(exc)) from exc
        layers = fan_slice(mesh, plan)
        dth = math.radians(dtheta)
        if r_min * dth < params.h_min - 1e-9 or r_max * dth > params.h_max + 1e-9:
            ctx.warn(
                f"layer heights {r_min * dth:.3f}..{r_max * dth:.3f} mm leave the bead range "
                f"[{params.h_min}, {params.h_max}] mm (CSratio {csratio(r_min, r_max):.2f}, minimum "
                f"{min_csratio(params.h_min, params.h_max):.2f})"
            )
        for l in layers:
            if l.region.is_empty:
                ctx.warn("fan layer is empty", layer=l.index)
        _refuse_open(
            layers,
            "radius_offset 0 (the part's own bend axis) or mode = sections, which closes on the end face"
            if offset
            else "set axis_point / axis_direction to the part's bend axis (its end face must be a plane through it)",
        )
        if search is not None:
            _remember_search(params, layers, search.to_json())
        return {"layers": Layered(layers)}

    @staticmethod
    def _sections(ctx, params, mesh: MeshData):
        try:
            sections, layers = plan_sections(
                mesh,
                params.axis_point,
                params.axis_direction,
                params.h_min,
                params.h_max,
                max_overhang=params.max_overhang,
                step=params.search_step,
                max_offset=params.search_max,
                max_sections=params.max_sections,
            )
        except ValueError as exc:
            raise PlanningError(str(exc)) from exc
        if not layers:
            raise PlanningError("fan sections: no layer (the part has no cross-section past its start plane)")
        _refuse_open(
            layers,
            "set axis_point / axis_direction to the part's bend axis: the last section closes "
            "on the half-plane through it at the part's end, which must be the end face",
        )
        first = 0
        for k, sec in enumerate(sections):
            last = first + sec.layers - 1
            if not sec.fits and sec.excess > params.height_tolerance + 1e-9:
                if sec.worst_layer is None:  # fan_sections measures every excess at a layer
                    raise PlanningError(
                        f"fan section {k}: heights {sec.excess:.2f} mm outside their bounds at no layer"
                    )
                w = layers[sec.worst_layer]
                lo_h, hi_h = height_range(w)
                raise PlanningError(
                    f"fan section {k} of {len(sections)} (layers {first}..{last}; the best plan of up to "
                    f"max_sections = {params.max_sections} sections that ends on the end face) needs heights {lo_h:.2f}..{hi_h:.2f} mm at layer "
                    f"{w.index} (or overhang over {params.max_overhang:g} mm): {sec.excess:.2f} mm outside "
                    f"[{params.h_min:g}, {params.h_max:g}] mm, more than height_tolerance = "
                    f"{params.height_tolerance:g} mm. Fix: a bead range (h_min, h_max and its bead model) "
                    f"spanning {lo_h:.2f}..{hi_h:.2f} mm, or height_tolerance ≥ {math.ceil(sec.excess * 100) / 100:.2f} "
                    "mm if the process tolerates it, or a part with a larger bend radius",
                    layer=w.index,
                )
            if not sec.fits:
                ctx.warn(
                    f"fan section {k} (layers {first}..{last}): heights r·Δθ leave [{params.h_min:g}, "
                    f"{params.h_max:g}] mm by up to {sec.excess:.3f} mm (layer {sec.worst_layer}; within "
                    f"height_tolerance {params.height_tolerance:g} mm): no plan of up to {params.max_sections} "
                    "sections that ends on the part's end face keeps them inside; bead-model clamps the speeds"
                )
            first += sec.layers
        if params.layer_count is not None:
            layers = layers[: params.layer_count]
        return layers

    def artifacts(self, ctx, params, outputs):
        layers = outputs["layers"]
        report = plan_report(layers, params.h_min, params.h_max)
        search = _SEARCHES.get(_search_key(params, layers))
        if search is not None:
            report["search"] = search
        return {
            "layers.json": serialize.dumps(serialize.layers_json(layers)),
            "fan.json": serialize.dumps(_rounded(report)),
        }


def _refuse_open(layers, fix: str) -> None:
    """PlanningError at the first layer whose cross-section is open (fewer holes than the part's
    first cross-section: its plane crosses an end face): wall-path could not lay it."""
    if not layers:
        return
    shape = topology(layers[0].region)
    for l in layers:
        if not l.region.is_empty and topology(l.region) != shape:
            raise PlanningError(
                f"fan layer {l.index} of {len(layers)} is open (cross-section holes {list(topology(l.region))}"
                f" vs {list(shape)} at layer 0): its plane crosses the part's end face, so that "
                f"layer and the part beyond could not be built; {fix}",
                layer=l.index,
            )


# Radius-search results by (params, first layer frame): the search needs the mesh, which
# `artifacts` does not see; a run that hits the cache in a fresh process omits the candidate list.
_SEARCHES: dict[str, dict] = {}


def _search_key(params, layers) -> str:
    first = next((l for l in layers if l is not None), None)
    frame = b"" if first is None or first.frame is None else np.round(first.frame, 9).tobytes()
    return hashlib.sha1(params.model_dump_json().encode() + frame + str(len(layers)).encode()).hexdigest()


def _remember_search(params, layers, doc: dict) -> None:
    if len(_SEARCHES) > 64:
        _SEARCHES.clear()
    _SEARCHES[_search_key(params, Layered(layers))] = doc


def _rounded(obj):
    if isinstance(obj, float):  # 8 significant digits: model coefficients are ~1e-6
        return None if not math.isfinite(obj) else float(f"{obj:.8g}")
    if isinstance(obj, dict):
        return {k: _rounded(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_rounded(v) for v in obj]
    return obj


def _with_wire_feed(lp, wfs: float):
    """The layer's paths with `wire_feed_speed` = wfs (m/min) in every welded zone lacking one."""
    from dataclasses import replace

    from ..zoning.zones import with_weld_defaults

    return replace(lp, sections=tuple(with_weld_defaults(sp, {"wire_feed_speed": round(wfs, 4)}) for sp in lp.sections))


@register
class BeadModelNode(LayerNode):
    """Bead-height model: each deposition segment's travel speed from its local layer height.

    H(Ts) = a2·Ts² + a1·Ts + a0 (H mm, Ts mm/min), valid for Ts in [ts_min, ts_max]; defaults are
    the 316L GMAW fit of Rauch et al. 2021 (WFS 8.1 m/min): 1.2245e-6·Ts² − 0.0032·Ts + 4.3126 on
    400–1200 mm/min, i.e. H 3.23 → 2.24 mm. A segment's needed height is the local layer height at
    its midpoint: r·Δθ on a fan layer (r = distance from the slicing axis), the thickness on a
    planar one. The model is inverted there; heights outside [H(ts_max), H(ts_min)] are clamped
    with a warning naming the layer. Arc-off segments keep their speed. The model holds only at its
    wire feed, so every welded zone gets `wire_feed_speed` = that feed (`model_wfs`, the study's
    8.1 m/min; with a fitted model the `wfs` it is read at) unless the zone states its own: the
    post-processor commands it. Writes `<node>.bead.json`
    (model, height range, minimum CSratio (1 + q)/(2(1 − q)), per-layer radii, heights, speeds).
    """

    type = "bead-model"
    title = "Bead-height model (speed per point)"
    category = "curved"
    inputs = (
        Port("toolpath", "toolpath", "Toolpath on fan (or planar) layers"),
        Port(
            "model",
            "bead-model",
            "Optional fitted bead model (bead-fit): its height law at `wfs` replaces the coefficients",
            optional=True,
        ),
    )
    outputs = (Port("toolpath", "toolpath", "Same paths, travel speed per segment from the model"),)
    over = "toolpath"
    version = "2"  # 2: the model's wire feed in every welded zone

    class Params(NodeParams):
        a2: float = Field(
            1.2245e-6,
            description="Quadratic coefficient",
            json_schema_extra=unit("mm/(mm/min)²"),
            title="Quadratic coefficient a₂",
        )
        a1: float = Field(
            -0.0032,
            description="Linear coefficient",
            json_schema_extra=unit("mm/(mm/min)"),
            title="Linear coefficient a₁",
        )
        a0: float = Field(4.3126, description="Constant term", json_schema_extra=unit("mm"), title="Constant term a₀")
        ts_min: float = Field(
            400.0,
            gt=0,
            le=100_000,
            description="Lowest travel speed of the fit",
            json_schema_extra=unit("mm/min"),
            title="Lowest travel speed of the fit",
        )
        ts_max: float = Field(
            1200.0,
            gt=0,
            le=100_000,
            description="Highest travel speed of the fit",
            json_schema_extra=unit("mm/min"),
            title="Highest travel speed of the fit",
        )
        wfs: float | None = Field(
            None,
            gt=0,
            le=40,
            json_schema_extra=unit("m/min"),
            description="With a connected bead model: the wire feed it is read at (empty = the middle of its trials)",
            title="Wire feed speed",
        )
        model_wfs: float = Field(
            8.1,
            gt=0,
            le=40,
            json_schema_extra=unit("m/min"),
            description="Wire feed the coefficients hold at (Rauch et al. 2021: 8.1 m/min); "
            "written as wire_feed_speed into every welded zone without one",
            title="Wire feed of the coefficients",
        )

        @model_validator(mode="after")
        def _check(self):
            BeadModel(self.a2, self.a1, self.a0, self.ts_min, self.ts_max)  # monotonic on the range
            return self

    @staticmethod
    def model(params) -> BeadModel:
        return BeadModel(params.a2, params.a1, params.a0, params.ts_min, params.ts_max)

    def run_layer(self, ctx, params, index, items):
        model = self.model(params)
        if items.get("model") is not None:
            try:
                model = BeadModel(*items["model"].height_polynomial(params.wfs))
            except ValueError as e:
                raise PlanningError(f"bead model: {e}", layer=index) from None
        new = apply_bead_model(items["toolpath"], model)
        fit = items.get("model")
        wfs = (
            params.model_wfs
            if fit is None
            else (params.wfs if params.wfs is not None else 0.5 * (fit.wfs_range[0] + fit.wfs_range[1]))
        )
        new = _with_wire_feed(new, float(wfs))
        row = layer_report(new, model)
        if row["clamped"]:
            h_lo, h_hi = model.h_range
            ctx.warn(
                f"{row['clamped']} of {row['segments']} segments need heights "
                f"{row['height_min_mm']:.2f}..{row['height_max_mm']:.2f} mm outside the model's "
                f"[{h_lo:.2f}, {h_hi:.2f}] mm: speeds clamped to [{params.ts_min:g}, "
                f"{params.ts_max:g}] mm/min",
                layer=index,
            )
        return {"toolpath": new}

    def combine(self, ctx, params, outputs, inputs):
        fit = inputs.get("model")
        self._fitted = BeadModel(*fit.height_polynomial(params.wfs)) if fit is not None else None
        return super().combine(ctx, params, outputs, inputs)

    def artifacts(self, ctx, params, outputs):
        model = getattr(self, "_fitted", None) or self.model(params)
        rows = toolpath_report(outputs["toolpath"], model)
        h_lo, h_hi = model.h_range
        report = {
            "model": {
                "a2": params.a2,
                "a1": params.a1,
                "a0": params.a0,
                "ts_min_mm_min": params.ts_min,
                "ts_max_mm_min": params.ts_max,
            },
            "h_min_mm": h_lo,
            "h_max_mm": h_hi,
            "min_csratio": min_csratio(h_lo, h_hi),
            "clamped_segments": sum(r["clamped"] for r in rows),
            "layers": rows,
        }
        return {
            "toolpath.json": serialize.dumps(serialize.toolpath_json(outputs["toolpath"])),
            "bead.json": serialize.dumps(_rounded(report)),
        }
