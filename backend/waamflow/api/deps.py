"""FastAPI dependencies as `Annotated` aliases (FastAPI full-stack template style)."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, HTTPException, Path, Request

from .services import Services
from .store import valid_file_name, valid_graph_name


def get_services(request: Request) -> Services:
    return request.app.state.services


ServicesDep = Annotated[Services, Depends(get_services)]


def graph_name(name: Annotated[str, Path(description="graph name: letters, digits, space, _ . -; ≤ 80 chars")]) -> str:
    if not valid_graph_name(name):
        raise HTTPException(400, detail={"message": f"invalid graph name {name!r}: use letters, digits, space, _ . - (≤ 80 chars)"})
    return name


def file_name(filename: str) -> str:
    if not valid_file_name(filename):
        raise HTTPException(400, detail={"message": f"invalid file name {filename!r}"})
    return filename


GraphName = Annotated[str, Depends(graph_name)]
FileName = Annotated[str, Depends(file_name)]
