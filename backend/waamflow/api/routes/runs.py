"""Runs: start (202), status, progress events (SSE), artifacts, cancel."""

from __future__ import annotations

import asyncio
import json
from typing import Any, Literal

from fastapi import APIRouter, Header, HTTPException, Query, Response
from fastapi.responses import FileResponse, StreamingResponse
from pydantic import BaseModel, ConfigDict, Field, model_validator

from ...core.errors import RecipeError
from ...engine.graph import build_graph
from ...engine.recipe import apply_overrides
from ..services import parse_api_recipe
from ..deps import ArtifactName, ClientDep, RunId, ServicesDep, UserDep
from ..schemas import RunEvent, errors
from ..store import GRAPH_NAME_PATTERN

router = APIRouter(prefix="/api/runs", tags=["runs"])


class RunRequest(BaseModel):
    """`graph`, `recipe` or both; `params_xml` with either (an unsaved recipe's draft XML too)."""

    # "`graph`, `recipe` or both" in JSON Schema: not both absent/null (a `not` the TypeScript
    # generator leaves alone, so the request type stays one object of optional fields); `{}` is
    # schema-invalid, as the server has always answered (422)
    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={
            "examples": [{"graph": "rectangle-study", "inputs": {"pattern": "swiping", "speed": 40}}],
            "not": {"properties": {"graph": {"type": "null"}, "recipe": {"type": "null"}}},
        },
    )
    graph: str | None = Field(
        None,
        pattern=GRAPH_NAME_PATTERN,
        max_length=80,
        description="name of a saved graph (alone: run it as saved; with `recipe`: "
        "run `recipe` with this graph's files and parameter XML)",
    )
    recipe: dict[str, Any] | None = Field(None, description="an inline recipe (e.g. unsaved edits; see Recipe)")
    inputs: dict[str, Any] = Field(default_factory=dict, description="recipe input values to override")
    params_xml: str | None = Field(
        None,
        max_length=20_000_000,
        description="a draft zone-parameter XML used for this run (with `graph`: "
        "instead of the saved one); it never becomes a graph's XML (the "
        "run keeps it, to rebuild its 3D scene after a restart)",
    )
    accept_preflight: bool = Field(
        False,
        description="hand out the programs even when the preflight fails (the "
        "acceptance is written into each program's header); else a failed preflight keeps "
        "them back and `summary.preflight.withheld` names them",
    )

    @model_validator(mode="after")
    def _one(self) -> "RunRequest":
        if self.graph is None and self.recipe is None:
            raise ValueError("give 'graph', 'recipe', or both")
        return self


class RunCreated(BaseModel):
    id: str


class RunStatus(BaseModel):
    id: str
    graph: str | None
    status: Literal["queued", "running", "done", "failed", "cancelled", "interrupted"] = Field(
        description="interrupted: the server stopped while the run was queued or running"
    )
    progress: float
    error: dict[str, Any] | None = None
    summary: dict[str, Any] | None = None
    created: float
    started: float | None = None
    finished: float | None = None


class ArtifactInfo(BaseModel):
    name: str
    size: int


class RunListItem(BaseModel):
    id: str
    graph: str | None
    status: str
    progress: float | None
    created: float
    finished: float | None
    same_as_saved: bool | None = Field(
        None,
        description="with `?graph=`: whether the run used the graph's recipe "
        "and parameter XML as saved now (false: unsaved edits or an older revision)",
    )


def _get_run(svc, run_id: str) -> dict:
    run = svc.store.get_run(run_id)
    if run is None:
        raise HTTPException(404, detail={"message": f"no run {run_id!r}"})
    return run


