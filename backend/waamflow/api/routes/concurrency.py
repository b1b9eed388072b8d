"""Optimistic concurrency of saved graphs and their parameter XML (#25): GET answers the stored
revision as a strong ETag (`etag`, `ETAG_HEADER`); a PUT that sends If-Match (`IfMatch`) saves
only when it is still the stored revision (`_expected`), else 409 with both versions
(`_conflict`, `CONFLICT_409`). A PUT without If-Match saves unconditionally (scripts, the CLI,
older clients). Files answer their content's sha256 as ETag (`FILE_ETAG`).

Split from `api.routes.graphs` (issue 27), which holds the routes; every name stays importable
from there.
"""

from __future__ import annotations

from typing import Any

from fastapi import Header
from fastapi.responses import JSONResponse

from ..schemas import ConflictResponse, error_body
from ..store import RevisionConflict


# Optimistic concurrency (#25): GET answers the stored revision as a strong ETag; a PUT that sends
# If-Match saves only when it is still the stored revision, else 409 with both versions. A PUT
# without If-Match saves unconditionally (scripts, the CLI, older clients).
ETAG_HEADER = {
    "ETag": {
        "description": 'the stored revision, a strong entity tag: `"<revision>"`',
        "schema": {"type": "string", "pattern": '^"[0-9]+"$'},
    }
}


# an optional header is a string when sent: typed `str` (default None), its schema is not nullable,
# so no client (nor schemathesis) sends the text "null" as a valid If-Match
OptionalHeader = str


IfMatch = Header(
    None,
    alias="If-Match",
    pattern=r'^\s*(\*|(W/)?"[^"]*"(\s*,\s*(W/)?"[^"]*")*)\s*$',
    description='the ETag (revision) the client loaded, e.g. `"3"`: the save happens only when it is '
    "still the stored revision, else 409 with both versions. `*`: any stored revision. "
    "Without it the PUT saves unconditionally.",
)


CONFLICT_409: dict[int | str, dict[str, Any]] = {
    409: {
        "model": ConflictResponse,
        "description": "Conflict: a read-only example, or the stored revision is no longer the "
        "If-Match one (`detail.yours` / `detail.theirs` hold both versions)",
    }
}


def etag(revision: int) -> str:
    return f'"{revision}"'


def _expected(if_match: str | None, current: int | None) -> int | None:
    """The revision an If-Match asks for: None = no condition; -1 = one that never matches.
    Weak tags never match (strong comparison, RFC 9110 13.1.1)."""
    if if_match is None:
        return None
    tags = [t.strip() for t in if_match.split(",")]
    if "*" in tags:
        return current if current is not None else -1
    for t in tags:
        if (
            t.startswith('"')
            and t.endswith('"')
            and t[1:-1].isdigit()
            and current is not None
            and int(t[1:-1]) == current
        ):
            return current
    return -1


def _conflict(what: str, name: str, yours: Any, err: RevisionConflict, key: str) -> JSONResponse:
    if err.current is None:
        msg = f"{name!r} was deleted since you opened it"
        theirs = None
    else:
        msg = (
            f"Someone saved this {what} since you opened it: {name!r} is now at revision {err.current}. "
            "Reload theirs, overwrite (If-Match their revision) or save under another name."
        )
        theirs = {"revision": err.current, key: err.content}
    body = error_body(409, {"message": msg, "kind": "conflict"})
    body["detail"].update({"yours": yours, "theirs": theirs})
    return JSONResponse(
        status_code=409, content=body, headers={"ETag": etag(err.current)} if err.current is not None else None
    )


FILE_ETAG = {
    "ETag": {
        "description": 'the stored content\'s sha256 (hex), quoted: `"<sha256>"`',
        "schema": {"type": "string", "pattern": '^"[0-9a-f]{64}"$'},
    }
}
