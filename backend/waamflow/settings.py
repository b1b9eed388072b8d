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


def _default_run_memory_mb() -> float:
    """Half of the machine's memory, MB (0 where it is unknown: no limit)."""
    try:
        return float(round(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") / 2**20 / 2))
    except (ValueError, OSError, AttributeError):
        return 0.0


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
    workers: int = Field(
        default_factory=lambda: max(1, min(4, os.cpu_count() or 1)), description="runs executed at the same time"
    )
    layer_workers: int | None = Field(
        None, ge=1, le=256, description="processes per run for the layers of layer nodes (None: every core; 1: serial)"
    )
    scheduler: str | None = Field(
        None,
        description="Dask scheduler (tcp://HOST:PORT) the layers of runs go to "
        "instead of local processes (WAAMFLOW_SCHEDULER)",
    )
    max_upload_mb: int = 200
    disk_reserve_mb: float = Field(
        16.0,
        ge=0,
        description="space kept in a file in the data folder and given back when "
        "the disk is full, so that deletes still go through, MB",
    )
    max_body_mb: float = Field(
        32.0,
        gt=0,
        description="any request body but a file upload (recipes, parameter XML, "
        "previews), MB; a larger Content-Length gets 413 unread",
    )
    body_timeout_s: float = Field(30.0, ge=0, description="a request body that sends nothing for this long gets 408, s")
    # connections (`waamflow serve`; uvicorn h11 with a header timeout and a connection cap)
    max_connections: int = Field(1000, ge=1, description="open connections; one more is closed at once")
    max_connections_per_client: int = Field(
        256,
        ge=1,
        description="open connections from one address; more are closed at once (clients behind one proxy share it)",
    )
    header_timeout_s: float = Field(10.0, gt=0, description="a connection must send its request head within this, s")
    keep_alive_s: float = Field(5.0, gt=0, description="an idle keep-alive connection is closed after this, s")
    max_header_kb: int = Field(64, ge=4, description="size of a request's head (line + headers), kB")
    memory_cache_entries: int = 50_000
    disk_cache_gb: float = 2.0
    # security (README "Security model")
    token: str | None = Field(
        None, description="bearer token every /api route and the viewer require (named 'default')"
    )
    token_file: Path | None = Field(None, description="file of named tokens: JSON {name: token} or lines name:token")
    cors_origins: list[str] = Field(
        default_factory=list, description="origins allowed to call the API from a browser (none by default)"
    )
    allowed_hosts: list[str] = Field(
        default_factory=list,
        description="Host names answered without a token besides loopback names and "
        "--host (DNS-rebinding protection; JSON list in WAAMFLOW_ALLOWED_HOSTS)",
    )
    auth_failures_per_minute: int = Field(
        10,
        ge=1,
        description="wrong tokens one client address may send per minute before 429 (the wait doubles each time)",
    )
    # resource limits per run (README "Limits"); 0 = no limit
    run_timeout_s: float = Field(1800.0, ge=0, description="wall time of one run, s")
    max_layers: int = Field(5000, ge=0, description="layers a run may produce")
    max_points: int = Field(20_000_000, ge=0, description="path points (summed over all layers) a run may produce")
    max_artifact_mb: float = Field(500.0, ge=0, description="size of one run's artifacts, MB")
    max_memory_mb: float = Field(
        8192.0,
        ge=0,
        description="resident memory of the server process while runs are going, MB "
        "(0 = unlimited); over it the largest running run fails",
    )
    run_memory_mb: float = Field(
        default_factory=_default_run_memory_mb,
        ge=0,
        description="memory of one run's whole process tree (the run and its layer "
        "workers together), MB (default: half the machine's); also of a "
        "preview's. Each run executes in a process tree of its own, held to it "
        "by a cgroup (memory.max) where the server may make one, else by the "
        "server's watchdog; a run or preview that needs more fails naming the "
        "limit. 0 = runs and previews execute in the server process, unlimited "
        "(Linux only; elsewhere 0)",
    )
    max_queued_runs: int = Field(16, ge=1, description="runs waiting or running; one more gets 429 + Retry-After")
    # estimates checked before a run or preview starts (422 with the estimate); 0 = no limit
    max_triangles: int = Field(20_000_000, ge=0, description="triangles of a run's meshes (STL header, OBJ faces)")
    max_dxf_entities: int = Field(500_000, ge=0, description="entities of a run's DXF sketches")
    max_uncompressed_mb: float = Field(1024.0, ge=0, description="what a run's 3MF files expand to (zip directory), MB")
    preview_timeout_s: float = Field(60.0, ge=0, description="wall time of one POST /api/preview, s")

    def model_post_init(self, _ctx) -> None:
        if self.graphs_dir is None:
            self.graphs_dir = _default_graphs()
