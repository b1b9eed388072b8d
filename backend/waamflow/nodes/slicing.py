"""The `slice` node: planar slicing of a part (solid mesh or midsurface) into layers."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from ..core import serialize
from ..core.errors import PlanningError, RecipeError
from ..core.model import Layered, Midsurface
from ..core.tolerances import TOL
from ..engine.node import Node, NodeParams, register, unit
from ..engine.ports import Port
from ..slicing import empty_layers_inside, slice_part_scheduled
from ..slicing.planes import TOP_MAX_FACTOR, TOP_MIN_FRACTION, LayerSchedule


def model_layer_height(ctx, param: float, model, explicit: bool = True) -> float:
    """The layer height: a connected bead model's target bead height wins over the `layer_height`
    param (a warning names both when the param was set (`explicit`) to another value); without a
    model (or target), the param."""
    if model is None:
        return param
    target = getattr(model, "target_height_mm", None)
    if target is None:
        ctx.warn(f"the connected bead model has no target bead height: layer_height {param:g} mm used")
        return param
    target = float(target)
    if not 0 < target <= 50:
        raise RecipeError(f"the bead model's target height {target:g} mm is not a layer height (0 < h ≤ 50 mm)")
    if explicit and abs(target - param) > 1e-9:
        ctx.warn(
            f"layer height {target:g} mm from the bead model's target bead height (connected model wins "
            f"over layer_height {param:g} mm)"
        )
    return target


def _mm(x: float) -> str:
    return f"{round(float(x), 4):g} mm"


def _no_layers(part, params, layer_height: float) -> str:
    """Why a slice gave no layers: the part's height along the build direction against the layer
    height and the range settings, and what to change."""
    d = np.asarray(params.direction, dtype=float)
    d = d / np.linalg.norm(d)
    if isinstance(part, Midsurface):
        pts = np.vstack(
            [np.column_stack([c, np.full(len(c), z)]) for c in part.curves for z in (part.z0, part.z0 + part.height)]
        )
    else:
        pts = np.asarray(part.vertices, dtype=float)
    h = pts @ d
    lo, hi = float(h.min()), float(h.max())
    tall = hi - lo
    what = (
        f"no layers: the part is {_mm(tall)} tall (from {_mm(lo)} to {_mm(hi)} along the build direction), "
        f"layer height {_mm(layer_height)}, top '{params.top}'"
    )
    if tall <= TOL.merge:
        return (
            what + ": the part is flat along the build direction, nothing to stack layers on (a flat surface "
            "or a 2D drawing): check the build direction, or give a drawing its wall height (the sketch "
            "node extrudes curves)"
        )
    if tall < layer_height:
        ceil = "" if params.top == "ceil" else "use top 'ceil' (one thinner layer), "
        return (
            what + f": thinner than one layer; {ceil}a layer_height of at most "
            f"{_mm(tall)}, or check the part's size (the input node's 'units': a part in m or in read as mm "
            "is 1000 or 25.4 times too small)"
        )
    return (
        what + f", start_offset {_mm(params.start_offset)}, z_min {params.z_min}, z_max {params.z_max}: the "
        "slicing range is empty; set start_offset, z_min and z_max within the part's range"
    )


def _reason(geos: str) -> str:
    """GEOS's validity reason "Self-intersection[x y]" as words with the point in mm."""
    name, _, rest = geos.partition("[")
    try:
        x, y = (float(v) for v in rest.rstrip("]").split()[:2])
    except ValueError:
        return geos
    return f"{name.lower()} at ({x:.2f}, {y:.2f}) mm"


