"""Saved graphs (recipes), their parameter XML and their files."""

from __future__ import annotations

import json
from typing import Annotated, Any

from fastapi import APIRouter, Body, Depends, Header, HTTPException, Query, Request, Response
from fastapi import Path as PathParam
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field

from ...core.errors import RecipeError
from ...engine.graph import build_graph
from ...engine.recipe import Recipe
from ..auth import DEFAULT_ROLE
from ..deps import ClientDep, FileName, GraphName, ServicesDep, UserDep
from ..schemas import ConflictResponse, error_body, errors
from ..services import parse_api_recipe
from ..store import RevisionConflict
from .concurrency import CONFLICT_409 as CONFLICT_409
from .concurrency import ETAG_HEADER as ETAG_HEADER
from .concurrency import FILE_ETAG as FILE_ETAG
from .concurrency import IfMatch as IfMatch
from .concurrency import OptionalHeader as OptionalHeader
from .concurrency import _conflict as _conflict
from .concurrency import _expected as _expected
from .concurrency import etag as etag


def _owned(request: Request) -> None:
    """Every change under /api/graphs/{name} (recipe, parameter XML, files, delete): an editor changes
    only the graphs it created, an admin any (#26 fault 7). A name not in use is the saver's; a
    shipped example is left to the routes' 409."""
    if request.method in ("GET", "HEAD", "OPTIONS"):
        return
    role = getattr(request.state, "role", DEFAULT_ROLE)
    name = request.path_params.get("name")
    if role == "admin" or not isinstance(name, str):
        return
    store = request.app.state.services.store
    if store.graph_revision(name) is None or store.is_example(name):
        return
    owner, user = store.graph_owner(name), getattr(request.state, "user", None)
    if owner is None or owner != user:
        whose = f"belongs to {owner!r}" if owner else "was saved before owners were recorded"
        raise HTTPException(
            403,
            detail={
                "kind": "forbidden",
                "message": f"graph {name!r} {whose}: role {role!r} "
                "changes only the graphs it created (an admin changes any; save yours "
                "under another name)",
            },
        )


def get_role(request: Request) -> str:
    return getattr(request.state, "role", DEFAULT_ROLE)


router = APIRouter(prefix="/api/graphs", tags=["graphs"], dependencies=[Depends(_owned)])


class ExampleError(BaseModel):
    file: str = Field(description="the file in the server's graphs folder")
    size: int = Field(description="its size, bytes (0 when it is not a regular file)")
    reason: str = Field(
        description="why it is not offered: over the recipe size limit (max_body_mb), not a "
        "regular file, not valid JSON, not a valid recipe"
    )


# a recipe's revision number: 1, 2, … (bounded: SQLite's integers are 64-bit)
Revision = Annotated[int, PathParam(ge=1, le=2**53, description="revision number (1 = the first save)")]


class GraphInfo(BaseModel):
    name: str
    description: str
    example: bool
    updated: float
    has_params: bool = Field(False, description="whether GET /api/graphs/{name}/params has a file to return")
    owner: str | None = Field(
        None,
        description="token name that created it (editors change only their own); "
        "null: a shipped example or saved before owners were recorded",
    )
    error: ExampleError | None = Field(
        None,
        description="a recipe of the server's graphs folder that could not be "
        "offered: its GET answers 422 with this reason",
    )


class SaveResult(BaseModel):
    name: str
    created: bool
    problems: list[dict[str, Any]]
    revision: int = Field(description="the saved revision (also the ETag header, quoted)")


class RevisionInfo(BaseModel):
    revision: int
    time: float
    user: str | None = Field(None, description="who saved it (token name; null without authentication)")


class FileInfo(BaseModel):
    name: str
    size: int
    updated: float
    sha256: str | None = Field(
        None,
        description="sha256 (hex) of the content the name points at now; a run "
        "request's `files` pins a name to one such content",
    )


class FileVersion(BaseModel):
    version: int = Field(description="1 for the first content uploaded under the name, then +1 per upload")
    sha256: str
    size: int
    time: float
    user: str | None = None


