"""The 3D preview (viser) through the app's own origin: `/viewer/` (its page) and its websocket,
relayed to the viser server on 127.0.0.1 behind the API's authentication (AuthMiddleware covers
`/viewer`: the GUI's session cookie lets the iframe and its websocket in; HostOriginMiddleware
checks Host and the websocket's Origin). viser listens on loopback only and closes any websocket
that does not carry the server's secret (`PROXY_HEADER`, added here), so this is the only way in —
for browsers and for other users of the same machine alike. viser's client opens its websocket at the page's
own URL (http→ws), so the websocket arrives at `/viewer` too; its query (`?view=<id>`, which
browser view the client belongs to) is passed on to viser."""

from __future__ import annotations

import asyncio
import logging
import urllib.error
import urllib.request

from fastapi import FastAPI, Request, WebSocket
from fastapi.responses import RedirectResponse, Response
from starlette.concurrency import run_in_threadpool
from starlette.websockets import WebSocketDisconnect

log = logging.getLogger("waamflow.viewer")


def _port(app: FastAPI) -> int | None:
    svc = getattr(app.state, "services", None)
    viewer = getattr(svc, "viewer", None)
    return getattr(viewer, "bound_port", None) if viewer is not None else None


def mount_viewer_proxy(app: FastAPI) -> None:
    @app.get("/viewer", include_in_schema=False)
    def viewer_root() -> Response:
        return RedirectResponse("/viewer/")

    @app.get("/viewer/{path:path}", include_in_schema=False)
    async def viewer_http(path: str, request: Request) -> Response:
        port = _port(request.app)
        if port is None or ".." in path.split("/"):
            return Response("the 3D preview is not running", status_code=404, media_type="text/plain")
        url = f"http://127.0.0.1:{port}/{path}" + (f"?{request.url.query}" if request.url.query else "")

        def fetch() -> tuple[int, bytes, str]:
            try:
                with urllib.request.urlopen(url, timeout=30) as r:  # noqa: S310 (loopback viser only)
                    return r.status, r.read(), r.headers.get("Content-Type", "application/octet-stream")
            except urllib.error.HTTPError as e:
                return e.code, e.read(), e.headers.get("Content-Type", "text/plain")

        status, body, ctype = await run_in_threadpool(fetch)
        return Response(body, status_code=status, media_type=ctype, headers={"Cache-Control": "no-cache"})

    async def relay(ws: WebSocket) -> None:
        import websockets.asyncio.client as wsc

        from ..viewer.service import PROXY_HEADER

        port = _port(ws.app)
        if port is None:
            await ws.close(code=1011)
            return
        protocols = ws.scope.get("subprotocols") or []
        try:
            query = ws.url.query
            secret = getattr(ws.app.state, "viewer_secret", None)
            upstream = await wsc.connect(
                f"ws://127.0.0.1:{port}/" + (f"?{query}" if query else ""),
                subprotocols=protocols or None,
                max_size=None,
                compression=None,
                open_timeout=10,
                additional_headers={PROXY_HEADER: secret} if secret else None,
            )
        except Exception as e:
            log.warning("3D preview websocket relay failed: %s", e)
            await ws.close(code=1011)
            return
        await ws.accept(subprotocol=upstream.subprotocol)

        async def down() -> None:
            async for msg in upstream:
                if isinstance(msg, bytes):
                    await ws.send_bytes(msg)
                else:
                    await ws.send_text(msg)

        async def up() -> None:
            while True:
                m = await ws.receive()
                if m["type"] == "websocket.disconnect":
                    return
                data = m.get("bytes")
                await upstream.send(data if data is not None else m.get("text", ""))

        tasks = [asyncio.create_task(down()), asyncio.create_task(up())]
        try:
            await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        except WebSocketDisconnect:
            pass
        finally:
            for t in tasks:
                t.cancel()
            await upstream.close()
            try:
                await ws.close()
            except RuntimeError:
                pass

    app.add_api_websocket_route("/viewer", relay)
    app.add_api_websocket_route("/viewer/", relay)
