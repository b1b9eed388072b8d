"""ASGI guards in front of the routes: request bodies bounded before they are read, the Host and
Origin checks (DNS rebinding, cross-site websockets and event streams), wrong-token throttling,
and the audit of reads (previews, viewer actions, artifact downloads, failed logins).

Order (outermost first, see app.py): Audit → Throttle → Host/Origin → Auth → BodyLimit → routes.
Each answers with the API's ErrorResponse body."""

from __future__ import annotations

import asyncio
import ipaddress
import json
import logging
import re
import threading
import time
from collections import deque
from typing import Any, Callable

from fastapi import HTTPException

from .schemas import error_body

log = logging.getLogger("waamflow.server")

UPLOAD_PATH = re.compile(r"^/api/graphs/[^/]+/files/[^/]+$")
LOOPBACK_NAMES = frozenset({"localhost", "127.0.0.1", "::1"})


async def send_error(send, status: int, detail: dict, headers: dict[str, str] | None = None) -> None:
    body = json.dumps(error_body(status, detail)).encode()
    hdrs = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    hdrs += [(k.lower().encode(), v.encode()) for k, v in (headers or {}).items()]
    await send({"type": "http.response.start", "status": status, "headers": hdrs})
    await send({"type": "http.response.body", "body": body})


def _header(scope, name: bytes) -> str | None:
    for k, v in scope.get("headers") or ():
        if k == name:
            return v.decode("latin-1")
    return None


def client_address(scope) -> str | None:
    client = scope.get("client")
    return client[0] if client else None


# ---- bodies -------------------------------------------------------------------------------------
class BodyTooLarge(HTTPException):
    """Raised from `receive` when a body without Content-Length passes its limit: an HTTPException,
    so FastAPI's body parsing and the routes pass it on to the 413 handler unchanged (FastAPI's
    HTTPException: a Starlette one whose detail may be the error dict, not only a string)."""

    def __init__(self, limit: int, what: str) -> None:
        super().__init__(
            413, detail={"kind": "too_large", "message": f"{what} larger than {limit / 2**20:g} MB: refused"}
        )


class BodyTimeout(HTTPException):
    def __init__(self, seconds: float) -> None:
        super().__init__(
            408, detail={"kind": "timeout", "message": f"request body not received: nothing arrived for {seconds:g} s"}
        )


class BodyLimitMiddleware:
    """Bodies bounded before they are read: a `Content-Length` over the limit is refused with 413
    at once (nothing read); a body without one is counted as it streams in and cut (413) when it
    passes the limit; a body that stalls for `timeout_s` between chunks gets 408. File uploads
    (`PUT /api/graphs/{name}/files/{file}`) have `upload_limit`, every other body `body_limit`."""

    def __init__(self, app, body_limit: int, upload_limit: int, timeout_s: float = 30.0) -> None:
        self.app = app
        self.body_limit = body_limit
        self.upload_limit = upload_limit
        self.timeout_s = timeout_s

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        upload = bool(UPLOAD_PATH.match(scope["path"]))
        limit = self.upload_limit if upload else self.body_limit
        what = "file" if upload else "request body"
        declared = _header(scope, b"content-length")
        if declared is not None:
            try:
                n = int(declared)
                if n < 0:
                    raise ValueError
            except ValueError:
                return await send_error(send, 400, {"message": f"invalid Content-Length {declared[:40]!r}"})
            if n > limit:
                return await send_error(
                    send,
                    413,
                    {
                        "kind": "too_large",
                        "message": f"{what} of {n / 2**20:.1f} MB is larger than {limit / 2**20:g} MB: refused "
                        "before reading it" + (" (max_upload_mb)" if upload else " (max_body_mb)"),
                    },
                    {"Connection": "close"},
                )
        seen = 0
        complete = False
        timeout = self.timeout_s

        async def bounded():
            nonlocal seen, complete
            if complete:  # the body is in: what follows is the wait for a disconnect, never timed
                return await receive()
            try:
                msg = await (asyncio.wait_for(receive(), timeout) if timeout else receive())
            except asyncio.TimeoutError:
                raise BodyTimeout(timeout) from None
            if msg["type"] == "http.request":
                seen += len(msg.get("body", b""))
                if seen > limit:
                    raise BodyTooLarge(limit, what)
                if not msg.get("more_body", False):
                    complete = True
            return msg

        started = False

        async def watch(message):
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
            await send(message)

        try:
            await self.app(scope, bounded, watch)
        except (BodyTooLarge, BodyTimeout) as e:  # raised outside a route (e.g. by a middleware reading)
            if started:
                raise
            await send_error(send, e.status_code, e.detail, {"Connection": "close"})


