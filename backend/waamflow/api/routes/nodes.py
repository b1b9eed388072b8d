from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from ...engine.node import catalog

router = APIRouter(tags=["nodes"])


@router.get("/api/nodes", response_model=list[dict[str, Any]])
def list_nodes() -> list[dict[str, Any]]:
    """The node catalog: each type with its ports (typed, coloured) and its params JSON Schema."""
    return catalog()