def _writable(svc, name: str) -> None:
    """Shipped examples are read-only: users keep their changes with "save as"."""
    if svc.store.is_example(name):
        raise HTTPException(
            409,
            detail={"message": f"{name!r} is a shipped example and read-only: save it under another name (save as)"},
        )


@router.get("", response_model=list[GraphInfo], responses=errors(401))
def list_graphs(svc: ServicesDep) -> list[GraphInfo]:
    """Saved graphs and examples, by name; recipes of the graphs folder that could not be loaded are
    listed too, with `error` (file, size, reason) so that nobody looks for them in vain."""
    out = [GraphInfo(**g) for g in svc.store.list_graphs()]
    saved = {g.name for g in out}
    for name, bad in svc.unloaded.items():
        if name not in saved:
            out.append(
                GraphInfo(
                    name=name,
                    description=f"not loaded: {bad['reason']}",
                    example=True,
                    updated=bad["updated"],
                    error=ExampleError(file=bad["file"], size=bad["size"], reason=bad["reason"]),
                )
            )
    return sorted(out, key=lambda g: g.name)


def _unloaded(svc, name: str) -> None:
    """422 for a recipe of the graphs folder that could not be loaded (named, with the reason)."""
    bad = svc.unloaded.get(name)
    if bad is not None and svc.store.graph_revision(name) is None:
        raise HTTPException(
            422,
            detail={
                "kind": "unloadable_example",
                "field": "name",
                "message": f"{name!r} (graphs folder file {bad['file']}, {bad['size']} bytes) was not "
                f"loaded: {bad['reason']}",
            },
        )


@router.get(
    "/{name}",
    response_model=Recipe,
    response_model_exclude_none=True,
    response_model_by_alias=True,
    responses={200: {"description": "The recipe", "headers": ETAG_HEADER}, **errors(401, 404, 422)},
)
def get_graph(name: GraphName, svc: ServicesDep, response: Response) -> dict[str, Any]:
    _unloaded(svc, name)
    recipe = svc.store.get_graph(name)
    rev = svc.store.graph_revision(name)
    if recipe is None or rev is None:
        raise HTTPException(404, detail={"message": f"no graph named {name!r}"})
    response.headers["ETag"] = etag(rev)
    return recipe


@router.put(
    "/{name}",
    response_model=SaveResult,
    responses={
        200: {"description": "Saved", "headers": ETAG_HEADER},
        201: {"model": SaveResult, "description": "Created", "headers": ETAG_HEADER},
        **errors(401, 403, 413, 422),
        **CONFLICT_409,
    },
    openapi_extra={
        "requestBody": {
            "required": True,
            "content": {"application/json": {"schema": {"$ref": "#/components/schemas/Recipe"}}},
        }
    },
)
def put_graph(
    name: GraphName,
    svc: ServicesDep,
    user: UserDep,
    client: ClientDep,
    response: Response,
    recipe: dict[str, Any] = Body(..., description="the recipe (format waamflow/1; older formats are migrated)"),
    if_match: OptionalHeader = IfMatch,
) -> Any:
    """Save a recipe. Schema errors → 422; a graph that is valid JSON but not yet runnable (e.g. an
    unconnected input while the user is still wiring) is saved and its problems are returned.
    With `If-Match` the save happens only on that revision, else 409 with `yours` (the body sent)
    and `theirs` (`{"revision", "recipe"}` as stored); without it the save is unconditional."""
    _writable(svc, name)
    parsed = parse_api_recipe(recipe)  # RecipeError → 422 via the app's handler
    parsed = parsed.model_copy(update={"name": name})
    problems: list[dict] = []
    try:
        build_graph(parsed)
    except RecipeError as err:
        problems.append(err.to_dict())
    try:
        created, rev = svc.store.put_graph(
            name, parsed.to_json(), user=user, expect=_expected(if_match, svc.store.graph_revision(name))
        )
    except RevisionConflict as err:
        return _conflict("recipe", name, recipe, err, "recipe")
    svc.store.audit(
        user, "save_graph", name, {"created": created, "nodes": len(parsed.nodes), "revision": rev, "client": client}
    )
    response.status_code = 201 if created else 200
    response.headers["ETag"] = etag(rev)
    return SaveResult(name=name, created=created, problems=problems, revision=rev)


