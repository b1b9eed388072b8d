"""Serving the built frontend: hashed assets compressed and cached for a year, index.html never cached.

Vite names every file under `assets/` after a hash of its content, so a browser may keep it forever
(`immutable`); `index.html` points at the current hashes and is revalidated on every load. Text
assets are gzip-compressed once per file version (kept in memory: the bundle is a few files) for
clients that accept gzip.
"""
from __future__ import annotations

import gzip
from pathlib import Path

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
                resp = Response(self._gzipped(file), media_type=resp.media_type,
                                headers={"Content-Encoding": "gzip", "ETag": resp.headers.get("etag", "")})
            resp.headers["Vary"] = "Accept-Encoding"
        if resp.status_code in (200, 304):
            resp.headers["Cache-Control"] = IMMUTABLE
        return resp


def index_response(file: Path) -> FileResponse:
    """index.html (and other unhashed files at the root): always revalidated."""
    return FileResponse(file, headers={"Cache-Control": "no-cache"})
