"""The FastAPI application: REST under /api, the built GUI at /, viser started in the lifespan."""

from __future__ import annotations

import logging
from contextlib import asynccontextmanager
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

from .. import __version__
from ..core.errors import PlanningError, RecipeError, WaamflowError
from ..settings import Settings
from .routes import graphs, health, nodes, preview, runs, viewer
from .services import build_services
from .static import CompressedAssets, index_response
from .worker import RunManager

log = logging.getLogger("waamflow.server")


def _start_viewer(settings: Settings):
    if not settings.start_viewer or not settings.viewer_port:
        return None
    try:
        from ..viewer.service import ViewerService
    except ImportError:
        log.warning("3D preview unavailable (waamflow.viewer not importable)")
        return None
    try:
        viewer = ViewerService(host=settings.host, port=settings.viewer_port)
        viewer.start()
        return viewer
    except Exception as e:  # a busy port must not keep the API from starting
        log.warning("3D preview not started: %s", e)
        return None


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        svc = build_services(settings)
        if settings.start_workers:
            svc.runs = RunManager(svc.store, Path(settings.data_dir), svc.cache, settings.workers,
                                  svc.resolver_for, svc.after_run)
        svc.viewer = _start_viewer(settings)
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

    app = FastAPI(title="waamflow", version=__version__, lifespan=lifespan,
                  description="Node-graph CAM for Wire + Arc Additive Manufacturing. Units: mm, s, deg.")

    @app.exception_handler(RecipeError)
    async def _recipe_error(_: Request, err: RecipeError):
        return JSONResponse(status_code=422, content={"detail": err.to_dict()})

    @app.exception_handler(PlanningError)
    async def _planning_error(_: Request, err: PlanningError):
        return JSONResponse(status_code=422, content={"detail": err.to_dict()})

    @app.exception_handler(WaamflowError)
    async def _waamflow_error(_: Request, err: WaamflowError):
        return JSONResponse(status_code=400, content={"detail": err.to_dict()})

    @app.exception_handler(RequestValidationError)
    async def _validation(_: Request, err: RequestValidationError):
        errs = err.errors()
        first = errs[0] if errs else {"msg": "invalid request", "loc": ()}
        loc = ".".join(str(x) for x in first.get("loc", ()))
        msg = f"{first.get('msg')}" + (f" at '{loc}'" if loc else "")
        return JSONResponse(status_code=422, content={"detail": {"message": msg, "text": msg, "errors": [
            {"loc": list(e.get("loc", ())), "msg": e.get("msg")} for e in errs]}})

    for r in (health.router, nodes.router, graphs.router, runs.router, preview.router, viewer.router):
        app.include_router(r)

    static = settings.static_dir
    if static is not None and (Path(static) / "index.html").is_file():
        app.mount("/assets", CompressedAssets(Path(static) / "assets"), name="assets")

        @app.get("/{path:path}", include_in_schema=False)
        def spa(path: str):
            if path.startswith("api/"):
                return JSONResponse(status_code=404, content={"detail": {"message": f"no route /{path}"}})
            candidate = (Path(static) / path).resolve()
            if path and candidate.is_file() and candidate.is_relative_to(Path(static).resolve()):
                return index_response(candidate)
            return index_response(Path(static) / "index.html")
    else:
        @app.get("/", include_in_schema=False)
        def no_gui():
            return JSONResponse({"message": "waamflow API is running; the GUI is not built (run `make run`).",
                                 "docs": "/docs"})

    return app