@router.delete("/{name}", status_code=204, response_class=Response, responses=errors(401, 403, 404, 409, 422))
def delete_graph(name: GraphName, svc: ServicesDep, user: UserDep, client: ClientDep) -> Response:
    _writable(svc, name)
    if not svc.store.delete_graph(name):
        raise HTTPException(404, detail={"message": f"no graph named {name!r}"})
    svc.store.audit(user, "delete_graph", name, {"client": client})
    return Response(status_code=204)


@router.get(
    "/{name}/params",
    response_class=Response,
    responses={
        200: {"content": {"application/xml": {"schema": {"type": "string"}}}, "headers": ETAG_HEADER},
        **errors(401, 404, 422),
    },
)
def get_params(name: GraphName, svc: ServicesDep) -> Response:
    """The graph's zone-parameter XML (layer > section > zone) as last saved. A run never changes
    it: the run's merged XML (current geometry, every filled-in value kept) is the run artifact
    `<zone node>.params.xml`, saved here only by an explicit PUT."""
    if svc.store.get_graph(name) is None:
        raise HTTPException(404, detail={"message": f"no graph named {name!r}"})
    xml = svc.store.get_params_xml(name)
    if not xml:
        raise HTTPException(
            404, detail={"message": f"graph {name!r} has no parameter file yet: run it once to create the template"}
        )
    return Response(xml, media_type="application/xml", headers={"ETag": etag(svc.store.params_revision(name) or 1)})


@router.put(
    "/{name}/params",
    response_class=Response,
    status_code=204,
    responses={
        204: {"description": "Saved", "headers": ETAG_HEADER},
        **errors(400, 401, 403, 404, 413, 422),
        **CONFLICT_409,
    },
    openapi_extra={"requestBody": {"content": {"application/xml": {"schema": {"type": "string"}}}, "required": True}},
)
async def put_params(
    name: GraphName,
    svc: ServicesDep,
    user: UserDep,
    client: ClientDep,
    request: Request,
    if_match: OptionalHeader = IfMatch,
) -> Response:
    """Replace the graph's zone-parameter XML (validated: numbers, units, ranges). `If-Match` as
    for the recipe (the XML has its own revision); a 409's `theirs` is `{"revision", "xml"}`."""
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
    try:
        rev = svc.store.put_params_xml(
            name, text, user=user, expect=_expected(if_match, svc.store.params_revision(name))
        )
    except RevisionConflict as err:
        return _conflict("parameter file", name, text, err, "xml")
    svc.store.audit(user, "save_params", name, {"bytes": len(body), "revision": rev, "client": client})
    return Response(status_code=204, headers={"ETag": etag(rev)})


@router.get("/{name}/revisions", response_model=list[RevisionInfo], responses=errors(401, 404, 422))
def list_revisions(name: GraphName, svc: ServicesDep) -> list[RevisionInfo]:
    """The recipe's saved revisions, newest first (revision, time, user) — also of a deleted graph,
    whose revisions stay until an admin restores one (POST .../revisions/{rev}/restore)."""
    revs = svc.store.list_revisions(name)
    if not revs:
        raise HTTPException(404, detail={"message": f"no graph named {name!r} (and none deleted under that name)"})
    return [RevisionInfo(**r) for r in revs]


@router.get(
    "/{name}/revisions/{rev}",
    response_model=Recipe,
    response_model_exclude_none=True,
    response_model_by_alias=True,
    responses={
        200: {"description": "The recipe as saved in that revision", "headers": ETAG_HEADER},
        **errors(401, 404, 422),
    },
)
def get_revision(name: GraphName, rev: Revision, svc: ServicesDep, response: Response) -> dict[str, Any]:
    """One earlier revision of the recipe, also of a deleted graph (restore it by PUTting it back, or
    as an admin with POST .../restore)."""
    text = svc.store.get_revision(name, rev)
    if text is None:
        raise HTTPException(404, detail={"message": f"graph {name!r} has no revision {rev}"})
    response.headers["ETag"] = etag(rev)
    return json.loads(text)


