"""The FastAPI application: REST under /api, the built GUI at /, viser started in the lifespan."""

from __future__ import annotations

import errno
import json
import logging
import re
import secrets
import sqlite3
from collections.abc import AsyncIterator, Callable, Sequence
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.middleware.cors import CORSMiddleware
from fastapi.openapi.utils import get_openapi
from fastapi.responses import JSONResponse, Response
from starlette.exceptions import HTTPException as StarletteHTTPException

from .. import __version__
from ..core.errors import PlanningError, RecipeError, WaamflowError
from ..settings import Settings
from .auth import AuthMiddleware, load_tokens, needs_auth
from .guards import (
    AuthThrottle,
    BodyLimitMiddleware,
    HostOriginMiddleware,
    ThrottleAuditMiddleware,
    is_loopback_host,
    store_auditor,
)
from .routes import audit, builds, graphs, health, nodes, preview, runs, viewer
from .schemas import ErrorResponse, error_body
from .services import build_services
from .static import CompressedAssets, index_response, mount_viewer_client
from .viewer_proxy import mount_viewer_proxy
from .worker import Limits, RunManager

log = logging.getLogger("waamflow.server")


def viewer_host(settings: Settings, tokens: dict) -> str:
    """viser has no authentication of its own: it listens on loopback only, whatever --host says, and
    browsers reach it through this server's /viewer/ proxy (token, role, Host and Origin checks)."""
    return "127.0.0.1"


def disk_full(err: BaseException) -> bool:
    """An OSError ENOSPC/EDQUOT or SQLite's 'database or disk is full'."""
    if isinstance(err, OSError) and err.errno in (errno.ENOSPC, errno.EDQUOT):
        return True
    return isinstance(err, sqlite3.OperationalError) and "full" in str(err).lower()


def allowed_hosts(settings: Settings, tokens: dict) -> set[str] | None:
    """Host names answered by a server without tokens (DNS-rebinding protection): loopback names,
    the address it listens on and `allowed_hosts`. None (any Host) once tokens are required."""
    if tokens:
        return None
    names = {h.lower() for h in settings.allowed_hosts}
    if not is_loopback_host(settings.host.lower()):
        names.add(settings.host.lower())
    return names


def _start_viewer(settings: Settings, host: str | None = None, proxy_secret: str | None = None):
    if not settings.start_viewer or not settings.viewer_port:
        return None
    try:
        from ..viewer.service import ViewerService
    except ImportError:
        log.warning("3D preview unavailable (waamflow.viewer not importable)")
        return None
    try:
        viewer = ViewerService(host=host or "127.0.0.1", port=settings.viewer_port, proxy_secret=proxy_secret)
        viewer.start()
        return viewer
    except Exception as e:  # a busy port must not keep the API from starting
        log.warning("3D preview not started: %s", e)
        return None


# OpenAPI links: which answer gives which later request its parameters (a saved graph's name,
# a run's id). Clients and schemathesis' stateful phase follow them: save → read/run/delete.
GRAPH = {"name": "$response.body#/name"}
RUN = {"run_id": "$response.body#/id"}
LINKS: dict[tuple[str, str], tuple[tuple[str, ...], dict[str, tuple[str, str, dict, dict | None]]]] = {
    ("put", "/api/graphs/{name}"): (
        ("200", "201"),
        {
            "GetGraph": ("get", "/api/graphs/{name}", GRAPH, None),
            "SaveGraphAgain": ("put", "/api/graphs/{name}", GRAPH, None),
            "DeleteGraph": ("delete", "/api/graphs/{name}", GRAPH, None),
            "GetParams": ("get", "/api/graphs/{name}/params", GRAPH, None),
            "PutParams": ("put", "/api/graphs/{name}/params", GRAPH, None),
            "ListFiles": ("get", "/api/graphs/{name}/files", GRAPH, None),
            "UploadFile": ("put", "/api/graphs/{name}/files/{filename}", GRAPH, None),
            "RunGraph": ("post", "/api/runs", {}, {"graph": "$response.body#/name"}),
        },
    ),
    ("get", "/api/graphs"): (
        ("200",),
        {
            "GetFirstGraph": ("get", "/api/graphs/{name}", {"name": "$response.body#/0/name"}, None),
            "DeleteFirstGraph": ("delete", "/api/graphs/{name}", {"name": "$response.body#/0/name"}, None),
            "RunFirstGraph": ("post", "/api/runs", {}, {"graph": "$response.body#/0/name"}),
        },
    ),
    ("post", "/api/runs"): (
        ("202",),
        {
            "GetRun": ("get", "/api/runs/{run_id}", RUN, None),
            "RunEvents": ("get", "/api/runs/{run_id}/events", RUN, None),
            "RunLog": ("get", "/api/runs/{run_id}/log", RUN, None),
            "ListArtifacts": ("get", "/api/runs/{run_id}/artifacts", RUN, None),
            "CancelRun": ("delete", "/api/runs/{run_id}", RUN, None),
        },
    ),
    ("get", "/api/runs"): (
        ("200",),
        {
            "GetFirstRun": ("get", "/api/runs/{run_id}", {"run_id": "$response.body#/0/id"}, None),
            "ListFirstRunArtifacts": ("get", "/api/runs/{run_id}/artifacts", {"run_id": "$response.body#/0/id"}, None),
        },
    ),
    ("get", "/api/runs/{run_id}/artifacts"): (
        ("200",),
        {
            "GetArtifact": (
                "get",
                "/api/runs/{run_id}/artifacts/{name}",
                {"run_id": "$request.path.run_id", "name": "$response.body#/0/name"},
                None,
            ),
        },
    ),
}


