from __future__ import annotations

from fastapi import APIRouter, Request
from pydantic import BaseModel, Field

from ... import __version__
from ..deps import ServicesDep

router = APIRouter(tags=["health"])


class Health(BaseModel):
    status: str
    version: str
    viewer_url: str | None
    viewer_port: int | None
    workers: int
    auth_required: bool = Field(description="the other routes need 'Authorization: Bearer <token>'")
    viewer_page: str | None = Field(
        None,
        description="viser's client page on this origin under a content-hashed "
        "URL (cached for a year); open it with `?websocket=<viewer websocket URL>`",
    )


@router.get("/api/health", response_model=Health)
def health(svc: ServicesDep, request: Request) -> Health:
    url = getattr(svc.viewer, "url", None) if svc.viewer is not None else None
    port = getattr(svc.viewer, "bound_port", None) if svc.viewer is not None else None
    if port is not None:
        # viser listens on loopback only; the GUI reaches it through /viewer/ (same origin, same auth)
        url, port = "/viewer/", None
    port_or_url = port is not None or url is not None
    # viewer_port stays None (kept for older clients): the 3D preview is served only at viewer_url
    return Health(
        status="ok",
        version=__version__,
        viewer_url=url,
        viewer_port=port,
        workers=svc.settings.workers,
        auth_required=svc.auth_required,
        viewer_page=page.url if port_or_url and (page := getattr(request.app.state, "viewer_client", None)) else None,
    )
