"""Steer the embedded 3D preview: which node and layer it follows (the GUI calls this on selection)."""

from __future__ import annotations

from fastapi import APIRouter, Response
from pydantic import BaseModel, ConfigDict, Field

from ..deps import ServicesDep
from ..schemas import LayerIndex, errors

router = APIRouter(prefix="/api/viewer", tags=["viewer"])


class Selection(BaseModel):
    model_config = ConfigDict(extra="forbid")
    node: str | None = Field(None, description="node id whose output to show (None = all)")
    layer: LayerIndex | None = Field(None, description="layer index to focus (None = all)")


@router.post("/select", status_code=204, response_class=Response, responses=errors(401, 422))
def select(sel: Selection, svc: ServicesDep) -> Response:
    """Follow a node/layer in the 3D view. A no-op when the preview is off."""
    if svc.viewer is not None:
        svc.viewer.select(sel.node, sel.layer)
    return Response(status_code=204)
