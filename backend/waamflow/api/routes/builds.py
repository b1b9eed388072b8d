"""Live builds (#29): start from a finished run, post each layer's scan, get the next layer's
program back (adapted to what was built). See `waamflow.api.builds` and `waamflow.asbuilt`."""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from fastapi import APIRouter, HTTPException, Path, Query, Request
from fastapi.concurrency import run_in_threadpool
from pydantic import BaseModel, ConfigDict, Field

from ...asbuilt.adapt import Window
from ...asbuilt.dwell import check_temperature
from ...asbuilt.scan import ScanError, read_heights, read_points
from ..builds import BuildNotFound, Builds
from ..deps import ServicesDep, UserDep
from ..schemas import errors
from ..store import RUN_ID_PATTERN

router = APIRouter(prefix="/api/builds", tags=["builds"])

BuildId = Annotated[str, Path(pattern=r"^[0-9a-f]{12}$", description="build id (12 hex digits)")]


class BuildRequest(BaseModel):
    model_config = ConfigDict(extra="forbid", json_schema_extra={"examples": [{"run": "3f2a9c01b7de"}]})
    run: str = Field(..., pattern=RUN_ID_PATTERN, description="a finished run: its recipe is the plan")
    min_speed_factor: float = Field(0.6, gt=0, le=1, description="slowest adapted speed, × the planned one")
    max_speed_factor: float = Field(1.6, ge=1, le=5, description="fastest adapted speed, × the planned one")
    interpass_c: float | None = Field(
        None,
        gt=-50,
        le=1500,
        allow_inf_nan=False,
        description="target interpass temperature (°C) for dwells from measured "
        "temperatures; default: the recipe's interpass node, else 200 °C",
    )
    max_dwell_s: float = Field(
        1800.0,
        ge=0,
        le=36000,
        allow_inf_nan=False,
        description="longest interpass dwell a program may hold (s); longer needs are clamped",
    )


class LayerProgram(BaseModel):
    layer: int = Field(..., description="the layer this program builds")
    adaptation: dict[str, Any] = Field(
        ..., description="what was adapted: speed factors, heights needed, samples clamped to the window"
    )
    files: dict[str, str] = Field(..., description="file name → program text of this one layer")


class BuildInfo(BaseModel):
    id: str
    run: str
    graph: str | None = None
    status: Literal["building", "complete"]
    created: str
    layers_planned: int
    layers_scanned: int


class BuildDetail(BuildInfo):
    next_layer: int | None
    layers: list[dict[str, Any]] = Field(
        ...,
        description="per scanned layer: coverage, mean/RMS/max top error (mm), "
        "the interpass temperature measured after it (°C)",
    )
    programs: list[dict[str, Any]] = Field(
        [], description="per program issued: layer, pass, speed factors, samples clamped, interpass dwell (s)"
    )
    plan_layers: list[int] = Field([], description="the planned layers' numbers, in build order")
    layers_added: int = Field(0, description="layers laid again (the top more than half a layer low after a scan)")
    layers_dropped: int = Field(0, description="layers left out (the top more than half a layer high)")
    skipped: list[int] = Field([], description="the layers left out")
    interpass: dict[str, Any] | None = Field(
        None, description="the interpass dwell rule: target and ambient °C, longest dwell s, the heat model"
    )
    log: list[dict[str, Any]] = Field(..., description="every step: time (UTC), who, action, detail")


class SurfaceLayer(BaseModel):
    layer: int
    thickness: float = Field(..., description="planned layer height, mm")
    x: list[float] = Field(..., description="planned crest x of every path sample (1 mm apart), mm")
    y: list[float]
    z: list[float]
    deviation: list[float | None] = Field(
        ..., description="measured − planned top height along the build direction, mm (null where the scan saw nothing)"
    )


class Surface(BaseModel):
    build: str
    layers: list[SurfaceLayer]


class AsBuiltView(BaseModel):
    model_config = ConfigDict(extra="forbid")
    view: str | None = Field(
        None,
        min_length=1,
        max_length=64,
        pattern=r"^[A-Za-z0-9._-]+$",
        description="the browser view (one per GUI tab); none: the default view",
    )
    show: bool = Field(True, description="false removes the as-built surface from the view")