def _warn_top(ctx, schedule: LayerSchedule, layer_count: int | None, min_fraction: float, max_factor: float) -> None:
    """Warnings about where the layers end: a `nearest` gap or overshoot, a `ceil` overshoot, and
    `layer_count` keeping fewer layers than reach the top."""
    fit = schedule.fit
    if fit is None:
        return
    where = f"{_mm(fit.gap)} below" if fit.gap > 0 else f"{_mm(-fit.gap)} above"
    if fit.action == "nearest" and abs(fit.gap) > 0:
        ctx.warn(
            f"top 'nearest': the last layer tops at {_mm(fit.reached)}, {where} {fit.limit} "
            f"{_mm(fit.target)} ({'a gap' if fit.gap > 0 else 'an overshoot'}; top 'ceil' ends on it)",
            layer=fit.layer,
        )
    elif fit.action == "overshoot":
        below = (
            "there is no layer below to thicken"
            if fit.layer == 0
            else f"thickening the layer below would pass top_max_factor {max_factor:g}"
        )
        ctx.warn(
            f"top 'ceil': the {_mm(fit.target - (fit.reached - fit.thickness))} of part above the last whole "
            f"layer is less than top_min_fraction {min_fraction:g} of a layer and {below}: one more layer of "
            f"{_mm(fit.thickness)} tops at {_mm(fit.reached)}, {where} {fit.limit} {_mm(fit.target)} "
            f"(an overshoot to machine off)",
            layer=fit.layer,
        )
    if len(schedule) < schedule.total:
        last = len(schedule) - 1
        gap = fit.target - float(schedule.tops[-1])
        ctx.warn(
            f"layer_count {layer_count} keeps the first {len(schedule)} of {schedule.total} layers: the last "
            f"tops at {_mm(schedule.tops[-1])}, {_mm(gap)} below {fit.limit} {_mm(fit.target)} "
            f"(a quick look, not the whole part)",
            layer=last,
        )


