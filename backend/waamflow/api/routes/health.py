from __future__ import annotations

from fastapi import APIRouter
from pydantic import BaseModel

from ... import __version__
from ..deps import ServicesDep

router = APIRouter(tags=["health"])


class Health(BaseModel):
    status: str
    version: str
    viewer_url: str | None
    workers: int


@router.get("/api/health", response_model=Health)
def health(svc: ServicesDep) -> Health:
    url = getattr(svc.viewer, "url", None) if svc.viewer is not None else None
    return Health(status="ok", version=__version__, viewer_url=url, workers=svc.settings.workers)
