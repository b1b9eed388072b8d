"""The `slice` node: planar slicing of a part (solid mesh or midsurface) into layers."""

from __future__ import annotations

from pydantic import Field, model_validator

from ..core import serialize
from ..core.errors import PlanningError, RecipeError
from ..core.model import Layered, Midsurface
from ..engine.node import Node, NodeParams, register, unit
from ..engine.ports import Port
from ..slicing import empty_layers_inside, slice_part


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
        ctx.warn(f"layer height {target:g} mm from the bead model's target bead height (connected model wins "
                 f"over layer_height {param:g} mm)")
    return target


@register
class SliceNode(Node):
    """Planar slicing into layers along a build direction (default +Z).

    Layer i occupies [z − t, z]: `z` is the layer's *top* (where the bead top sits and the torch
    deposits) and t its thickness; the geometry is cut at *mid-layer*, z − t/2. Layer 0 starts
    at the part's bottom (or `z_min`) plus `start_offset`; thicknesses come from `thicknesses`
    in order, then `layer_height`. Layers continue while their cutting plane is below the part's
    top (or `z_max`), at most `layer_count`. Solids give polygons with holes (even-odd nesting,
    any number of bodies and islands, overlapping bodies united); midsurface sketches give their curves on every layer
    within the extrusion. With a `direction` other than +Z, heights are measured along it and each
    layer carries its frame (layer-local x, y → world; in `layers.json` as "frame"). Warns on
    layers inside the part that come out empty. Writes `<node>.layers.json`.

    With a bead model connected (`model`, from bead-fit), the layer height is the model's target
    bead height: the connected model wins over `layer_height`, and a warning names both values
    when `layer_height` is set to another value (explicit `thicknesses` still come first).
    """

    type = "slice"
    title = "Slice"
    category = "slicing"
    inputs = (Port("mesh", "mesh", "Part: solid mesh or midsurface"),
              Port("model", "bead-model", "Optional bead model (bead-fit): its target bead height is the layer "
                                          "height, overriding `layer_height`", optional=True))
    outputs = (Port("layers", "layers", "Layers, bottom to top"),)

    class Params(NodeParams):
        layer_height: float = Field(1.5, gt=0, le=50, description="Layer height (after the listed thicknesses)",
                                    json_schema_extra=unit("mm"))
        thicknesses: list[float] = Field(default_factory=list, max_length=10_000,
                                         description="Explicit thicknesses of the first layers, bottom up",
                                         json_schema_extra=unit("mm"))
        start_offset: float = Field(0.0, ge=0, le=10_000, description="Bottom of layer 0 above the part's bottom (or z_min)",
                                    json_schema_extra=unit("mm"))
        layer_count: int | None = Field(None, ge=1, le=200_000, description="At most this many layers")
        z_min: float | None = Field(None, description="Bottom of layer 0 instead of the part's bottom",
                                    json_schema_extra=unit("mm"))
        z_max: float | None = Field(None, description="No layer is cut at or above this height",
                                    json_schema_extra=unit("mm"))
        direction: tuple[float, float, float] = Field(
            (0.0, 0.0, 1.0), description="Build direction (world); layers stack along it, heights are measured along it")

        @model_validator(mode="after")
        def _check(self):
            if any(not (0 < t <= 50) for t in self.thicknesses):
                raise ValueError("every thickness must be > 0 and ≤ 50 mm")
            if self.z_min is not None and self.z_max is not None and self.z_max <= self.z_min:
                raise ValueError("z_max must be above z_min")
            return self

    def run(self, ctx, params, inputs):
        part = inputs["mesh"]
        layer_height = model_layer_height(ctx, params.layer_height, inputs.get("model"),
                                          "layer_height" in params.model_fields_set)
        try:
            layers = slice_part(
                part, layer_height=layer_height, thicknesses=params.thicknesses,
                start_offset=params.start_offset, layer_count=params.layer_count,
                z_min=params.z_min, z_max=params.z_max, direction=params.direction,
            )
        except ValueError as exc:
            raise RecipeError(str(exc)) from exc
        if not layers:
            raise PlanningError("no layers: the slicing range (part height, start_offset, z_min/z_max) is empty")
        for i in empty_layers_inside(layers, part, params.direction):
            ctx.warn("layer is empty although it lies within the part's height (gap between bodies?)", layer=i)
        if isinstance(part, Midsurface) and not any(l.curves for l in layers):
            ctx.warn("no layer lies within the sketch's extrusion (check z0, height, z_min/z_max)")
        return {"layers": Layered(layers)}

    def artifacts(self, ctx, params, outputs):
        return {"layers.json": serialize.dumps(serialize.layers_json(outputs["layers"]))}
