"""FastAPI dependencies as `Annotated` aliases (FastAPI full-stack template style).

Names in paths carry their pattern in the OpenAPI schema, so a schema-valid name is accepted and
anything else is a 422 before a handler runs."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Path, Request

from .services import Services
from .store import FILE_NAME_PATTERN, GRAPH_NAME_PATTERN, RUN_ID_PATTERN


def get_services(request: Request) -> Services:
    return request.app.state.services


def get_user(request: Request) -> str | None:
    """Name of the token the request came with ("anonymous" when the server has no tokens)."""
    return getattr(request.state, "user", None)


def get_client(request: Request) -> str | None:
    """The client's address: the audit log's "from where" (the proxy's when behind one)."""
    return request.client.host if request.client else None


ServicesDep = Annotated[Services, Depends(get_services)]
UserDep = Annotated[str | None, Depends(get_user)]
ClientDep = Annotated[str | None, Depends(get_client)]

GraphName = Annotated[
    str,
    Path(
        pattern=GRAPH_NAME_PATTERN,
        min_length=1,
        max_length=80,
        examples=["rectangle-study"],
        description="graph name: letters, digits, space, _ . - (no '..'); ≤ 80 chars",
    ),
]
FileName = Annotated[
    str,
    Path(
        pattern=FILE_NAME_PATTERN,
        min_length=1,
        max_length=120,
        description="file name: letters, digits, _ . - (no '..'); ≤ 120 chars",
    ),
]
RunId = Annotated[str, Path(pattern=RUN_ID_PATTERN, description="run id (letters and digits)")]
ArtifactName = Annotated[
    str, Path(pattern=FILE_NAME_PATTERN, min_length=1, max_length=120, description="artifact file name")
]