@router.post(
    "/{name}/revisions/{rev}/restore",
    response_model=SaveResult,
    responses={
        200: {"description": "Restored as the graph's new revision", "headers": ETAG_HEADER},
        201: {"model": SaveResult, "description": "A deleted graph restored", "headers": ETAG_HEADER},
        **errors(401, 403, 404, 422),
        **CONFLICT_409,
    },
)
def restore_revision(
    name: GraphName,
    rev: Revision,
    svc: ServicesDep,
    user: UserDep,
    client: ClientDep,
    response: Response,
    role: str = Depends(get_role),
) -> Any:
    """Admins: put revision `rev` of the recipe back — over what was saved since (overwritten
    content) or as the graph again after a delete. It becomes a new revision (history only grows,
    nothing is lost, so no If-Match is needed). A deleted graph comes back with its owner, its whole
    recipe history and its parameter XML as last saved (with its history); its uploaded files were
    deleted with it (their space freed) and are named in `problems` (kind `not_restored`)."""
    if role != "admin":
        raise HTTPException(
            403,
            detail={"kind": "forbidden", "message": f"restoring a revision needs role 'admin' (this token: {role!r})"},
        )
    _writable(svc, name)
    text = svc.store.get_revision(name, rev)
    if text is None:
        raise HTTPException(404, detail={"message": f"graph {name!r} has no revision {rev}"})
    deleted = svc.store.deleted_info(name) if svc.store.graph_revision(name) is None else None
    # the owner is the deleted graph's (else: who saved `rev`, for graphs deleted before owners were kept)
    owner = (deleted or {}).get("owner") or next(
        (r["user"] for r in svc.store.list_revisions(name) if r["revision"] == rev), None
    )
    created, new = svc.store.put_graph(name, json.loads(text), user=user, owner=owner)
    problems: list[dict] = []
    if created:
        svc.store.reattach_params(name)  # the parameter XML as last saved, with its history
        if deleted and deleted["files"]:
            msg = (
                f"the files uploaded to {name!r} were deleted with it and are not restored: "
                f"{', '.join(deleted['files'])} (upload them again)"
            )
            problems.append({"kind": "not_restored", "message": msg, "text": msg})
    svc.store.audit(
        user, "restore_graph", name, {"from_revision": rev, "revision": new, "created": created, "client": client}
    )
    response.status_code = 201 if created else 200
    response.headers["ETag"] = etag(new)
    return SaveResult(name=name, created=created, problems=problems, revision=new)


@router.get("/{name}/files", response_model=list[FileInfo], responses=errors(401, 404, 422))
def list_files(name: GraphName, svc: ServicesDep) -> list[FileInfo]:
    if svc.store.get_graph(name) is None:
        raise HTTPException(404, detail={"message": f"no graph named {name!r}"})
    return [FileInfo(**f) for f in svc.store.list_files(name)]


@router.get(
    "/{name}/files/{filename}",
    response_class=Response,
    responses={
        200: {
            "content": {"application/octet-stream": {"schema": {"type": "string", "format": "binary"}}},
            "headers": FILE_ETAG,
        },
        **errors(401, 404, 422),
    },
)
def get_file(
    name: GraphName,
    filename: FileName,
    svc: ServicesDep,
    sha256: str | None = Query(
        None,
        pattern=r"^[0-9a-f]{64}$",
        description="one content the name held (GET .../versions); default: what it holds now",
    ),
) -> Response:
    """A file of the graph: what `filename` holds now, or the content `sha256` it held (the exact
    bytes a recipe pinned; e.g. to take them along when saving the recipe under another name)."""
    if svc.store.get_graph(name) is None:
        raise HTTPException(404, detail={"message": f"no graph named {name!r}"})
    versions = svc.store.list_file_versions(name, filename)
    want = sha256 or (versions[0]["sha256"] if versions else None)
    data = svc.store.get_file_content(name, want) if want and any(v["sha256"] == want for v in versions) else None
    if data is None:
        what = f"content sha256 {sha256[:12]}… of {filename!r}" if sha256 else f"file {filename!r}"
        raise HTTPException(404, detail={"message": f"graph {name!r} has no {what}"})
    return Response(data, media_type="application/octet-stream", headers={"ETag": f'"{want}"'})


