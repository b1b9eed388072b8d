"""Layer-parallel execution: the uncached layers of a `LayerNode` computed in worker processes.

The parent keeps everything that has to be ordered or shared: cache look-ups and writes, warnings
(added in layer order, so a parallel run reports exactly what a serial one does), progress events
and cancel. Workers only call `impl.run_layer` on chunks of consecutive layers. A node's whole
(non-layered) inputs travel once per chunk, and the chunks are few (about four per worker), so
pickling stays small next to the work.

Start method: `forkserver` with the node modules preloaded. Plain `fork` of a process that has
already loaded the kernels (GEOS, BLAS, the pool's own threads) hung now and then; the fork
server starts from a clean interpreter once per run and forks the workers from it.

Whether to go parallel is decided by measurement, not by a guess: the first uncached layer is
computed in the parent and timed, and the rest go to workers only when they are expected to take
longer than `MIN_PARALLEL_S` (the cost of starting workers and shipping inputs). Results are the
same objects either way, so artifacts are byte-identical to a serial run.
"""

from __future__ import annotations

import multiprocessing as mp
import os
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Any, Callable

from .node import Context, LayerNode

MIN_PARALLEL_S = 3.0      # expected serial seconds of the remaining layers below which workers do not pay
                          # (starting the fork server imports the kernels: about 2 s here)
TIMING_S = 0.05           # the parent computes (and times) uncached layers for this long first
CHUNKS_PER_WORKER = 4     # load balance vs. per-chunk overhead (inputs pickled once per chunk)


def default_workers() -> int:
    """`WAAMFLOW_LAYER_WORKERS`, else every core (1 = serial)."""
    env = os.environ.get("WAAMFLOW_LAYER_WORKERS")
    if env:
        try:
            return max(1, int(env))
        except ValueError:
            pass
    return max(1, os.cpu_count() or 1)


class _WorkerContext(Context):
    """What a node may ask of the engine inside a worker: files through the run's resolver,
    warnings collected per layer; progress and cancel are the parent's business."""

    def __init__(self, node_id: str, resolver) -> None:
        self.node_id = node_id
        self._resolver = resolver
        self.warnings: list[dict] = []
        self.layer: int | None = None

    def resolve_path(self, path: str) -> str:
        return str(self._resolver.resolve(path))

    def read_bytes(self, path: str, *, max_bytes: int | None = None) -> bytes:
        return self._resolver.read_bytes(path, max_bytes)

    def exists(self, path: str) -> bool:
        return self._resolver.exists(path)


    def progress(self, fraction: float, message: str = "") -> None:
        pass

    def check_cancelled(self) -> None:
        pass


def _run_chunk(impl: LayerNode, node_id: str, params_json: Any, resolver, chunk: list[tuple[int, dict]]):
    """Worker side: [(index, outputs, warnings) | (index, None, error text)] for a chunk. Params
    travel as JSON (their models may hold classes made at run time, which do not pickle) and are
    validated again here, exactly as the graph validated them."""
    params = type(impl).Params.model_validate(params_json)
    ctx = _WorkerContext(node_id, resolver)
    out = []
    for i, items in chunk:
        ctx.layer = i
        ctx.warnings = []
        try:
            out.append((i, impl.run_layer(ctx, params, i, items), ctx.warnings))
        except Exception as exc:  # re-run in the parent, which reports it with node/layer/section
            out.append((i, None, f"{type(exc).__name__}: {exc}"))
    return out


@dataclass
class LayerPool:
    """One process pool per run, started on first need and shared by the run's layer nodes."""

    workers: int
    tasks: int = 0
    _pool: ProcessPoolExecutor | None = field(default=None, repr=False)

    @property
    def enabled(self) -> bool:
        return self.workers > 1

    def _executor(self) -> ProcessPoolExecutor:
        if self._pool is None:
            ctx = mp.get_context("forkserver")
            ctx.set_forkserver_preload(["waamflow.nodes"])
            self._pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=ctx)
        return self._pool

    def map_layers(self, impl: LayerNode, node_id: str, params: Any, resolver, todo: list[tuple[int, dict]],
                   on_done: Callable[[int, dict | None, Any], None], cancelled: Callable[[], bool]) -> None:
        """Compute `todo` [(index, items)] in workers; `on_done(index, outputs, warnings | error)`
        is called in the parent as chunks finish (any order: the caller orders what must be)."""
        n_chunks = min(len(todo), self.workers * CHUNKS_PER_WORKER)
        size = -(-len(todo) // n_chunks)
        chunks = [todo[k:k + size] for k in range(0, len(todo), size)]
        pool = self._executor()
        pending: set[Future] = {pool.submit(_run_chunk, impl, node_id, params.model_dump(mode="json"), resolver, c) for c in chunks}
        self.tasks += len(pending)
        try:
            while pending:
                done, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
                for fut in done:
                    for i, out, extra in fut.result():
                        on_done(i, out, extra)
                if cancelled():
                    break
        finally:
            for fut in pending:
                fut.cancel()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