class ScanResult(BaseModel):
    layer: dict[str, Any] = Field(..., description="the scanned layer's as-built figures")
    next: LayerProgram | None = Field(None, description="the next layer's program (none when the build is complete)")


def _builds(svc) -> Builds:
    b = svc.extra.get("builds")
    if b is None:
        b = svc.extra["builds"] = Builds(svc)
    return b


def _detail(s) -> BuildDetail:
    sm = s.summary()
    m = sm["meta"]
    return BuildDetail(
        id=m["id"],
        run=m["run"],
        graph=m.get("graph"),
        status=sm["status"],
        created=sm["created"],
        layers_planned=sm["layers_planned"],
        layers_scanned=sm["layers_scanned"],
        next_layer=sm["next_layer"],
        layers=sm["layers"],
        programs=sm["programs"],
        plan_layers=sm["plan_layers"],
        layers_added=sm["layers_added"],
        layers_dropped=sm["layers_dropped"],
        skipped=sm["skipped"],
        interpass=sm["interpass"],
        log=sm["log"],
    )


def _session(svc, build_id: str):
    try:
        return _builds(svc).get(build_id)
    except BuildNotFound:
        raise HTTPException(404, detail={"message": f"no build {build_id!r}"}) from None


def _r(a, nd: int = 3) -> list:
    return [None if not math.isfinite(v) else round(v, nd) for v in map(float, a)]


def _program(s, who) -> LayerProgram:
    p = s.next_program(who)
    return LayerProgram(layer=p["layer"], adaptation=p["adaptation"], files=p["files"])


@router.post("", status_code=201, response_model=BuildDetail, responses=errors(401, 404, 422))
async def start_build(req: BuildRequest, svc: ServicesDep, user: UserDep) -> BuildDetail:
    """Start a build from a finished run (its recipe re-planned: seconds for a large part)."""
    window = Window(min_factor=req.min_speed_factor, max_factor=req.max_speed_factor)
    try:
        s = await run_in_threadpool(_builds(svc).create, req.run, user, window, req.interpass_c, req.max_dwell_s)
    except BuildNotFound:
        raise HTTPException(404, detail={"message": f"no run {req.run!r}"}) from None
    svc.store.audit(user, "start_build", s.state["meta"].get("graph"), {"build": s.state["meta"]["id"], "run": req.run})
    return _detail(s)


@router.get("", response_model=list[BuildInfo], responses=errors(401))
def list_builds(svc: ServicesDep) -> list[BuildInfo]:
    return [BuildInfo(**b) for b in _builds(svc).list()]


@router.get("/{build_id}", response_model=BuildDetail, responses=errors(401, 404, 422))
async def get_build(build_id: BuildId, svc: ServicesDep) -> BuildDetail:
    s = await run_in_threadpool(_session, svc, build_id)
    return _detail(s)


@router.get("/{build_id}/program", response_model=LayerProgram, responses=errors(401, 404, 409, 422))
async def next_program(build_id: BuildId, svc: ServicesDep, user: UserDep) -> LayerProgram:
    """The program of the next layer to build, adapted to the scans so far."""
    s = await run_in_threadpool(_session, svc, build_id)
    if s.done:
        raise HTTPException(409, detail={"message": f"build {build_id} is complete"})
    with _builds(svc).lock(build_id):
        prog = await run_in_threadpool(_program, s, user)
    svc.store.audit(user, "build_program", s.state["meta"].get("graph"), {"build": build_id, "layer": prog.layer})
    return prog


