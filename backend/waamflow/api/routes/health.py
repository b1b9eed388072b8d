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


@router.get("/api/health", response_model=Health)
def health(svc: ServicesDep, request: Request) -> Health:
    url = getattr(svc.viewer, "url", None) if svc.viewer is not None else None
    port = getattr(svc.viewer, "bound_port", None) if svc.viewer is not None else None
    client = request.client.host if request.client else ""
    if svc.auth_required and client not in ("127.0.0.1", "::1", "localhost", "testclient"):
        # with tokens the viewer (no auth of its own) listens on loopback only: not reachable from there
        url = port = None
    # viewer_port lets a browser on another host build the URL from its own location.hostname
    return Health(status="ok", version=__version__, viewer_url=url, viewer_port=port, workers=svc.settings.workers,
                  auth_required=svc.auth_required)