@router.post("", status_code=202, response_model=RunCreated, responses=errors(401, 404, 422, 429))
def start_run(req: RunRequest, svc: ServicesDep, user: UserDep, client: ClientDep) -> RunCreated:
    """Queue a run. 422: the recipe is invalid or names a file outside the sandbox (node + field);
    429: the run queue is full (Retry-After)."""
    if req.graph is not None:
        data = svc.store.get_graph(req.graph)
        if data is None:
            raise HTTPException(404, detail={"message": f"no graph named {req.graph!r}"})
    if req.recipe is not None:
        data = req.recipe
    recipe = parse_api_recipe(data)
    recipe = apply_overrides(recipe, list(req.inputs.items()))
    if req.params_xml is not None:
        from ...zoning.params_xml import validate_xml

        validate_xml(req.params_xml)  # RecipeError (naming layer/section/zone) → 422
    recipe = svc.prepare(req.graph, recipe, req.params_xml)
    resolver = svc.resolver_for(req.graph, recipe, req.params_xml)
    svc.check_recipe_files(recipe, resolver)  # files first: 422 naming node and param
    svc.check_sandbox(build_graph(recipe), resolver)  # → 422
    run_id = svc.run_manager().submit(
        req.graph, recipe, req.params_xml, accept_preflight=req.accept_preflight
    )  # validates the graph: RecipeError → 422
    svc.store.audit(
        user,
        "run",
        req.graph,
        {
            "run": run_id,
            "inline_recipe": req.recipe is not None,
            **({"accept_preflight": True} if req.accept_preflight else {}),
            "client": client,
        },
    )
    return RunCreated(id=run_id)


@router.get("", response_model=list[RunListItem], responses=errors(401, 422))
def list_runs(
    svc: ServicesDep,
    limit: int = Query(50, ge=1, le=500),
    graph: str | None = Query(
        None, pattern=GRAPH_NAME_PATTERN, max_length=80, description="only the runs of this saved graph (newest first)"
    ),
) -> list[dict[str, Any]]:
    runs = svc.store.list_runs(limit, graph=graph)
    if graph is not None:
        for r in runs:
            r["same_as_saved"] = _same_as_saved(svc, graph, r["id"])
    return runs


def _same_as_saved(svc, graph: str, run_id: str) -> bool | None:
    """The run's recipe (as prepared for it) and draft XML against the graph's saved ones (#25: a
    reopened recipe's latest results count as current only when they are of what is saved)."""
    saved, run = svc.store.get_graph(graph), svc.store.get_run(run_id)
    if saved is None or run is None:
        return None
    xml = svc.store.get_run_params_xml(run_id)
    if xml is not None and xml != svc.store.get_params_xml(graph):
        return False
    try:
        mine = svc.prepare(graph, parse_api_recipe(saved), xml)
    except (RecipeError, ValueError):  # a saved recipe that no longer parses: not the run's
        return False
    strip = lambda d: {k: v for k, v in d.items() if k not in ("ui", "name")}  # noqa: E731
    return strip(mine.to_json()) == strip(run["recipe"])


@router.get("/{run_id}", response_model=RunStatus, responses=errors(401, 404, 422))
def get_run(run_id: RunId, svc: ServicesDep) -> RunStatus:
    run = _get_run(svc, run_id)
    return RunStatus(
        id=run["id"],
        graph=run["graph"],
        status=run["status"],
        progress=run["progress"] or 0.0,
        error=run["error"],
        summary=run["summary"],
        created=run["created"],
        started=run["started"],
        finished=run["finished"],
    )


# one Server-Sent Event (OpenAPI 3.1: the schema of a text/event-stream describes each event)
SSE_EVENT = {
    "type": "object",
    "required": ["data"],
    "properties": {
        "data": {
            "type": "string",
            "contentMediaType": "application/json",
            "contentSchema": {"$ref": "#/components/schemas/RunEvent"},
        },
        "id": {"type": "string", "pattern": "^[0-9]+$", "description": "the event's seq (Last-Event-ID to resume)"},
        "event": {"type": "string"},
    },
}

# media type of each artifact by file extension (anything else: application/octet-stream)
TEXT_ARTIFACTS = (".gcode", ".nc", ".ngc", ".src", ".dat", ".mod", ".csv", ".txt", ".log")
ARTIFACT_MEDIA = {
    ".json": "application/json",
    ".xml": "application/xml",
    ".svg": "image/svg+xml",
    ".png": "image/png",
    **{ext: "text/plain" for ext in TEXT_ARTIFACTS},
}
ARTIFACT_SCHEMAS = {
    "application/json": {"schema": {}},
    "application/xml": {"schema": {"type": "string"}},
    "image/svg+xml": {"schema": {"type": "string"}},
    "image/png": {"schema": {"type": "string", "format": "binary"}},
    "text/plain": {"schema": {"type": "string"}},
    "application/octet-stream": {"schema": {"type": "string", "format": "binary"}},
}


def artifact_media_type(name: str) -> str:
    dot = name.rfind(".")
    return ARTIFACT_MEDIA.get(name[dot:].lower() if dot >= 0 else "", "application/octet-stream")


