"""Bearer-token authentication for the API and the 3D viewer.

Tokens come from `WAAMFLOW_TOKEN` (one token, named "default") and/or a token file
(`--token-file` / `WAAMFLOW_TOKEN_FILE`): either a JSON object `{"name": "token", ...}` or lines
`name:token` (blank lines and `#` comments ignored). With at least one token configured every
`/api` route except `/api/health` needs `Authorization: Bearer <token>`; the caller's token name is
the "who" of the audit log. GET requests (an `EventSource`, an artifact link) may carry the token
in the `waamflow_token` session cookie the GUI sets, since a browser cannot add a header to them;
requests that change anything need the header.

Roles (#26 fault 7): each token has one — `viewer` (reads: graphs, runs, artifacts, the 3D view),
`operator` (+ starts, previews and cancels runs), `editor` (+ saves, uploads and deletes the graphs
it created), `admin` (everything: any graph, restoring deleted or overwritten revisions, the audit
log). A token file line `name:token:role` or a JSON entry `{"name": {"token": "...", "role":
"editor"}}` sets it; a token without one (`name:token`, `{"name": "token"}`, WAAMFLOW_TOKEN — every
file written before roles) is `admin`, so existing set-ups keep working. Without tokens the one
local user is `admin`. A request beyond the role's rights → 403 naming the role and what it needs.
"""

from __future__ import annotations

import hmac
import json
import re
from pathlib import Path
from typing import Any

from ..core.errors import WaamflowError

COOKIE = "waamflow_token"
TOKEN_NAME = re.compile(r"^[A-Za-z0-9_.@-]{1,64}$")
MIN_TOKEN_LENGTH = 16
# a token is refused when it has fewer distinct characters than this: 16 × 'a' passes the length
# rule but is guessed at once (`secrets.token_urlsafe(32)` has ~30 distinct of 43)
MIN_DISTINCT_CHARS = 8
OPEN_PATHS = ("/api/health",)
ROLES = ("viewer", "operator", "editor", "admin")  # each may do what those before it may
DEFAULT_ROLE = "admin"  # a token with no role (token files written before roles) keeps every right
# what an operator may change besides reading: run, preview, cancel, and the machine side of an
# as-built build (start one, upload a layer's scan); a viewer only moves the 3D view
OPERATOR_WRITES = (
    ("POST", re.compile(r"^/api/runs/?$")),
    ("DELETE", re.compile(r"^/api/runs/[^/]+/?$")),
    ("POST", re.compile(r"^/api/preview/?$")),
    ("POST", re.compile(r"^/api/builds/?$")),
    ("POST", re.compile(r"^/api/builds/[^/]+/scans/?$")),
)
VIEWER_WRITES = (("POST", re.compile(r"^/api/viewer/(select|view)/?$")),)
SAFE_METHODS = ("GET", "HEAD", "OPTIONS")


class Tokens(dict[str, str]):
    """name → token (a plain dict for every existing use), plus `roles`: name → role."""

    def __init__(self, *args: Any, roles: dict[str, str] | None = None, **kw: str) -> None:
        super().__init__(*args, **kw)
        self.roles: dict[str, str] = dict(roles or {})

    def role(self, name: str | None) -> str:
        return self.roles.get(name or "", DEFAULT_ROLE)


def role_of(tokens: dict[str, str], name: str | None) -> str:
    return tokens.role(name) if isinstance(tokens, Tokens) else DEFAULT_ROLE


def at_least(role: str | None, needed: str) -> bool:
    return ROLES.index(role if role in ROLES else DEFAULT_ROLE) >= ROLES.index(needed)


ADMIN_ONLY = re.compile(r"^/api/audit(/.*)?$")  # who did what, from where: for admins