# ---- Host and Origin ----------------------------------------------------------------------------
def host_name(value: str | None) -> str | None:
    """The host of a Host header or an Origin's authority, without the port ('[::1]:8000' → '::1')."""
    if not value:
        return None
    v = value.strip().lower()
    if "://" in v:
        v = v.split("://", 1)[1]
    v = v.split("/", 1)[0]
    if v.startswith("["):
        return v[1 : v.find("]")] if "]" in v else None
    return v.rsplit(":", 1)[0] if v.count(":") == 1 else v


def is_loopback_host(host: str) -> bool:
    if host in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _authority(value: str | None) -> str | None:
    if not value:
        return None
    v = value.strip().lower()
    if "://" in v:
        v = v.split("://", 1)[1]
    return v.split("/", 1)[0] or None


class HostOriginMiddleware:
    """Without tokens (loopback only) the server answers only requests whose `Host` names this
    machine: loopback names and addresses, the `--host` it listens on, and `allowed_hosts`; any
    other Host (a DNS-rebinding page's `attacker.example`) gets 421. With or without tokens, a
    browser request from another site — an `Origin` that is not this server's own and not in
    `cors_origins` — is refused with 403 on websockets (`/viewer`), event streams and every
    request that changes something."""

    SAFE = frozenset({"GET", "HEAD", "OPTIONS"})

    def __init__(self, app, allowed_hosts: set[str] | None, cors_origins: set[str]) -> None:
        self.app = app
        self.allowed = {h.lower() for h in allowed_hosts} if allowed_hosts is not None else None
        self.cors = {o.rstrip("/").lower() for o in cors_origins}

    def host_ok(self, host: str | None) -> bool:
        if self.allowed is None:
            return True
        return host is not None and (host in self.allowed or is_loopback_host(host))

    async def __call__(self, scope, receive, send):
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        raw_host = _header(scope, b"host")
        host = host_name(raw_host)
        if not self.host_ok(host):
            msg = (
                f"Host {raw_host!r} is not served here: without a token this server answers only requests "
                "addressed to this machine (DNS-rebinding protection); add the name with WAAMFLOW_ALLOWED_HOSTS "
                "or serve with a token"
            )
            if scope["type"] == "websocket":
                return await send({"type": "websocket.close", "code": 1008, "reason": "host not allowed"})
            return await send_error(send, 421, {"kind": "misdirected", "message": msg})
        origin = _header(scope, b"origin")
        checked = (
            scope["type"] == "websocket" or scope.get("method") not in self.SAFE or scope["path"].endswith("/events")
        )
        if (
            checked
            and origin is not None
            and origin != "null"
            and _authority(origin) != _authority(raw_host)
            and origin.rstrip("/").lower() not in self.cors
        ):
            msg = (
                f"Origin {origin!r} may not use this server from a browser (cross-site request): open the GUI "
                "from the server's own address, or add the origin to WAAMFLOW_CORS_ORIGINS"
            )
            if scope["type"] == "websocket":
                return await send({"type": "websocket.close", "code": 1008, "reason": "origin not allowed"})
            return await send_error(send, 403, {"kind": "forbidden", "message": msg})
        if checked and origin == "null" and scope["type"] == "websocket":
            return await send({"type": "websocket.close", "code": 1008, "reason": "origin not allowed"})
        return await self.app(scope, receive, send)


# ---- wrong-token throttling ---------------------------------------------------------------------
class AuthThrottle:
    """Failed authentications per client address: more than `per_minute` in the last 60 s →
    429 with Retry-After until the window has room again; the wait doubles with each further
    refusal (exponential back-off, at most `max_wait_s`)."""

    def __init__(self, per_minute: int = 10, max_wait_s: float = 300.0) -> None:
        self.per_minute = per_minute
        self.max_wait_s = max_wait_s
        self.failures: dict[str, deque] = {}
        self.blocked_until: dict[str, tuple[float, int]] = {}  # address → (until, refusals so far)
        self.lock = threading.Lock()

    def retry_after(self, addr: str, now: float | None = None) -> float:
        """Seconds the address must wait (0: it may try)."""
        now = time.monotonic() if now is None else now
        with self.lock:
            until, _ = self.blocked_until.get(addr, (0.0, 0))
            return max(0.0, until - now)

    def failed(self, addr: str, now: float | None = None) -> None:
        now = time.monotonic() if now is None else now
        with self.lock:
            q = self.failures.setdefault(addr, deque())
            q.append(now)
            while q and q[0] < now - 60.0:
                q.popleft()
            if len(q) > self.per_minute:
                _, n = self.blocked_until.get(addr, (0.0, 0))
                wait = min(self.max_wait_s, (q[0] + 60.0 - now) * 2**n if n else q[0] + 60.0 - now)
                self.blocked_until[addr] = (now + max(1.0, wait), n + 1)
            if len(self.failures) > 10_000:  # a flood of addresses must not grow this without bound
                for a in [a for a, d in self.failures.items() if not d or d[-1] < now - 60.0]:
                    self.failures.pop(a, None)

    def succeeded(self, addr: str) -> None:
        with self.lock:
            self.failures.pop(addr, None)
            self.blocked_until.pop(addr, None)