@router.post(
    "/{build_id}/scans",
    response_model=ScanResult,
    responses=errors(400, 401, 404, 409, 413, 422),
    openapi_extra={
        "requestBody": {
            "content": {
                "application/octet-stream": {
                    "schema": {
                        "type": "string",
                        "format": "binary",
                        "minLength": 1,
                        "description": "PLY or XYZ/CSV point cloud, or per-path heights CSV (layer,s,height[,width])",
                    }
                }
            },
            "required": True,
        }
    },
)
async def post_scan(
    build_id: BuildId,
    request: Request,
    svc: ServicesDep,
    user: UserDep,
    layer: int = Query(..., ge=0, description="the layer the scan is of"),
    kind: Literal["cloud", "heights"] = Query("cloud"),
    register: bool = Query(
        False,
        description="best-fit the scan's frame to the planned top first "
        "(an uncalibrated scanner; it also removes a uniform error)",
    ),
    interpass_temp_c: float | None = Query(
        None,
        ge=-50,
        le=2000,
        allow_inf_nan=False,
        description="the part temperature measured after this layer (°C, −50…2000): the next "
        "layer's program waits until the heat model says the part is at the "
        "build's interpass temperature",
    ),
) -> ScanResult:
    """The scan of the layer just built: measured against the plan, kept, and answered with the next
    layer's program. A scan of another layer, off the part, empty or with NaNs → 422 with the reason."""
    if interpass_temp_c is not None:
        try:
            check_temperature(interpass_temp_c, "interpass_temp_c")
        except ValueError as err:
            raise HTTPException(
                422, detail={"message": str(err), "field": "interpass_temp_c", "layer": layer}
            ) from None
    limit = svc.settings.max_upload_mb * 1024 * 1024
    body = await request.body()
    if len(body) > limit:
        raise HTTPException(413, detail={"message": f"scan larger than {svc.settings.max_upload_mb} MB"})
    if not body:
        raise HTTPException(400, detail={"message": "empty scan"})
    s = await run_in_threadpool(_session, svc, build_id)
    if s.done:
        raise HTTPException(409, detail={"message": f"build {build_id} is complete"})

    def work():
        with _builds(svc).lock(build_id):
            try:
                if kind == "cloud":
                    scan = read_points(body, layer, source=f"scan of layer {layer}")
                else:
                    scan = read_heights(body.decode("utf-8", "replace"), layer, source=f"scan of layer {layer}")[layer]
            except ScanError as err:
                s.refuse(user, layer, str(err))
                raise
            row = s.add_scan(scan, who=user, register_frame=register, raw=body, interpass_c=interpass_temp_c)
            nxt = None if s.done else _program(s, user)
            return row, nxt

    try:
        row, nxt = await run_in_threadpool(work)
    except ScanError as err:
        svc.store.audit(user, "scan_refused", s.state["meta"].get("graph"), {"build": build_id, "layer": layer})
        raise HTTPException(422, detail={"message": str(err), "layer": layer}) from None
    svc.store.audit(user, "build_scan", s.state["meta"].get("graph"), {"build": build_id, "layer": layer})
    return ScanResult(layer=row, next=nxt)


@router.get("/{build_id}/surface", response_model=Surface, responses=errors(401, 404, 422))
async def surface(
    build_id: BuildId,
    svc: ServicesDep,
    layer: int | None = Query(None, ge=0, description="only this layer (default: every scanned one)"),
) -> Surface:
    """The as-built top of the scanned layers: per path sample the planned crest and the measured
    deviation from it (what the 2D canvas overlays along the path)."""
    s = await run_in_threadpool(_session, svc, build_id)
    rows = [r for r in s.surface() if layer is None or r["layer"] == layer]
    return Surface(
        build=build_id,
        layers=[
            SurfaceLayer(
                layer=r["layer"],
                thickness=r["thickness"],
                x=_r(r["points"][:, 0]),
                y=_r(r["points"][:, 1]),
                z=_r(r["points"][:, 2]),
                deviation=_r(r["deviation"], 4),
            )
            for r in rows
        ],
    )


@router.post("/{build_id}/view", responses=errors(401, 404, 409, 422))
async def show_in_3d(build_id: BuildId, req: AsBuiltView, svc: ServicesDep) -> dict[str, Any]:
    """Draw the build's as-built surface (scanned tops coloured by deviation) in a 3D view beside
    the plan; returns the legend (deviation range in mm, colour stops, points and layers drawn)."""
    if svc.viewer is None:
        raise HTTPException(409, detail={"message": "the 3D preview is not running on this server"})
    s = await run_in_threadpool(_session, svc, build_id)
    layers = s.surface() if req.show else None
    try:
        legend = await run_in_threadpool(
            lambda: svc.viewer.show_asbuilt(build_id if req.show else None, layers, view=req.view)
        )
    except RuntimeError as err:
        raise HTTPException(409, detail={"message": str(err)}) from None
    return {"build": build_id, "shown": req.show, "legend": legend}
