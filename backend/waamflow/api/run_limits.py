"""What a run is held to: its resource limits (`Limits`, from the settings; its estimate checked
against them before it starts), the errors of a run over a limit (`LimitError`) or of a full queue
(`QueueFullError`, HTTP 429), whether runs get processes of their own under an address-space cap
(`RUN_PROCESSES`), the memory of a process tree (`rss_bytes`) and how a run or preview over its
memory budget is recognised and reported (`is_memory_error`, `memory_limit_message`).

Split from `api.worker` (issue 27): that module is the run queue (`RunManager`: slots, cancel,
live events, the run's process); every name stays importable from there.
"""

from __future__ import annotations

from dataclasses import dataclass
import multiprocessing as mp
import os

from ..core.errors import WaamflowError
from ..engine.estimate import check_estimate, estimate


@dataclass(frozen=True)
class Limits:
    """Per-run resource limits (0 = none). See Settings / README "Limits"."""

    wall_s: float = 0.0
    layers: int = 0
    points: int = 0
    artifact_bytes: int = 0
    memory_bytes: int = 0
    queue: int = 0
    triangles: int = 0
    dxf_entities: int = 0
    uncompressed_bytes: int = 0
    preview_s: float = 0.0
    run_memory_bytes: int = 0  # memory of a run's whole process tree (0: runs in the server process)

    @classmethod
    def from_settings(cls, s) -> "Limits":
        return cls(
            wall_s=s.run_timeout_s,
            layers=s.max_layers,
            points=s.max_points,
            artifact_bytes=int(s.max_artifact_mb * 1024 * 1024),
            memory_bytes=int(s.max_memory_mb * 1024 * 1024),
            queue=s.max_queued_runs,
            triangles=s.max_triangles,
            dxf_entities=s.max_dxf_entities,
            uncompressed_bytes=int(s.max_uncompressed_mb * 2**20),
            preview_s=s.preview_timeout_s,
            run_memory_bytes=int(s.run_memory_mb * 2**20) if RUN_PROCESSES else 0,
        )

    def check_estimate(self, graph, resolver) -> dict:
        """Before a run or preview: its estimate (layers, triangles, DXF entities, 3MF size) against
        these limits → EstimateError (422) naming the estimate; else the estimate."""
        est = estimate(graph, resolver)
        check_estimate(
            est,
            max_layers=self.layers,
            max_triangles=self.triangles,
            max_dxf_entities=self.dxf_entities,
            max_uncompressed_bytes=self.uncompressed_bytes,
        )
        return est.to_dict()


class LimitError(WaamflowError):
    """A run went over a resource limit; it ends as failed with this reason."""

    kind = "limit"


class QueueFullError(WaamflowError):
    """Too many runs queued or running: HTTP 429 with Retry-After."""

    kind = "busy"
    http_status = 429

    def __init__(self, message: str, retry_after: int) -> None:
        super().__init__(message)
        self.headers = {"Retry-After": str(retry_after)}


def rss_bytes() -> int:
    """Resident memory of this process and every process it started (layer workers, the fork
    server), bytes (0 where unknown): the memory limit covers the whole tree."""
    try:
        import psutil

        me = psutil.Process()
        total = me.memory_info().rss
        for child in me.children(recursive=True):
            try:
                total += child.memory_info().rss
            except (psutil.NoSuchProcess, psutil.AccessDenied):
                pass
        return total
    except Exception:
        try:
            with open("/proc/self/statm") as f:
                return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
        except (OSError, ValueError, IndexError):
            return 0


def _fork_available() -> bool:
    try:
        import resource  # noqa: F401

        return "fork" in mp.get_all_start_methods() and hasattr(resource, "RLIMIT_AS")
    except ImportError:
        return False


RUN_PROCESSES = _fork_available()  # runs in processes of their own under RLIMIT_AS (Linux)


def where_text(err: dict | None) -> str:
    """' (node 'x', layer 3)' from an error's or event's node and layer ('' without a node)."""
    if err and err.get("node"):
        return f" (node {err['node']!r}" + (f", layer {err['layer']}" if err.get("layer") is not None else "") + ")"
    return ""


def memory_limit_message(budget: int, err: dict | None = None, what: str = "run") -> str:
    return (
        f"{what} used more than {budget / 2**20:.0f} MB of memory{where_text(err)}, its memory limit "
        "(run_memory_mb, for its whole process tree: the run and its layer workers): raise --run-memory-mb / "
        "WAAMFLOW_RUN_MEMORY_MB, or make the work smaller (fewer layers, a coarser mesh)"
    )


def is_memory_error(err: BaseException) -> bool:
    """A MemoryError, or a node error made of one (in the run or reported back by a layer worker)."""
    seen = 0
    e: BaseException | None = err
    while e is not None and seen < 8:
        if isinstance(e, MemoryError) or "MemoryError" in str(e):
            return True
        e = e.__cause__ or e.__context__
        seen += 1
    return False
