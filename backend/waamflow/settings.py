"""Server settings (pydantic-settings): env vars WAAMFLOW_*, overridden by `waamflow serve` flags."""

from __future__ import annotations

import os
from pathlib import Path

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict

REPO_ROOT = Path(__file__).resolve().parents[2]


def _default_graphs() -> Path | None:
    for p in (Path.cwd() / "graphs", REPO_ROOT / "graphs"):
        if p.is_dir():
            return p
    return None


def _default_static() -> Path | None:
    for p in (REPO_ROOT / "frontend" / "dist", Path(__file__).resolve().parent / "static"):
        if (p / "index.html").is_file():
            return p
    return None


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="WAAMFLOW_")

    data_dir: Path = Field(Path("data"), description="SQLite database, run folders and cache")
    graphs_dir: Path | None = Field(default_factory=_default_graphs, description="example recipes offered at start")
    static_dir: Path | None = Field(default_factory=_default_static, description="built frontend (index.html)")
    host: str = "127.0.0.1"
    port: int = 8000
    viewer_port: int = Field(8080, description="viser 3D preview port; 0 disables it")
    start_viewer: bool = True
    start_workers: bool = True
    workers: int = Field(default_factory=lambda: max(1, min(4, os.cpu_count() or 1)))
    max_upload_mb: int = 200
    memory_cache_entries: int = 50_000
    disk_cache_gb: float = 2.0

    def model_post_init(self, _ctx) -> None:
        if self.graphs_dir is None:
            self.graphs_dir = _default_graphs()
