"""The audit log: saves, deletes, uploads, runs and cancels, with who (the token's name) and when."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Query
from pydantic import BaseModel, Field

from ..deps import ServicesDep
from ..schemas import errors

router = APIRouter(tags=["audit"])

ACTIONS = ("save_graph", "delete_graph", "save_params", "upload_file", "run", "cancel_run")


class AuditEntry(BaseModel):
    id: int
    time: float = Field(description="Unix time, s")
    who: str | None = Field(description="name of the token used ('anonymous' on a server without tokens)")
    action: str = Field(description=", ".join(ACTIONS))
    target: str | None = Field(description="graph name")
    detail: dict[str, Any] | None


@router.get("/api/audit", response_model=list[AuditEntry], responses=errors(401, 422))
def audit_log(
    svc: ServicesDep,
    limit: int = Query(100, ge=1, le=1000),
    before: int | None = Query(None, ge=1, le=2**62, description="entries older than this id (paging)"),
    who: str | None = Query(None, max_length=64),
    action: str | None = Query(None, max_length=32),
) -> list[dict]:
    """Newest first."""
    return svc.store.list_audit(limit, before, who, action)
