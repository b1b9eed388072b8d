"""Response models of the REST API that mirror engine/core JSON (so the TypeScript client is
generated for them too). The dicts are produced by core.serialize / Node.describe / Event.to_dict;
these models only declare their shape."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from ..engine.events import EVENT_KINDS

Point2 = list[float]


class PortInfo(BaseModel):
    name: str
    type: str
    description: str
    optional: bool
    color: str


class NodeInfo(BaseModel):
    type: str
    title: str
    category: str
    description: str
    version: str
    per_layer: bool
    inputs: list[PortInfo]
    outputs: list[PortInfo]
    params_schema: dict[str, Any] = Field(description="JSON Schema of the node's params (numeric fields carry `unit`)")


class ProcessParameterInfo(BaseModel):
    name: str
    unit: str
    label: str
    minimum: float
    maximum: float
    description: str


class RunEvent(BaseModel):
    """One progress event (engine/events.py), as sent in each SSE `data:` line."""

    model_config = ConfigDict(extra="allow")
    seq: int
    kind: Literal[EVENT_KINDS]  # type: ignore[valid-type]
    time: float
    progress: float
    node: str | None = None
    layer: int | None = None
    section: str | None = None
    message: str | None = None
    seconds: float | None = None
    cached: bool | None = None
    error: dict[str, Any] | None = None


class PolygonJSON(BaseModel):
    exterior: list[Point2]
    holes: list[list[Point2]]


class LayerJSON(BaseModel):
    index: int
    z: float = Field(description="top of the layer, mm")
    thickness: float = Field(description="mm")
    area_mm2: float
    polygons: list[PolygonJSON]
    curves: list[list[Point2]]
    frame: list[list[float]] | None = Field(None, description="4×4 layer-local → world, for non-horizontal layers")


class SectionJSON(BaseModel):
    key: str
    polygon: PolygonJSON
    guide: list[Point2] | None
    start: Point2 | None
    stop: Point2 | None


class SectionPathJSON(BaseModel):
    key: str
    strategy: str
    points: list[list[float]] = Field(description="(n, 3) world mm")
    zone: list[str]
    arc: list[bool]
    inside: list[bool]
    speed: list[float | None] = Field(description="mm/s per segment")
    length_mm: float
    zone_colors: dict[str, str] | None = None
    zone_params: dict[str, dict[str, float]] | None = None
    approach: list[list[float]] | None = None
    tool_axis: list[list[float]] | None = None