@router.get(
    "/{run_id}/events",
    response_class=StreamingResponse,
    responses={200: {"content": {"text/event-stream": {"schema": SSE_EVENT}}}, **errors(401, 404, 422)},
)
async def run_events(
    run_id: RunId, svc: ServicesDep, last_event_id: str | None = Header(None, max_length=20)
) -> StreamingResponse:
    """Server-Sent Events: each `data:` line is one JSON event (see engine/events.py); the stream
    ends after run_finished / run_failed / run_cancelled. Resumes after `Last-Event-ID`."""
    _get_run(svc, run_id)
    runs = svc.run_manager()  # 503 before the stream starts, not inside it
    start = int(last_event_id) if last_event_id and last_event_id.isdigit() else 0

    async def stream():
        seq = start
        idle = 0.0
        while True:
            events, ended = runs.events_since(run_id, seq)
            for ev in events:
                seq = max(seq, ev["seq"])
                yield f"id: {ev['seq']}\ndata: {json.dumps(ev)}\n\n"
            if ended and not events:
                return
            if events:
                idle = 0.0
            else:
                idle += 0.1
                if idle >= 15:
                    idle = 0.0
                    yield ": keep-alive\n\n"
            await asyncio.sleep(0.1)

    return StreamingResponse(
        stream(), media_type="text/event-stream", headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"}
    )


@router.get("/{run_id}/log", response_model=list[RunEvent], responses=errors(401, 404, 422))
def run_log(run_id: RunId, svc: ServicesDep, after: int = Query(0, ge=0, le=2**62)) -> list[dict]:
    """The run's events so far as one JSON list (the SSE stream's content, for scripts)."""
    _get_run(svc, run_id)
    return svc.run_manager().events_since(run_id, after)[0]


@router.get("/{run_id}/artifacts", response_model=list[ArtifactInfo], responses=errors(401, 404, 422))
def list_artifacts(run_id: RunId, svc: ServicesDep) -> list[ArtifactInfo]:
    _get_run(svc, run_id)
    d = svc.run_manager().run_dir(run_id)
    if not d.is_dir():
        return []
    return [ArtifactInfo(name=p.name, size=p.stat().st_size) for p in sorted(d.iterdir()) if p.is_file()]


@router.head(
    "/{run_id}/artifacts/{name}",
    response_class=Response,
    responses={
        200: {"description": "The artifact's headers (Content-Length, Content-Type), no body"},
        **errors(401, 404, 422),
    },
)
def head_artifact(run_id: RunId, name: ArtifactName, svc: ServicesDep) -> FileResponse:
    """GET's headers without the body (a download's size and type)."""
    return get_artifact(run_id, name, svc)


@router.get(
    "/{run_id}/artifacts/{name}",
    response_class=FileResponse,
    responses={200: {"content": ARTIFACT_SCHEMAS}, **errors(401, 404, 422)},
)
def get_artifact(run_id: RunId, name: ArtifactName, svc: ServicesDep) -> FileResponse:
    """One file of a run; its media type follows its extension (.json, .xml, .svg, .png, text
    programs and tables as text/plain, anything else application/octet-stream)."""
    _get_run(svc, run_id)
    d = svc.run_manager().run_dir(run_id).resolve()
    p = (d / name).resolve()
    if not p.is_relative_to(d) or not p.is_file():
        raise HTTPException(404, detail={"message": f"run {run_id} has no artifact {name!r}"})
    return FileResponse(
        p, media_type=artifact_media_type(name), filename=name, headers={"X-Content-Type-Options": "nosniff"}
    )


@router.delete("/{run_id}", status_code=202, response_model=RunStatus, responses=errors(401, 404, 422))
def cancel_run(run_id: RunId, svc: ServicesDep, user: UserDep, client: ClientDep) -> RunStatus:
    """Cancel (CONTRACT.md): a queued or running run stops and becomes `cancelled`; a finished one
    (done, failed, cancelled, interrupted) is left as it is. It never removes anything: the run's
    status, log and artifacts stay readable (GET answers 200 afterwards), the answer is the run's
    status after the request (202)."""
    run = _get_run(svc, run_id)
    if svc.run_manager().cancel(run_id):
        svc.store.audit(user, "cancel_run", run["graph"], {"run": run_id, "client": client})
    return get_run(run_id, svc)