def add_links(schema: dict) -> None:
    paths = schema.get("paths", {})
    for (method, path), (statuses, links) in LINKS.items():
        responses = paths[path][method]["responses"]
        out = {}
        for name, (t_method, t_path, params, body) in links.items():
            link = {"operationId": paths[t_path][t_method]["operationId"]}
            if params:
                link["parameters"] = params
            if body is not None:
                link["requestBody"] = body
            out[name] = link
        for status in statuses:
            responses[status]["links"] = out


def allowed_methods(schema: dict, path: str) -> list[str]:
    """The methods the OpenAPI schema declares for the path a request went to (the `Allow` of a 405:
    exactly what the resource supports, RFC 9110 10.2.1; HEAD where a route answers it)."""
    for template, ops in schema.get("paths", {}).items():
        if re.fullmatch(re.sub(r"\\\{[^/]+?\\\}", "[^/]+", re.escape(template)), path):
            methods = {m.upper() for m in ops if m in ("get", "put", "post", "delete", "patch", "head", "options")}
            return sorted(methods)
    return []


ROUTERS = (
    health.router,
    nodes.router,
    graphs.router,
    runs.router,
    preview.router,
    viewer.router,
    audit.router,
    builds.router,
)


def create_app(settings: Settings | None = None) -> FastAPI:
    """The API: the services made in the lifespan, one error body for every failure, the routers,
    the OpenAPI schema with that error model, the guarding middleware, the viewer behind its proxy
    and the built GUI (when there is one)."""
    settings = settings or Settings()
    tokens = load_tokens(settings.token, settings.token_file)
    app = FastAPI(
        title="waamflow",
        version=__version__,
        lifespan=_lifespan(settings, tokens),
        description="Node-graph CAM for Wire + Arc Additive Manufacturing. Units: mm, s, deg.",
    )
    _add_error_handlers(app, settings)
    for r in ROUTERS:
        app.include_router(r)
    # FastAPI's documented way to change the schema: replace the app's `openapi` method
    app.openapi = _openapi(app, tokens)  # type: ignore[method-assign]
    _add_middleware(app, settings, tokens)
    # viser listens on loopback and admits only websockets carrying this secret: browsers reach it
    # through this origin's /viewer/ (under the API's auth, Host and Origin checks), never directly
    app.state.viewer_secret = secrets.token_urlsafe(32)
    mount_viewer_proxy(app)
    mount_viewer_client(app)  # viser's page under a content-hashed URL, cached like the hashed assets
    _serve_gui(app, settings.static_dir)  # last: its catch-all route must not shadow the others
    return app


# ---- lifecycle ----------------------------------------------------------------------------------
def _lifespan(settings: Settings, tokens: dict[str, str]) -> Callable[[FastAPI], AbstractAsyncContextManager[None]]:
    """Startup: the services (store, cache), the run manager, the 3D viewer; shutdown in reverse."""

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        svc = build_services(settings)
        if settings.start_workers:
            svc.runs = RunManager(
                svc.store,
                Path(settings.data_dir),
                svc.cache,
                settings.workers,
                svc.resolver_for,
                svc.after_run,
                Limits.from_settings(settings),
                layer_workers=settings.layer_workers,
                scheduler=settings.scheduler,
            )
        svc.viewer = _start_viewer(settings, viewer_host(settings, tokens), app.state.viewer_secret)
        if svc.viewer is not None:
            svc.viewer.loader = svc.scene_source  # a run made before a restart is rebuilt on demand
        svc.auth_required = bool(tokens)
        app.state.services = svc
        try:
            yield
        finally:
            if svc.runs is not None:
                svc.runs.shutdown()
            if svc.viewer is not None:
                try:
                    svc.viewer.stop()
                except Exception:
                    log.exception("viewer stop failed")
            svc.store.close()

    return lifespan


