from __future__ import annotations

from dataclasses import asdict

from fastapi import APIRouter

from ...core.process import ZONE_PARAMETERS
from ...engine.node import catalog
from ..schemas import NodeInfo, ProcessParameterInfo, errors

router = APIRouter(tags=["nodes"])


@router.get("/api/nodes", response_model=list[NodeInfo], responses=errors(401))
def list_nodes() -> list[dict]:
    """The node catalog: each type with its ports (typed, coloured) and its params JSON Schema."""
    return catalog()


@router.get("/api/process-parameters", response_model=list[ProcessParameterInfo], responses=errors(401))
def process_parameters() -> list[dict]:
    """The zone parameters of the XML file: names, units and sanity bounds (core/process.py)."""
    return [asdict(p) for p in ZONE_PARAMETERS]
