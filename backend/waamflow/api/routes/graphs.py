"""Saved graphs (recipes), their parameter XML and their files."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Body, HTTPException, Request, Response
from pydantic import BaseModel, Field

from ...core.errors import RecipeError
from ...engine.graph import build_graph
from ...engine.recipe import Recipe
from ..services import parse_api_recipe
from ..deps import FileName, GraphName, ServicesDep, UserDep
from ..schemas import errors

router = APIRouter(prefix="/api/graphs", tags=["graphs"])


class GraphInfo(BaseModel):
    name: str
    description: str
    example: bool
    updated: float
    has_params: bool = Field(False, description="whether GET /api/graphs/{name}/params has a file to return")


class SaveResult(BaseModel):
    name: str
    created: bool
    problems: list[dict[str, Any]]


class FileInfo(BaseModel):
    name: str
    size: int
    updated: float


def _writable(svc, name: str) -> None:
    """Shipped examples are read-only: users keep their changes with "save as"."""
    if svc.store.is_example(name):
        raise HTTPException(409, detail={"message": f"{name!r} is a shipped example and read-only: "
                                                    "save it under another name (save as)"})


@router.get("", response_model=list[GraphInfo], responses=errors(401))
def list_graphs(svc: ServicesDep) -> list[GraphInfo]:
    return [GraphInfo(**g) for g in svc.store.list_graphs()]


@router.get("/{name}", response_model=Recipe, response_model_exclude_none=True, response_model_by_alias=True,
            responses=errors(401, 404, 422))
def get_graph(name: GraphName, svc: ServicesDep) -> dict[str, Any]:
    recipe = svc.store.get_graph(name)
    if recipe is None:
        raise HTTPException(404, detail={"message": f"no graph named {name!r}"})
    return recipe


@router.put("/{name}", response_model=SaveResult, responses={201: {"model": SaveResult, "description": "Created"},
                                                                **errors(401, 409, 413, 422)},
            openapi_extra={"requestBody": {"required": True, "content": {"application/json": {
                "schema": {"$ref": "#/components/schemas/Recipe"}}}}})
def put_graph(name: GraphName, svc: ServicesDep, user: UserDep, response: Response,
              recipe: dict[str, Any] = Body(..., description="the recipe (format waamflow/1; older formats are migrated)")) -> SaveResult:
    """Save a recipe. Schema errors → 422; a graph that is valid JSON but not yet runnable (e.g. an
    unconnected input while the user is still wiring) is saved and its problems are returned."""
    _writable(svc, name)
    parsed = parse_api_recipe(recipe)  # RecipeError → 422 via the app's handler
    parsed = parsed.model_copy(update={"name": name})
    problems: list[dict] = []
    try:
        build_graph(parsed)
    except RecipeError as err:
        problems.append(err.to_dict())
    created = svc.store.put_graph(name, parsed.to_json())
    svc.store.audit(user, "save_graph", name, {"created": created, "nodes": len(parsed.nodes)})
    response.status_code = 201 if created else 200
    return SaveResult(name=name, created=created, problems=problems)


@router.delete("/{name}", status_code=204, response_class=Response, responses=errors(401, 404, 409, 422))
def delete_graph(name: GraphName, svc: ServicesDep, user: UserDep) -> Response:
    _writable(svc, name)
    if not svc.store.delete_graph(name):
        raise HTTPException(404, detail={"message": f"no graph named {name!r}"})
    svc.store.audit(user, "delete_graph", name)
    return Response(status_code=204)


@router.get("/{name}/params", response_class=Response,
            responses={200: {"content": {"application/xml": {"schema": {"type": "string"}}}}, **errors(401, 404, 422)})
def get_params(name: GraphName, svc: ServicesDep) -> Response:
    """The graph's zone-parameter XML (layer > section > zone) as last saved. A run never changes
    it: the run's merged XML (current geometry, every filled-in value kept) is the run artifact
    `<zone node>.params.xml`, saved here only by an explicit PUT."""
    if svc.store.get_graph(name) is None:
        raise HTTPException(404, detail={"message": f"no graph named {name!r}"})
    xml = svc.store.get_params_xml(name)
    if not xml:
        raise HTTPException(404, detail={"message": f"graph {name!r} has no parameter file yet: run it once to create the template"})
    return Response(xml, media_type="application/xml")


@router.put("/{name}/params", response_class=Response, status_code=204, responses=errors(400, 401, 404, 409, 413, 422),
            openapi_extra={"requestBody": {"content": {"application/xml": {"schema": {"type": "string"}}}, "required": True}})
async def put_params(name: GraphName, svc: ServicesDep, user: UserDep, request: Request) -> Response:
    """Replace the graph's zone-parameter XML (validated: numbers, units, ranges)."""
    if svc.store.get_graph(name) is None:
        raise HTTPException(404, detail={"message": f"no graph named {name!r}"})
    _writable(svc, name)
    body = await request.body()
    if len(body) > 20_000_000:
        raise HTTPException(413, detail={"message": "parameter file larger than 20 MB"})
    try:
        text = body.decode("utf-8")
    except UnicodeDecodeError:
        raise HTTPException(400, detail={"message": "parameter file is not UTF-8 text"}) from None
    from ...zoning.params_xml import validate_xml

    validate_xml(text)  # RecipeError (naming layer/section/zone) → 422
    svc.store.put_params_xml(name, text)
    svc.store.audit(user, "save_params", name, {"bytes": len(body)})
    return Response(status_code=204)


@router.get("/{name}/files", response_model=list[FileInfo], responses=errors(401, 404, 422))
def list_files(name: GraphName, svc: ServicesDep) -> list[FileInfo]:
    if svc.store.get_graph(name) is None:
        raise HTTPException(404, detail={"message": f"no graph named {name!r}"})
    return [FileInfo(**f) for f in svc.store.list_files(name)]


@router.put("/{name}/files/{filename}", status_code=204, response_class=Response,
            responses=errors(400, 401, 404, 409, 413, 422),
            openapi_extra={"requestBody": {"content": {"application/octet-stream": {"schema": {
                "type": "string", "format": "binary", "minLength": 1,
                "description": "the file's bytes (not empty; at most max_upload_mb)"}}}, "required": True}})
async def put_file(name: GraphName, filename: FileName, svc: ServicesDep, user: UserDep, request: Request) -> Response:
    """Upload a file a node of this graph reads (mesh, sketch, DXF); nodes name it by `filename`."""
    if svc.store.get_graph(name) is None:
        raise HTTPException(404, detail={"message": f"no graph named {name!r}: save the graph first"})
    _writable(svc, name)
    limit = svc.settings.max_upload_mb * 1024 * 1024
    body = await request.body()
    if len(body) > limit:
        raise HTTPException(413, detail={"message": f"file larger than {svc.settings.max_upload_mb} MB"})
    if not body:
        raise HTTPException(400, detail={"message": "empty file"})
    svc.store.put_file(name, filename, body)
    svc.store.audit(user, "upload_file", name, {"file": filename, "bytes": len(body)})
    return Response(status_code=204)
