"""Serving the built frontend: hashed assets compressed and cached for a year, index.html never cached.

Vite names every file under `assets/` after a hash of its content, so a browser may keep it forever
(`immutable`); `index.html` points at the current hashes and is revalidated on every load. Text
assets are gzip-compressed once per file version (kept in memory: the bundle is a few files) for
clients that accept gzip.
"""

from __future__ import annotations

import gzip
import hashlib
from pathlib import Path

from fastapi import Request
from fastapi.responses import FileResponse
from starlette.responses import Response
from starlette.staticfiles import StaticFiles
from starlette.types import Scope

IMMUTABLE = "public, max-age=31536000, immutable"
COMPRESSIBLE = {".js", ".mjs", ".css", ".svg", ".json", ".map", ".html", ".txt", ".wasm", ".xml"}
MIN_SIZE = 1024  # below this, gzip's header costs more than it saves


def _accepts_gzip(scope: Scope) -> bool:
    for k, v in scope.get("headers", ()):
        if k == b"accept-encoding":
            return any(part.split(";")[0].strip() in ("gzip", "*") for part in v.decode("latin-1").split(","))
    return False


class CompressedAssets(StaticFiles):
    """`StaticFiles` for content-hashed files: long cache headers, gzip when the client accepts it."""

    def __init__(self, directory: Path):
        super().__init__(directory=directory, check_dir=False)
        self._gz: dict[tuple[str, int, int], bytes] = {}

    def _gzipped(self, path: Path) -> bytes:
        st = path.stat()
        key = (str(path), st.st_mtime_ns, st.st_size)
        if key not in self._gz:
            self._gz[key] = gzip.compress(path.read_bytes(), compresslevel=9, mtime=0)
        return self._gz[key]

    async def get_response(self, path: str, scope: Scope) -> Response:
        resp = await super().get_response(path, scope)
        if isinstance(resp, FileResponse) and resp.status_code == 200:
            file = Path(resp.path)
            if file.suffix in COMPRESSIBLE and file.stat().st_size >= MIN_SIZE and _accepts_gzip(scope):
                resp = Response(
                    self._gzipped(file),
                    media_type=resp.media_type,
                    headers={"Content-Encoding": "gzip", "ETag": resp.headers.get("etag", "")},
                )
            resp.headers["Vary"] = "Accept-Encoding"
        if resp.status_code in (200, 304):
            resp.headers["Cache-Control"] = IMMUTABLE
        return resp


def index_response(file: Path) -> FileResponse:
    """index.html (and other unhashed files at the root): always revalidated."""
    return FileResponse(file, headers={"Cache-Control": "no-cache"})


class ViewerClientPage:
    """viser's client page (one self-contained index.html of ~0.8 MB) under a content-hashed URL,
    cached like the hashed assets: viser's own HTTP server sends it without a cache header, so every
    visit to the 3D tab downloaded it again. The page finds viser's websocket from its `websocket`
    query parameter (viser's client reads it), so it may be served from this origin."""

    PREFIX = "/viewer-client/"

    def __init__(self, file: Path):
        self.data = file.read_bytes()
        self.digest = hashlib.sha256(self.data).hexdigest()[:16]
        self.gz = gzip.compress(self.data, compresslevel=9, mtime=0)

    @property
    def url(self) -> str:
        return f"{self.PREFIX}{self.digest}/index.html"

    @classmethod
    def find(cls) -> "ViewerClientPage | None":
        try:
            import viser
        except ImportError:
            return None
        build = Path(viser.__file__).parent / "client" / "build"
        if not (build / "index.html").is_file():
            return None
        try:  # the page as the viewer serves it: viser's, with the embedding lines (viewer/embed.py)
            from ..viewer.embed import client_root

            build = client_root(build)
        except (ImportError, OSError):
            pass
        return cls(build / "index.html")

    def response(self, digest: str, accept_gzip: bool) -> Response:
        if digest != self.digest:  # an old hash after a viser upgrade: the page asks health again
            return Response(
                "no such viewer page version",
                status_code=404,
                media_type="text/plain",
                headers={"Cache-Control": "no-cache"},
            )
        headers = {"Cache-Control": IMMUTABLE, "Vary": "Accept-Encoding", "ETag": f'"{self.digest}"'}
        if accept_gzip:
            headers["Content-Encoding"] = "gzip"
        return Response(self.gz if accept_gzip else self.data, media_type="text/html; charset=utf-8", headers=headers)


def mount_viewer_client(app) -> ViewerClientPage | None:
    """GET /viewer-client/<sha256 prefix>/index.html: viser's client page, cached for a year."""
    page = ViewerClientPage.find()
    if page is None:
        return None

    @app.get(ViewerClientPage.PREFIX + "{digest}/index.html", include_in_schema=False)
    def viewer_client(digest: str, request: Request) -> Response:
        return page.response(digest, _accepts_gzip(request.scope))

    app.state.viewer_client = page
    return page