@register
class SliceNode(Node):
    """Planar slicing into layers along a build direction (default +Z).

    Layer i occupies [z − t, z]: `z` is the layer's *top* (where the bead top sits and the torch
    deposits) and t its thickness; the geometry is cut at *mid-layer*, z − t/2. Layer 0 starts
    at the part's bottom (or `z_min`) plus `start_offset`; thicknesses come from `thicknesses`
    in order, then `layer_height`, up to the part's top (or `z_max`) by the `top` policy:
    `ceil` (default) ends the last layer on the top — the remainder above the last whole layer
    is a thinned last layer when it is ≥ `top_min_fraction` (0.5) of a layer, else it is merged
    into the layer below up to `top_max_factor` (1.5) × its thickness, else one more layer is
    built and its overshoot warned; `nearest` ends on the nearest whole layer and warns the gap
    or overshoot; `exact` allows whole layers only and fails (exit 3) naming two layer heights
    that fit. `layer_count` keeps only the first layers (a quick look; a warning says how far
    below the top they stop). Solids give polygons with holes (even-odd nesting,
    any number of bodies and islands, overlapping bodies united); midsurface sketches give their curves on every layer
    within the extrusion. With a `direction` other than +Z, heights are measured along it and each
    layer carries its frame (layer-local x, y → world; in `layers.json` as "frame"). Warns on
    layers inside the part that come out empty. Writes `<node>.layers.json`.

    With a bead model connected (`model`, from bead-fit), the layer height is the model's target
    bead height: the connected model wins over `layer_height`, and a warning names both values
    when `layer_height` is set to another value (explicit `thicknesses` still come first).
    """

    type = "slice"
    # 2: the `top` policy (ceil by default: the last layer ends on the part's top); 3: sections that
    # cross themselves made valid, and warned
    version = "3"
    title = "Slice"
    category = "slicing"
    inputs = (
        Port("mesh", "mesh", "Part: solid mesh or midsurface"),
        Port(
            "model",
            "bead-model",
            "Optional bead model (bead-fit): its target bead height is the layer height, overriding `layer_height`",
            optional=True,
        ),
    )
    outputs = (Port("layers", "layers", "Layers, bottom to top"),)

    class Params(NodeParams):
        layer_height: float = Field(
            1.5,
            gt=0,
            le=50,
            description="Layer height (after the listed thicknesses)",
            json_schema_extra=unit("mm"),
            title="Layer height",
        )
        thicknesses: list[float] = Field(
            default_factory=list,
            max_length=10_000,
            description="Explicit thicknesses of the first layers, bottom up",
            json_schema_extra=unit("mm"),
            title="First layer thicknesses",
        )
        start_offset: float = Field(
            0.0,
            ge=0,
            le=10_000,
            description="Bottom of layer 0 above the part's bottom (or z_min)",
            json_schema_extra=unit("mm"),
            title="Start offset",
        )
        layer_count: int | None = Field(
            None,
            ge=1,
            le=200_000,
            description="Only the first this many layers (a quick look; warned when they stop below the top)",
            title="Only the first layers",
        )
        z_min: float | None = Field(
            None,
            description="Bottom of layer 0 instead of the part's bottom",
            json_schema_extra=unit("mm"),
            title="Bottom height",
        )
        z_max: float | None = Field(
            None,
            description="The layers end at this height instead of the part's top (by the `top` policy)",
            json_schema_extra=unit("mm"),
            title="Top height",
        )
        top: Literal["ceil", "nearest", "exact"] = Field(
            "ceil",
            description="How the last layer meets the part's top (or z_max): 'ceil' ends on it (last layer "
            "thinned, or merged into the one below, else one layer more, warned); 'nearest' "
            "the nearest whole layer, gap or overshoot warned; 'exact' whole layers only, "
            "else an error naming layer heights that fit",
            title="Top layer rule",
        )
        top_min_fraction: float = Field(
            TOP_MIN_FRACTION,
            ge=0.05,
            le=1.0,
            description="'ceil': a thinned last layer is at least this fraction of its nominal thickness "
            "(a thinner remainder is merged into the layer below)",
            title="Thinned top layer limit",
        )
        top_max_factor: float = Field(
            TOP_MAX_FACTOR,
            ge=1.0,
            le=3.0,
            description="'ceil': a layer thickened by a merged remainder stays at most this factor of its "
            "thickness (else one layer more is built above the top)",
            title="Thickened top layer limit",
        )
        direction: tuple[float, float, float] = Field(
            (0.0, 0.0, 1.0),
            description="Build direction (world); layers stack along it, heights are measured along it",
            title="Build direction",
        )

        @model_validator(mode="after")
        def _check(self):
            if any(not (0 < t <= 50) for t in self.thicknesses):
                raise ValueError("every thickness must be > 0 and ≤ 50 mm")
            if self.z_min is not None and self.z_max is not None and self.z_max <= self.z_min:
                raise ValueError("z_max must be above z_min")
            return self

    def run(self, ctx, params, inputs):
        part = inputs["mesh"]
        layer_height = model_layer_height(
            ctx, params.layer_height, inputs.get("model"), "layer_height" in params.model_fields_set
        )
        repairs: list[tuple[int, str, float, float]] = []
        try:
            layers, schedule = slice_part_scheduled(
                part,
                layer_height=layer_height,
                thicknesses=params.thicknesses,
                start_offset=params.start_offset,
                layer_count=params.layer_count,
                z_min=params.z_min,
                z_max=params.z_max,
                direction=params.direction,
                top=params.top,
                min_fraction=params.top_min_fraction,
                max_factor=params.top_max_factor,
                submit=ctx.submit if ctx.can_submit() else None,
                repairs=repairs,
            )
        except ValueError as exc:
            raise RecipeError(str(exc)) from exc
        if not layers:
            raise PlanningError(_no_layers(part, params, layer_height))
        for i, reason, before, after in repairs:
            ctx.warn(
                f"the section crosses itself ({_reason(reason)}): the mesh's surface passes through itself "
                f"there; planned on its outline ({before:.1f} → {after:.1f} mm², shapely make_valid): "
                "repair the mesh (e.g. a boolean union of its shells) to be sure of this layer",
                layer=i,
            )
        _warn_top(ctx, schedule, params.layer_count, params.top_min_fraction, params.top_max_factor)
        for i in empty_layers_inside(layers, part, params.direction):
            ctx.warn("layer is empty although it lies within the part's height (gap between bodies?)", layer=i)
        if isinstance(part, Midsurface) and not any(l.curves for l in layers):
            ctx.warn("no layer lies within the sketch's extrusion (check z0, height, z_min/z_max)")
        return {"layers": Layered(layers)}

    def artifacts(self, ctx, params, outputs):
        return {"layers.json": serialize.dumps(serialize.layers_json(outputs["layers"]))}
