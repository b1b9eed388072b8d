from __future__ import annotations

from dataclasses import asdict

from typing import Any

from fastapi import APIRouter, Response
from pydantic import BaseModel

from ...core.process import ZONE_PARAMETERS
from ...engine.node import catalog
from ..schemas import NodeInfo, ProcessParameterInfo, errors

router = APIRouter(tags=["nodes"])


class MachineProfileInfo(BaseModel):
    """A machine profile (data/machines): presets of post-process params for one controller."""

    name: str
    title: str
    description: str
    post: dict[str, Any]


@router.get("/api/nodes", response_model=list[NodeInfo], responses=errors(401))
def list_nodes() -> list[dict]:
    """The node catalog: each type with its ports (typed, coloured) and its params JSON Schema."""
    return catalog()


@router.get("/api/process-parameters", response_model=list[ProcessParameterInfo], responses=errors(401))
def process_parameters() -> list[dict]:
    """The zone parameters of the XML file: names, units and sanity bounds (core/process.py)."""
    return [asdict(p) for p in ZONE_PARAMETERS]


@router.get("/api/profiles", response_model=list[MachineProfileInfo], responses=errors(401))
def list_profiles() -> list[dict]:
    """Machine profiles for the post-process node's `profile` param (generic, LinuxCNC, Marlin,
    KUKA KR C4, ABB IRC5): each with the post-process params it presets."""
    from ...program.profiles import load_profiles

    return list(load_profiles().values())


@router.get(
    "/api/schemas/zone-params.xsd",
    response_class=Response,
    responses={200: {"content": {"application/xml": {"schema": {"type": "string"}}}}, **errors(401)},
)
def zone_params_xsd() -> Response:
    """The XML Schema (XSD 1.0) of the zone-parameter file (layer > section > zone > parameters,
    units and bounds): the file every zone node reads is validated against it."""
    from ...zoning.xsd import XSD_PATH

    return Response(XSD_PATH.read_bytes(), media_type="application/xml")