def method_allowed(role: str, method: str, path: str) -> str | None:
    """None when `role` may send `method` to `path`, else the role that may (the coarse rule every
    route gets; ownership of graphs is checked by the graph routes)."""
    if ADMIN_ONLY.match(path):
        return None if role == "admin" else "admin"
    if role in ("editor", "admin") or method in SAFE_METHODS:
        return None
    if any(m == method and rx.match(path) for m, rx in VIEWER_WRITES):
        return None
    if role == "operator" and any(m == method and rx.match(path) for m, rx in OPERATOR_WRITES):
        return None
    return "operator" if any(m == method and rx.match(path) for m, rx in OPERATOR_WRITES) else "editor"


class TokenFileError(WaamflowError):
    exit_code = 2
    kind = "invalid_config"


def parse_tokens(text: str, source: str = "token file") -> Tokens:
    """name → token from a token file's text (JSON object or `name:token` lines)."""
    stripped = text.strip()
    pairs: list[tuple[str, object, object]] = []  # (name, token, role or None)
    if stripped.startswith("{"):
        try:
            data = json.loads(stripped)
        except json.JSONDecodeError as e:
            raise TokenFileError(f"{source}: invalid JSON ({e})") from None
        for k, v in data.items():
            if isinstance(v, dict):  # {"name": {"token": "...", "role": "editor"}}
                extra = sorted(set(v) - {"token", "role"})
                if extra:
                    raise TokenFileError(f"{source}: token {k!r} has unknown fields {extra} (token, role)")
                pairs.append((str(k), v.get("token"), v.get("role")))
            else:
                pairs.append((str(k), v, None))
    else:
        for i, line in enumerate(text.splitlines(), 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            parts = line.split(":")
            if len(parts) not in (2, 3):
                raise TokenFileError(f"{source} line {i}: expected 'name:token' or 'name:token:role'")
            pairs.append((parts[0].strip(), parts[1].strip(), parts[2].strip() if len(parts) == 3 else None))
    out = Tokens()
    for name, token, role in pairs:
        if not TOKEN_NAME.match(name):
            raise TokenFileError(f"{source}: invalid token name {name!r} (letters, digits, _ . @ -; ≤ 64 chars)")
        token = check_token(token, f"{source}: token {name!r}")
        if name in out:
            raise TokenFileError(f"{source}: token name {name!r} appears twice")
        if role is not None and (not isinstance(role, str) or role not in ROLES):
            raise TokenFileError(f"{source}: token {name!r} has role {role!r}; roles: {', '.join(ROLES)}")
        out[name] = token
        out.roles[name] = role or DEFAULT_ROLE
    if not out:
        raise TokenFileError(f"{source}: no tokens")
    return out


def check_token(token: object, what: str) -> str:
    """`token` when it is a usable token (a string, long and varied enough), else TokenFileError."""
    if not isinstance(token, str) or len(token) < MIN_TOKEN_LENGTH or any(c.isspace() for c in token) or ":" in token:
        raise TokenFileError(
            f"{what} must be a string of at least {MIN_TOKEN_LENGTH} characters without "
            "spaces or ':' (e.g. `python -c 'import secrets; print(secrets.token_urlsafe(32))'`)"
        )
    distinct = len(set(token))
    if distinct < MIN_DISTINCT_CHARS:
        raise TokenFileError(
            f"{what} is too weak: {'one character repeated' if distinct == 1 else f'{distinct} distinct characters'}"
            f" (at least {MIN_DISTINCT_CHARS} distinct needed); make one with "
            "`python -c 'import secrets; print(secrets.token_urlsafe(32))'`"
        )
    return token


def load_tokens(token: str | None, token_file: str | Path | None) -> Tokens:
    tokens = Tokens()
    if token_file:
        p = Path(token_file)
        try:
            mode = p.stat().st_mode
            if mode & 0o006:  # other users could read the tokens, or add their own
                what = "readable and writable" if mode & 0o006 == 0o006 else "readable" if mode & 0o004 else "writable"
                raise TokenFileError(
                    f"token file {p} is {what} by every user (mode {mode & 0o777:04o}): "
                    f"run `chmod 600 {p}` (or 640 for a group) and start again"
                )
            text = p.read_text(encoding="utf-8")
        except OSError as e:
            raise TokenFileError(f"cannot read token file {p}: {e.strerror}") from None
        parsed = parse_tokens(text, str(p))
        tokens.update(parsed)
        tokens.roles.update(parsed.roles)
    if token:
        check_token(token, "WAAMFLOW_TOKEN")
        tokens.setdefault("default", token)
        tokens.roles.setdefault("default", DEFAULT_ROLE)
    return tokens


def match_token(tokens: dict[str, str], presented: str | None) -> str | None:
    """The name of the token `presented` equals (constant-time comparison against every token)."""
    if not presented:
        return None
    found = None
    given = presented.encode("utf-8", "replace")
    for name, token in tokens.items():
        if hmac.compare_digest(given, token.encode("utf-8")) and found is None:
            found = name
    return found


def _bearer(headers: dict[bytes, bytes]) -> str | None:
    value = headers.get(b"authorization", b"").decode("latin-1")
    scheme, _, cred = value.partition(" ")
    return cred.strip() if scheme.lower() == "bearer" else None


def _cookie(headers: dict[bytes, bytes]) -> str | None:
    for part in headers.get(b"cookie", b"").decode("latin-1").split(";"):
        k, _, v = part.strip().partition("=")
        if k == COOKIE:
            return v
    return None


def needs_auth(path: str) -> bool:
    return (path.startswith("/api/") or path == "/api" or path.startswith("/viewer")) and path not in OPEN_PATHS


async def _forbidden(send, user: str, role: str, needed: str) -> None:
    msg = f"token {user!r} has role {role!r}: this needs {needed} or above (roles: {', '.join(ROLES)})"
    body = json.dumps(
        {
            "detail": {
                "kind": "forbidden",
                "message": msg,
                "text": msg,
                "node": None,
                "layer": None,
                "section": None,
                "field": None,
            }
        }
    ).encode()
    await send(
        {
            "type": "http.response.start",
            "status": 403,
            "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())],
        }
    )
    await send({"type": "http.response.body", "body": body})


class AuthMiddleware:
    """ASGI middleware: http and websocket requests to protected paths need a known token.
    The matched token name is put in `scope["state"]["user"]` (request.state.user)."""

    def __init__(self, app, tokens: dict[str, str]) -> None:
        self.app = app
        self.tokens = tokens

    async def __call__(self, scope, receive, send):
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        scope.setdefault("state", {})
        if not self.tokens:
            scope["state"]["user"] = "anonymous"
            scope["state"]["role"] = DEFAULT_ROLE  # the one local user
            return await self.app(scope, receive, send)
        headers = dict(scope.get("headers") or [])
        user = match_token(self.tokens, _bearer(headers))
        if user is None and (scope["type"] == "websocket" or scope.get("method") in ("GET", "HEAD")):
            user = match_token(self.tokens, _cookie(headers))
        if user is not None:
            scope["state"]["user"] = user
            scope["state"]["role"] = role = role_of(self.tokens, user)
            needed = (
                method_allowed(role, scope.get("method", "GET"), scope["path"])
                if scope["type"] == "http" and needs_auth(scope["path"])
                else None
            )
            if needed is not None:
                return await _forbidden(send, user, role, needed)
            return await self.app(scope, receive, send)
        if not needs_auth(scope["path"]):
            scope["state"]["user"] = None
            return await self.app(scope, receive, send)
        if scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008})
            return
        wrong = _bearer(headers) is not None
        msg = (
            "invalid token" if wrong else "authentication required"
        ) + ": send 'Authorization: Bearer <token>' (the server's WAAMFLOW_TOKEN or a token of its --token-file)"
        body = json.dumps({"detail": {"kind": "unauthorized", "message": msg, "text": msg}}).encode()
        challenge = 'Bearer realm="waamflow"' + (', error="invalid_token"' if wrong else "")
        await send(
            {
                "type": "http.response.start",
                "status": 401,
                "headers": [
                    (b"content-type", b"application/json"),
                    (b"content-length", str(len(body)).encode()),
                    (b"www-authenticate", challenge.encode()),
                ],
            }
        )
        await send({"type": "http.response.body", "body": body})
