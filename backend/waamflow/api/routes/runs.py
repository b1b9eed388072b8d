"""Runs: start (202), status, progress events (SSE), artifacts, cancel."""

from __future__ import annotations

import asyncio
import json
import mimetypes
from typing import Any, Literal

from fastapi import APIRouter, Header, HTTPException, Response
from fastapi.responses import FileResponse, StreamingResponse
from pydantic import BaseModel, ConfigDict, Field, model_validator

from ...engine.graph import build_graph
from ...engine.recipe import apply_overrides, parse_recipe
from ..deps import ServicesDep
from ..schemas import RunEvent
from ..store import valid_file_name, valid_graph_name

router = APIRouter(prefix="/api/runs", tags=["runs"])


class RunRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    graph: str | None = Field(None, description="name of a saved graph (alone: run it as saved; with `recipe`: "
                                                 "run `recipe` with this graph's files and parameter XML)")
    recipe: dict[str, Any] | None = Field(None, description="an inline recipe (e.g. unsaved edits)")
    inputs: dict[str, Any] = Field(default_factory=dict, description="recipe input values to override")
    params_xml: str | None = Field(None, max_length=20_000_000,
                                   description="with `graph`: a draft zone-parameter XML used for this run "
                                               "instead of the saved one; it is never stored")

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
    status: Literal["queued", "running", "done", "failed", "cancelled"]
    progress: float
    error: dict[str, Any] | None = None
    summary: dict[str, Any] | None = None
    created: float
    started: float | None = None
    finished: float | None = None


class ArtifactInfo(BaseModel):
    name: str
    size: int


def _get_run(svc, run_id: str) -> dict:
    if not run_id.isalnum() or len(run_id) > 40:
        raise HTTPException(400, detail={"message": f"invalid run id {run_id!r}"})
    run = svc.store.get_run(run_id)
    if run is None:
        raise HTTPException(404, detail={"message": f"no run {run_id!r}"})
    return run


@router.post("", status_code=202, response_model=RunCreated)
def start_run(req: RunRequest, svc: ServicesDep) -> RunCreated:
    if req.graph is not None:
        if not valid_graph_name(req.graph):
            raise HTTPException(400, detail={"message": f"invalid graph name {req.graph!r}"})
        data = svc.store.get_graph(req.graph)
        if data is None:
            raise HTTPException(404, detail={"message": f"no graph named {req.graph!r}"})
    if req.recipe is not None:
        data = req.recipe
    recipe = parse_recipe(data)
    recipe = apply_overrides(recipe, list(req.inputs.items()))
    if req.params_xml is not None:
        if req.graph is None:
            raise HTTPException(400, detail={"message": "'params_xml' needs 'graph' (the graph whose files the run uses)"})
        from ...zoning.params_xml import validate_xml

        validate_xml(req.params_xml)  # RecipeError (naming layer/section/zone) → 422
    recipe = svc.prepare(req.graph, recipe, req.params_xml)
    svc.check_sandbox(build_graph(recipe), svc.resolver_for(req.graph, recipe, req.params_xml))  # → 422
    run_id = svc.runs.submit(req.graph, recipe, req.params_xml)  # validates the graph: RecipeError → 422
    return RunCreated(id=run_id)


@router.get("", response_model=list[dict[str, Any]])
def list_runs(svc: ServicesDep, limit: int = 50) -> list[dict[str, Any]]:
    return svc.store.list_runs(max(1, min(limit, 500)))


@router.get("/{run_id}", response_model=RunStatus)
def get_run(run_id: str, svc: ServicesDep) -> RunStatus:
    run = _get_run(svc, run_id)
    return RunStatus(id=run["id"], graph=run["graph"], status=run["status"], progress=run["progress"] or 0.0,
                     error=run["error"], summary=run["summary"], created=run["created"], started=run["started"],
                     finished=run["finished"])


@router.get("/{run_id}/events", response_class=StreamingResponse,
            responses={200: {"content": {"text/event-stream": {}}}})
async def run_events(run_id: str, svc: ServicesDep, last_event_id: str | None = Header(None)) -> StreamingResponse:
    """Server-Sent Events: each `data:` line is one JSON event (see engine/events.py); the stream
    ends after run_finished / run_failed / run_cancelled. Resumes after `Last-Event-ID`."""
    _get_run(svc, run_id)
    start = int(last_event_id) if last_event_id and last_event_id.isdigit() else 0

    async def stream():
        seq = start
        idle = 0.0
        while True:
            events, ended = svc.runs.events_since(run_id, seq)
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

    return StreamingResponse(stream(), media_type="text/event-stream",
                             headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})


@router.get("/{run_id}/log", response_model=list[RunEvent])
def run_log(run_id: str, svc: ServicesDep, after: int = 0) -> list[dict]:
    """The run's events so far as one JSON list (the SSE stream's content, for scripts)."""
    _get_run(svc, run_id)
    return svc.runs.events_since(run_id, after)[0]


@router.get("/{run_id}/artifacts", response_model=list[ArtifactInfo])
def list_artifacts(run_id: str, svc: ServicesDep) -> list[ArtifactInfo]:
    _get_run(svc, run_id)
    d = svc.runs.run_dir(run_id)
    if not d.is_dir():
        return []
    return [ArtifactInfo(name=p.name, size=p.stat().st_size) for p in sorted(d.iterdir()) if p.is_file()]


@router.get("/{run_id}/artifacts/{name}", response_class=FileResponse)
def get_artifact(run_id: str, name: str, svc: ServicesDep) -> FileResponse:
    _get_run(svc, run_id)
    if not valid_file_name(name):
        raise HTTPException(400, detail={"message": f"invalid artifact name {name!r}"})
    p = svc.runs.run_dir(run_id) / name
    if not p.is_file():
        raise HTTPException(404, detail={"message": f"run {run_id} has no artifact {name!r}"})
    media = mimetypes.guess_type(name)[0] or "text/plain"
    if name.endswith((".gcode", ".src", ".dat", ".mod", ".csv")):
        media = "text/plain"
    return FileResponse(p, media_type=media, filename=name)


@router.delete("/{run_id}", status_code=202, response_model=RunStatus)
def cancel_run(run_id: str, svc: ServicesDep) -> RunStatus:
    """Cancel a queued or running run (finished runs are left as they are)."""
    _get_run(svc, run_id)
    svc.runs.cancel(run_id)
    return get_run(run_id, svc)
