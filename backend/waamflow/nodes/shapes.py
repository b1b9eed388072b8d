"""Parametric shapes that stand in for a sliced part: the robot study's objective rectangle."""

from __future__ import annotations

from pydantic import Field
from shapely.geometry import MultiPolygon, box

from ..core.model import Layer, Layered
from ..engine.node import Node, NodeParams, register, unit
from ..engine.ports import Port


def rectangle_layers(
    length: float, width: float, origin_x: float, origin_y: float, layer_count: int, layer_height: float
) -> Layered[Layer]:
    """`layer_count` horizontal layers, each the rectangle [origin_x, origin_x + length] ×
    [origin_y, origin_y + width] (mm); layer i has its top at z = (i + 1)·layer_height."""
    region = MultiPolygon([box(origin_x, origin_y, origin_x + length, origin_y + width)])
    return Layered(
        tuple(
            Layer(index=i, z=(i + 1) * layer_height, thickness=layer_height, region=region) for i in range(layer_count)
        )
    )


@register
class RectangleNode(Node):
    """An objective rectangle (OR) as layers: the area to fill in the robot study (da Silva Viola et
    al. 2023: small OR 43 × 21.5 mm, large OR 86 × 43 mm, passes along the length).

    The rectangle spans `length` along x (the pass direction of the default guide) and `width`
    along y from its corner (origin_x, origin_y); every layer has the same rectangle.
    """

    type = "rectangle"
    title = "Rectangle"
    category = "geometry"
    outputs = (Port("layers", "layers", "Rectangle regions, one per layer"),)

    class Params(NodeParams):
        length: float = Field(
            43.0,
            gt=0,
            le=10_000,
            description="Length along x (along the passes)",
            json_schema_extra=unit("mm"),
            title="Length",
        )
        width: float = Field(
            21.5, gt=0, le=10_000, description="Width along y", json_schema_extra=unit("mm"), title="Width"
        )
        origin_x: float = Field(
            0.0,
            ge=-10_000,
            le=10_000,
            description="x of the lower-left corner",
            json_schema_extra=unit("mm"),
            title="Corner x",
        )
        origin_y: float = Field(
            0.0,
            ge=-10_000,
            le=10_000,
            description="y of the lower-left corner",
            json_schema_extra=unit("mm"),
            title="Corner y",
        )
        layer_count: int = Field(1, ge=1, le=10_000, description="Number of layers", title="Number of layers")
        layer_height: float = Field(
            1.5, gt=0, le=50, description="Layer height", json_schema_extra=unit("mm"), title="Layer height"
        )

    def run(self, ctx, params, inputs):
        return {
            "layers": rectangle_layers(
                params.length, params.width, params.origin_x, params.origin_y, params.layer_count, params.layer_height
            )
        }