class ThrottleAuditMiddleware:
    """Around authentication: a client address over the wrong-token limit gets 429 before its token
    is even looked at; each 401 with a token (a failed login) counts and is audited with the
    address; successful reads worth tracing are audited too (`audit_action`)."""

    def __init__(self, app, throttle: AuthThrottle | None, audit: Callable[[dict, int], None] | None) -> None:
        self.app = app
        self.throttle = throttle
        self.audit = audit

    async def __call__(self, scope, receive, send):
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        addr = client_address(scope) or "?"
        has_token = _header(scope, b"authorization") is not None or "waamflow_token=" in (
            _header(scope, b"cookie") or ""
        )
        if self.throttle is not None and has_token:
            wait = self.throttle.retry_after(addr)
            if wait > 0:
                secs = int(wait) + 1
                msg = f"too many wrong tokens from {addr}: try again in {secs} s"
                if scope["type"] == "websocket":
                    return await send({"type": "websocket.close", "code": 1008, "reason": "throttled"})
                return await send_error(send, 429, {"kind": "throttled", "message": msg}, {"Retry-After": str(secs)})
        status = [0]

        async def watch(message):
            if message["type"] == "http.response.start":
                status[0] = message["status"]
            elif message["type"] == "websocket.close" and not status[0]:
                status[0] = 1008 if message.get("code") == 1008 else 101
            elif message["type"] == "websocket.accept":
                status[0] = 101
            await send(message)

        try:
            await self.app(scope, receive, watch)
        finally:
            code = status[0]
            failed_login = has_token and (
                code == 401
                or (scope["type"] == "websocket" and code == 1008 and (scope.get("state") or {}).get("user") is None)
            )
            if self.throttle is not None and has_token:
                if failed_login:
                    self.throttle.failed(addr)
                elif code and code < 400:
                    self.throttle.succeeded(addr)
            if self.audit is not None and code:
                try:
                    self.audit(scope, code if not failed_login else 401)
                except Exception:  # the audit must never turn an answer into an error
                    log.exception("audit entry not written")


def audit_action(scope, status: int) -> tuple[str, str | None, dict] | None:
    """(action, target, detail) of a request the audit log records beside the routes' own entries
    (saves, deletes, uploads, runs, cancels): previews, viewer actions, artifact downloads, failed
    logins. None: not recorded."""
    path, method = scope["path"], scope.get("method", "WS")
    state = scope.get("state") or {}
    if status == 401 and (_header(scope, b"authorization") or "waamflow_token=" in (_header(scope, b"cookie") or "")):
        return "failed_login", None, {"path": path, "method": method}
    if status >= 400:
        return None
    if method == "POST" and path == "/api/preview":
        return (
            "preview",
            state.get("audit_target"),
            {"node": state.get("audit_node"), "layer": state.get("audit_layer")},
        )
    if method == "POST" and path.startswith("/api/viewer/"):
        return "viewer_" + path.rsplit("/", 1)[-1], None, {}
    if scope["type"] == "websocket" and path.startswith("/viewer") and status == 101:
        return "viewer_connect", None, {}
    m = re.match(r"^/api/runs/([^/]+)/artifacts/([^/]+)$", path)
    if m and method in ("GET", "HEAD"):
        return "download_artifact", m.group(1), {"file": m.group(2)}
    return None


def store_auditor(get_store: Callable[[Any], Any]) -> Callable[[dict, int], None]:
    def write(scope, status: int) -> None:
        got = audit_action(scope, status)
        if got is None:
            return
        store = get_store(scope)
        if store is None:
            return
        action, target, detail = got
        who = (scope.get("state") or {}).get("user")
        store.audit(
            who, action, target, {**{k: v for k, v in detail.items() if v is not None}, "client": client_address(scope)}
        )

    return write