# ---- errors -------------------------------------------------------------------------------------
def error_response(status: int, detail: Any, headers: dict[str, str] | None = None) -> JSONResponse:
    """Every error the API answers: the ErrorResponse body (`error_body`) with its status."""
    return JSONResponse(status_code=status, content=error_body(status, detail), headers=headers)


def _disk_full(request: Request, data_dir: str | Path) -> JSONResponse:
    """507 after a write failed on a full disk; the disk reserve is released so deletes go through."""
    svc = getattr(request.app.state, "services", None)
    freed = svc.release_reserve() if svc is not None else 0
    log.error(
        "disk full under %s (%s %s); released %d bytes of reserve", data_dir, request.method, request.url.path, freed
    )
    return error_response(
        507,
        {
            "kind": "disk_full",
            "message": "the disk holding the data folder is full: nothing was saved. Free space (delete graphs, "
            "runs or uploads you no longer need: deletes still work) and try again",
        },
    )


def _validation_detail(errs: Sequence[Any]) -> dict[str, Any]:
    """A request FastAPI could not validate: its first error as the message and field, all of them listed."""
    first = errs[0] if errs else {"msg": "invalid request", "loc": ()}
    loc = ".".join(str(x) for x in first.get("loc", ()))
    msg = f"{first.get('msg')}" + (f" at '{loc}'" if loc else "")
    return {
        "kind": "invalid_request",
        "message": msg,
        "text": msg,
        "field": loc or None,
        "errors": [
            {"loc": [x if isinstance(x, int) else str(x) for x in e.get("loc", ())], "msg": str(e.get("msg"))}
            for e in errs
        ],
    }


def _add_error_handlers(app: FastAPI, settings: Settings) -> None:
    """Recipe and planning errors → 422, other WaamflowErrors → their status, a full disk → 507,
    HTTP errors and request validation → the same ErrorResponse body."""

    @app.exception_handler(RecipeError)
    async def _recipe_error(_: Request, err: RecipeError) -> JSONResponse:
        return error_response(422, err.to_dict())

    @app.exception_handler(PlanningError)
    async def _planning_error(_: Request, err: PlanningError) -> JSONResponse:
        return error_response(422, err.to_dict())

    @app.exception_handler(WaamflowError)
    async def _waamflow_error(_: Request, err: WaamflowError) -> JSONResponse:
        return error_response(getattr(err, "http_status", 400), err.to_dict(), getattr(err, "headers", None))

    @app.exception_handler(OSError)
    async def _os_error(request: Request, err: OSError) -> JSONResponse:
        if not disk_full(err):
            raise err
        return _disk_full(request, settings.data_dir)

    @app.exception_handler(sqlite3.OperationalError)
    async def _sqlite_error(request: Request, err: sqlite3.OperationalError) -> JSONResponse:
        if not disk_full(err):
            raise err
        return _disk_full(request, settings.data_dir)

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, err: StarletteHTTPException) -> JSONResponse:
        headers = dict(getattr(err, "headers", None) or {})
        # a string from Starlette, the error dict from FastAPI's HTTPException (its `detail: Any`)
        detail: str | dict[str, Any] = err.detail
        if err.status_code == 405:  # Allow: every method of the path, not only of the route tried first
            methods = allowed_methods(app.openapi(), request.url.path)
            headers["Allow"] = ", ".join(methods)
            detail = {"message": f"{request.method} is not allowed here; use {', '.join(methods)}"}
        if err.status_code == 400 and detail == "There was an error parsing the body":
            detail = {"message": "the request body is not valid JSON", "kind": "invalid_request"}
        return error_response(err.status_code, detail, headers or None)

    @app.exception_handler(RequestValidationError)
    async def _validation(_: Request, err: RequestValidationError) -> JSONResponse:
        return error_response(422, _validation_detail(err.errors()))


# ---- OpenAPI ------------------------------------------------------------------------------------
def _openapi(app: FastAPI, tokens: dict[str, str]) -> Callable[[], dict[str, Any]]:
    """The app's `openapi`: FastAPI's schema with one error model (every 4xx body is an
    ErrorResponse), every route behind the token declaring 401, and the links (`LINKS`)."""

    def openapi() -> dict[str, Any]:
        if app.openapi_schema:
            return app.openapi_schema
        schema = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
        _one_error_model(schema, tokens)
        add_links(schema)
        app.openapi_schema = schema
        return schema

    return openapi


