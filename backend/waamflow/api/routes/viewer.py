"""Steer the embedded 3D preview: which recipe's run it shows, which node and layer it follows,
view settings (visibility, layer range, colour modes, playback time), and the state and legend
data the GUI's 3D tab draws beside the scene.

Every call names a `view`: the id of one browser tab's 3D view (the GUI makes one per page load
and passes it to viser's page as `?view=`), so each tab — each user — has its own scene, camera,
playback and colours. Without `view` the calls steer the server's default view (scripts)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, HTTPException, Query, Response
from pydantic import BaseModel, ConfigDict, Field

from ..deps import ServicesDep
from ..schemas import LayerIndex, errors

router = APIRouter(prefix="/api/viewer", tags=["viewer"])

ViewId = Annotated[
    str,
    Field(
        min_length=1,
        max_length=64,
        pattern=r"^[A-Za-z0-9._-]+$",
        description="the browser view (one per GUI tab); none: the default view",
    ),
]


class Selection(BaseModel):
    model_config = ConfigDict(extra="forbid")
    node: str | None = Field(None, description="node id whose output to show (None = all)")
    layer: LayerIndex | None = Field(None, description="layer index to focus (None = all)")
    graph: str | None = Field(None, description="show the latest run of this saved graph (the GUI's open recipe)")
    run: str | None = Field(None, description="show this run (an unsaved recipe's run is keyed by its run id)")
    view: ViewId | None = None


class ViewSettings(BaseModel):
    model_config = ConfigDict(extra="forbid")
    hidden: list[str] | None = Field(None, description="node ids whose output is hidden")
    layer_lo: int | None = Field(None, ge=0, description="first layer shown")
    layer_hi: int | None = Field(None, ge=0, description="last layer shown (inclusive)")
    path_color: Literal["zone", "speed", "arc", "section"] | None = Field(None, description="toolpath colour")
    sim_color: Literal["deviation", "speed", "deposit"] | None = Field(None, description="simulated path colour")
    show_programmed: bool | None = Field(None, description="draw the programmed path")
    show_simulated: bool | None = Field(None, description="draw the simulated path")
    show_robot: bool | None = Field(None, description="draw the robot at the playback time")
    time_s: float | None = Field(None, ge=0, description="playback time, s")
    sim_offset_mm: float | None = Field(
        None, ge=0, le=1000, description="simulated path drawn this far above the programmed one, mm"
    )
    fit: bool | Literal["part", "cell"] = Field(
        False,
        description="frame the camera at the playback time: true or 'part' on the part as the positioner "
        "holds it, 'cell' on the part with robot, torch and positioner",
    )
    view: ViewId | None = None


@router.post("/select", status_code=204, response_class=Response, responses=errors(401, 422))
def select(sel: Selection, svc: ServicesDep) -> Response:
    """Follow a recipe (graph or run) and a node/layer in the 3D view. A no-op when the preview is off."""
    if svc.viewer is not None:
        if sel.graph is not None or sel.run is not None:
            svc.viewer.show(sel.graph or sel.run, view=sel.view)
        if sel.model_fields_set & {"node", "layer"} or not sel.model_fields_set & {"graph", "run"}:
            svc.viewer.select(sel.node, sel.layer, view=sel.view)
    return Response(status_code=204)


@router.post("/view", status_code=204, response_class=Response, responses=errors(401, 409, 422))
def view(v: ViewSettings, svc: ServicesDep) -> Response:
    """Change what the 3D view draws; fields left out keep their value."""
    if svc.viewer is None:
        raise HTTPException(409, detail={"message": "the 3D preview is not running (serve with --viewer-port)"})
    fields = v.model_dump(exclude_none=True, exclude={"hidden", "fit", "view"})
    try:
        svc.viewer.set_view(view=v.view, hidden=set(v.hidden) if v.hidden is not None else None, fit=v.fit, **fields)
    except ValueError as e:
        raise HTTPException(422, detail={"message": str(e)}) from e
    return Response(status_code=204)


@router.get("/state", responses=errors(401, 422))
def state(
    svc: ServicesDep,
    view: Annotated[
        str | None,
        Query(
            min_length=1,
            max_length=64,
            pattern=r"^[A-Za-z0-9._-]+$",
            description="the browser view; none: the default view",
        ),
    ] = None,
) -> dict[str, Any]:
    """The shown run (`key`, `run` id), its nodes (kinds drawn, visibility), layer extent, playback
    duration, view settings and legend data (zone colours, value ranges with units, colour-map
    stops). `loading` {key, run, since}: the selected recipe's latest finished run is being rebuilt
    (its scene was not in memory, e.g. after a restart); `rebuild_error` {run, message} if that failed.
    Legend ranges are robust (2nd–98th percentile): `min`/`max` give the data's extent and
    `clamped` says values beyond the colour map's ends are drawn in its end colours."""
    if svc.viewer is None:
        return {"running": False}
    return {"running": True, **svc.viewer.state(view=view)}
