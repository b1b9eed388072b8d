"""Response models of the REST API that mirror engine/core JSON (so the TypeScript client is
generated for them too). The dicts are produced by core.serialize / Node.describe / Event.to_dict;
these models only declare their shape."""

from __future__ import annotations

import json
from typing import Any, Literal

from typing import Annotated

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field

from ..engine.events import EVENT_KINDS

Point2 = list[float]


def _no_bool(v: Any) -> Any:
    if isinstance(v, bool):  # JSON true/false are not integers (pydantic's lax mode would take them)
        raise ValueError("Input should be a valid integer, not a boolean")
    return v


JsonInt = Annotated[int, BeforeValidator(_no_bool)]
# a layer index: the bounds come before the validator so they stay in the JSON Schema
LayerIndex = Annotated[int, Field(ge=0, le=1_000_000), BeforeValidator(_no_bool)]


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
    compute_seconds: float | None = Field(
        None,
        description="node_finished of a layer node: seconds spent on its "
        "layers in any process (in a parallel run a chain's first node's `seconds` "
        "also holds its followers' layers)",
    )
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


class ClimbJSON(BaseModel):
    from_layer: int = Field(description="the layer the helix is laid in (its one ignition)")
    laps: int = Field(description="layers' heights it climbs, its first lap's included")
    z_from: float = Field(description="mm")
    z_to: float = Field(description="mm")


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
    climbs: ClimbJSON | None = Field(
        None, description="a lap of a helix welded through several layers in one go, laid in `from_layer`"
    )


# ---- the one error model of every 4xx answer --------------------------------------------------
ERROR_KINDS = (
    "bad_request",
    "unauthorized",
    "forbidden",
    "not_found",
    "method_not_allowed",
    "conflict",
    "too_large",
    "invalid_request",
    "invalid_recipe",
    "invalid_input",
    "planning_failed",
    "outside_sandbox",
    "busy",
    "error",
)


class ValidationItem(BaseModel):
    loc: list[str | int]
    msg: str


class ErrorDetail(BaseModel):
    """Where and what: the same fields as a failed run's `error` (core/errors.py)."""

    kind: str = Field(description="machine-readable class: " + ", ".join(ERROR_KINDS))
    message: str
    node: str | None = Field(None, description="node id the error is about")
    layer: int | None = Field(None, description="layer index")
    section: str | None = Field(None, description="section key")
    field: str | None = Field(None, description="parameter or request field")
    text: str = Field(description="one line for people: location + message")
    errors: list[ValidationItem] | None = Field(None, description="every violation of a request schema (422)")


class ErrorResponse(BaseModel):
    detail: ErrorDetail


class ConflictDetail(ErrorDetail):
    """A 409: a read-only example (only the error fields), or a stale If-Match (also both versions)."""

    yours: Any = Field(None, description="stale If-Match: the body that was sent (recipe JSON or XML text)")
    theirs: dict[str, Any] | None = Field(
        None,
        description='stale If-Match: the stored version, `{"revision": n, '
        '"recipe": {...}}` or `{"revision": n, "xml": "..."}`; null when the '
        "graph was deleted meanwhile",
    )


class ConflictResponse(BaseModel):
    detail: ConflictDetail


STATUS_KIND = {
    400: "bad_request",
    401: "unauthorized",
    403: "forbidden",
    404: "not_found",
    405: "method_not_allowed",
    409: "conflict",
    413: "too_large",
    422: "invalid_request",
    429: "busy",
}
STATUS_TEXT = {
    400: "Bad request",
    401: "Missing or wrong bearer token",
    403: "The token's role does not allow this (roles: viewer, operator, editor, admin)",
    404: "Not found",
    409: "Conflict (e.g. a read-only example)",
    413: "Too large",
    422: "Invalid request, recipe or file",
    429: "Run queue full (see Retry-After)",
}


def error_body(status: int, detail: Any) -> dict:
    """Any error detail (string, dict from an HTTPException, WaamflowError.to_dict()) → ErrorResponse JSON."""
    if isinstance(detail, dict):
        d = dict(detail)
    else:
        d = {"message": str(detail) if detail else STATUS_TEXT.get(status, "error")}
    d.setdefault("kind", STATUS_KIND.get(status, "error"))
    d.setdefault("message", STATUS_TEXT.get(status, "error"))
    for k in ("node", "layer", "section", "field"):
        v = d.get(k)
        if k == "layer":
            d[k] = v if isinstance(v, int) and not isinstance(v, bool) else None
        else:
            d[k] = v if v is None or isinstance(v, str) else json.dumps(v, default=str)
    d["message"] = str(d["message"])
    d.pop("errors", None) if not isinstance(d.get("errors"), list) else None
    if not d.get("text"):
        loc = ", ".join(f"{k} {d[k]!r}" for k in ("node", "layer", "section", "field") if d.get(k) is not None)
        d["text"] = f"{loc}: {d['message']}" if loc else d["message"]
    return {"detail": ErrorDetail.model_validate(d).model_dump(exclude_none=False)}


def errors(*statuses: int) -> dict:
    """`responses=` of a route: each status it can answer with, all with the ErrorResponse body."""
    return {s: {"model": ErrorResponse, "description": STATUS_TEXT.get(s, "error")} for s in statuses}


def present(field: str, type_: str) -> dict:
    sub = {"type": type_, "additionalProperties": True} if type_ == "object" else {"type": type_}
    return {"required": [field], "properties": {field: sub}}


# JSON Schema of "`params_xml` only with `graph`" (null = absent). "`graph` and/or `recipe`" is
# checked by the server (422) and said in the description: as an anyOf it would turn the generated
# TypeScript request type into a union the GUI cannot build from optional fields.
XML_NEEDS_GRAPH = {
    "anyOf": [
        {"not": {"required": ["params_xml"]}},
        {"properties": {"params_xml": {"type": "null"}}},
        present("graph", "string"),
    ]
}
RUN_REQUEST_RULES = {"allOf": [XML_NEEDS_GRAPH]}
PREVIEW_REQUEST_RULES = {"allOf": [XML_NEEDS_GRAPH]}