@router.get("/{name}/files/{filename}/versions", response_model=list[FileVersion], responses=errors(401, 404, 422))
def list_file_versions(name: GraphName, filename: FileName, svc: ServicesDep) -> list[FileVersion]:
    """Every content uploaded under `filename`, newest first: each stays readable by its sha256, so a
    recipe that pinned it runs with exactly that content after a same-name upload."""
    if svc.store.get_graph(name) is None:
        raise HTTPException(404, detail={"message": f"no graph named {name!r}"})
    versions = svc.store.list_file_versions(name, filename)
    if not versions:
        raise HTTPException(404, detail={"message": f"graph {name!r} has no file {filename!r}"})
    return [FileVersion(**v) for v in versions]


@router.put(
    "/{name}/files/{filename}",
    status_code=204,
    response_class=Response,
    responses={
        204: {"description": "Stored; the name points at this content now", "headers": FILE_ETAG},
        **errors(400, 401, 404, 409, 413, 422),
        412: {
            "model": ConflictResponse,
            "description": "`If-None-Match: *` and the name exists (`detail.theirs` is its "
            "current {sha256, size}); nothing was stored",
        },
    },
    openapi_extra={
        "requestBody": {
            "content": {
                "application/octet-stream": {
                    "schema": {
                        "type": "string",
                        "format": "binary",
                        "minLength": 1,
                        "description": "the file's bytes (not empty; at most max_upload_mb)",
                    }
                }
            },
            "required": True,
        }
    },
)
async def put_file(
    name: GraphName,
    filename: FileName,
    svc: ServicesDep,
    user: UserDep,
    client: ClientDep,
    request: Request,
    if_none_match: str | None = Header(
        None,
        alias="If-None-Match",
        max_length=2000,
        description="`*`: store only if the graph has no file of this name "
        'yet; `"<sha256>"`: only if the name does not hold that '
        "content (else 412: ask before replacing)",
    ),
) -> Response:
    """Upload a file a node of this graph reads (mesh, sketch, DXF); nodes name it by `filename`.
    The content is stored under its sha256 (the `ETag`) and the name points at it; what the name
    pointed at before stays stored (GET .../versions), so a recipe pinned to it is unchanged."""
    if svc.store.get_graph(name) is None:
        raise HTTPException(404, detail={"message": f"no graph named {name!r}: save the graph first"})
    _writable(svc, name)
    limit = svc.settings.max_upload_mb * 1024 * 1024
    body = await request.body()
    if len(body) > limit:
        raise HTTPException(413, detail={"message": f"file larger than {svc.settings.max_upload_mb} MB"})
    if not body:
        raise HTTPException(400, detail={"message": "empty file"})
    if if_none_match is not None:
        have = next((f for f in svc.store.list_files(name) if f["name"] == filename), None)
        tags = {t.strip().removeprefix("W/").strip('"') for t in if_none_match.split(",")}
        if have is not None and ("*" in tags or have["sha256"] in tags):
            body412 = error_body(
                412,
                {
                    "message": f"graph {name!r} already has a file {filename!r}: replace it (PUT "
                    "without If-None-Match), keep both (another name) or cancel",
                    "kind": "conflict",
                },
            )
            body412["detail"].update(
                {"yours": {"size": len(body)}, "theirs": {"sha256": have["sha256"], "size": have["size"]}}
            )
            return JSONResponse(status_code=412, content=body412, headers={"ETag": f'"{have["sha256"]}"'})
    stored = svc.store.put_file(name, filename, body, user=user)
    svc.store.audit(
        user,
        "upload_file",
        name,
        {
            "file": filename,
            "bytes": len(body),
            "sha256": stored["sha256"],
            "version": stored["version"],
            "replaced": stored["previous"],
            "client": client,
        },
    )
    return Response(status_code=204, headers={"ETag": f'"{stored["sha256"]}"'})
