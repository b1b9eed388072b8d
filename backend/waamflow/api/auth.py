"""Bearer-token authentication for the API and the 3D viewer.

Tokens come from `WAAMFLOW_TOKEN` (one token, named "default") and/or a token file
(`--token-file` / `WAAMFLOW_TOKEN_FILE`): either a JSON object `{"name": "token", ...}` or lines
`name:token` (blank lines and `#` comments ignored). With at least one token configured every
`/api` route except `/api/health` needs `Authorization: Bearer <token>`; the caller's token name is
the "who" of the audit log. GET requests (an `EventSource`, an artifact link) may carry the token
in the `waamflow_token` session cookie the GUI sets, since a browser cannot add a header to them;
requests that change anything need the header.
"""

from __future__ import annotations

import hmac
import json
import re
from pathlib import Path

from ..core.errors import WaamflowError

COOKIE = "waamflow_token"
TOKEN_NAME = re.compile(r"^[A-Za-z0-9_.@-]{1,64}$")
MIN_TOKEN_LENGTH = 16
# a token is refused when it has fewer distinct characters than this: 16 × 'a' passes the length
# rule but is guessed at once (`secrets.token_urlsafe(32)` has ~30 distinct of 43)
MIN_DISTINCT_CHARS = 8
OPEN_PATHS = ("/api/health",)


class TokenFileError(WaamflowError):
    exit_code = 2
    kind = "invalid_config"


def parse_tokens(text: str, source: str = "token file") -> dict[str, str]:
    """name → token from a token file's text (JSON object or `name:token` lines)."""
    stripped = text.strip()
    pairs: list[tuple[str, str]] = []
    if stripped.startswith("{"):
        try:
            data = json.loads(stripped)
        except json.JSONDecodeError as e:
            raise TokenFileError(f"{source}: invalid JSON ({e})") from None
        pairs = [(str(k), v) for k, v in data.items()]
    else:
        for i, line in enumerate(text.splitlines(), 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            name, sep, token = line.partition(":")
            if not sep:
                raise TokenFileError(f"{source} line {i}: expected 'name:token'")
            pairs.append((name.strip(), token.strip()))
    out: dict[str, str] = {}
    for name, token in pairs:
        if not TOKEN_NAME.match(name):
            raise TokenFileError(f"{source}: invalid token name {name!r} (letters, digits, _ . @ -; ≤ 64 chars)")
        check_token(token, f"{source}: token {name!r}")
        if name in out:
            raise TokenFileError(f"{source}: token name {name!r} appears twice")
        out[name] = token
    if not out:
        raise TokenFileError(f"{source}: no tokens")
    return out


def check_token(token: object, what: str) -> None:
    if not isinstance(token, str) or len(token) < MIN_TOKEN_LENGTH or any(c.isspace() for c in token) or ":" in token:
        raise TokenFileError(f"{what} must be a string of at least {MIN_TOKEN_LENGTH} characters without "
                             "spaces or ':' (e.g. `python -c 'import secrets; print(secrets.token_urlsafe(32))'`)")
    distinct = len(set(token))
    if distinct < MIN_DISTINCT_CHARS:
        raise TokenFileError(f"{what} is too weak: {'one character repeated' if distinct == 1 else f'{distinct} distinct characters'}"
                             f" (at least {MIN_DISTINCT_CHARS} distinct needed); make one with "
                             "`python -c 'import secrets; print(secrets.token_urlsafe(32))'`")


def load_tokens(token: str | None, token_file: str | Path | None) -> dict[str, str]:
    tokens: dict[str, str] = {}
    if token_file:
        p = Path(token_file)
        try:
            mode = p.stat().st_mode
            if mode & 0o006:  # other users could read the tokens, or add their own
                what = "readable and writable" if mode & 0o006 == 0o006 else "readable" if mode & 0o004 else "writable"
                raise TokenFileError(f"token file {p} is {what} by every user (mode {mode & 0o777:04o}): "
                                     f"run `chmod 600 {p}` (or 640 for a group) and start again")
            text = p.read_text(encoding="utf-8")
        except OSError as e:
            raise TokenFileError(f"cannot read token file {p}: {e.strerror}") from None
        tokens.update(parse_tokens(text, str(p)))
    if token:
        check_token(token, "WAAMFLOW_TOKEN")
        tokens.setdefault("default", token)
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
            return await self.app(scope, receive, send)
        headers = dict(scope.get("headers") or [])
        user = match_token(self.tokens, _bearer(headers))
        if user is None and (scope["type"] == "websocket" or scope.get("method") in ("GET", "HEAD")):
            user = match_token(self.tokens, _cookie(headers))
        if user is not None:
            scope["state"]["user"] = user
            return await self.app(scope, receive, send)
        if not needs_auth(scope["path"]):
            scope["state"]["user"] = None
            return await self.app(scope, receive, send)
        if scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008})
            return
        wrong = _bearer(headers) is not None
        msg = ("invalid token" if wrong else "authentication required") + \
            ": send 'Authorization: Bearer <token>' (the server's WAAMFLOW_TOKEN or a token of its --token-file)"
        body = json.dumps({"detail": {"kind": "unauthorized", "message": msg, "text": msg}}).encode()
        challenge = 'Bearer realm="waamflow"' + (', error="invalid_token"' if wrong else "")
        await send({"type": "http.response.start", "status": 401, "headers": [
            (b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
            (b"www-authenticate", challenge.encode())]})
        await send({"type": "http.response.body", "body": body})