def _one_error_model(schema: dict[str, Any], tokens: dict[str, str]) -> None:
    comps = schema.setdefault("components", {}).setdefault("schemas", {})
    for name, sub in (
        ErrorResponse.model_json_schema(ref_template="#/components/schemas/{model}").get("$defs", {}).items()
    ):
        comps.setdefault(name, sub)
    comps["ErrorResponse"] = {
        k: v
        for k, v in ErrorResponse.model_json_schema(ref_template="#/components/schemas/{model}").items()
        if k != "$defs"
    }
    comps.pop("HTTPValidationError", None)
    comps.pop("ValidationError", None)
    ref = {"application/json": {"schema": {"$ref": "#/components/schemas/ErrorResponse"}}}
    schema.setdefault("components", {})["securitySchemes"] = {
        "bearer": {
            "type": "http",
            "scheme": "bearer",
            "description": "WAAMFLOW_TOKEN or a token of --token-file (only when the server has tokens)",
        }
    }
    # a server with tokens requires one on every route behind the check; without tokens it is optional
    security: list[dict[str, list[str]]] = [{"bearer": []}] if tokens else [{"bearer": []}, {}]
    for path, ops in schema.get("paths", {}).items():
        for op in ops.values():
            responses = op.setdefault("responses", {})
            if needs_auth(path):
                responses.setdefault("401", {"description": "Missing or wrong bearer token"})
                op["security"] = security
            if "requestBody" in op and "application/json" in op["requestBody"].get("content", {}):
                responses.setdefault("400", {"description": "The request body is not valid JSON"})
            for code, resp in responses.items():
                if code.startswith("4") and "ConflictResponse" not in json.dumps(resp.get("content", {})):
                    resp["content"] = ref
                    if code == "422":
                        resp["description"] = "Invalid request, recipe or file"


# ---- middleware ---------------------------------------------------------------------------------
def _scope_store(scope: Any) -> Any:
    """The store of the app serving `scope` (None before the lifespan made the services)."""
    svc = getattr(scope["app"].state, "services", None)
    return getattr(svc, "store", None)


def _add_middleware(app: FastAPI, settings: Settings, tokens: dict[str, str]) -> None:
    """CORS (when configured), body limits, bearer tokens, the failed-auth throttle and its audit,
    Host/Origin checks. Added innermost first: a request meets them in the reverse order."""
    if settings.cors_origins:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=list(settings.cors_origins),
            allow_credentials=False,
            allow_methods=["GET", "PUT", "POST", "DELETE"],
            allow_headers=["Authorization", "Content-Type", "If-Match"],
            expose_headers=["ETag"],
        )
    app.add_middleware(
        BodyLimitMiddleware,
        body_limit=int(settings.max_body_mb * 2**20),
        upload_limit=int(settings.max_upload_mb * 2**20),
        timeout_s=settings.body_timeout_s,
    )
    app.add_middleware(AuthMiddleware, tokens=tokens)
    app.state.auth_throttle = AuthThrottle(settings.auth_failures_per_minute) if tokens else None
    app.add_middleware(ThrottleAuditMiddleware, throttle=app.state.auth_throttle, audit=store_auditor(_scope_store))
    app.add_middleware(
        HostOriginMiddleware, allowed_hosts=allowed_hosts(settings, tokens), cors_origins=set(settings.cors_origins)
    )


# ---- the GUI ------------------------------------------------------------------------------------
def _serve_gui(app: FastAPI, static: str | Path | None) -> None:
    """The built GUI at / (its hashed assets under /assets, any other path its index.html, for the
    client-side routes), or a note at / that the GUI is not built."""
    if static is not None and (Path(static) / "index.html").is_file():
        root = Path(static)
        app.mount("/assets", CompressedAssets(root / "assets"), name="assets")

        @app.get("/{path:path}", include_in_schema=False)
        def spa(path: str) -> Response:
            if path.startswith("api/"):
                return error_response(404, {"message": f"no route /{path}"})
            candidate = (root / path).resolve()
            if path and candidate.is_file() and candidate.is_relative_to(root.resolve()):
                return index_response(candidate)
            return index_response(root / "index.html")
    else:

        @app.get("/", include_in_schema=False)
        def no_gui() -> JSONResponse:
            return JSONResponse(
                {"message": "waamflow API is running; the GUI is not built (run `make run`).", "docs": "/docs"}
            )
