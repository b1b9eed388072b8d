"""The run's layers on a Dask distributed cluster (`--scheduler tcp://HOST:PORT`): `DaskPool`, the
same `map_layers` as parallel.LayerPool, and `DaskWorkers`, the cluster as the preflight and
`Context.map_in_workers` see it (parallel.RunWorkers' interface). `distributed` is imported only
here, when a run names a scheduler. The thresholds and the chunking are parallel.py's (read at the
call: tests set them there)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Sequence, cast

from . import parallel

if TYPE_CHECKING:  # executor imports parallel, which imports this module only in make_pool
    from .executor import FileResolver
    from .parallel import ChainLink


@dataclass
class DaskWorkers:
    """A Dask cluster's workers as the preflight sees them (`RunWorkers`' interface): the cost
    model against `DASK_MIN_PARALLEL_S` (its workers run already), and a map that falls back to
    this process when the cluster fails (a task's own error is raised again here)."""

    pool: DaskPool

    @property
    def count(self) -> int:
        return self.pool.workers

    def pays(self, triangles: int, layers: int, points: int) -> bool:
        return parallel.wants_workers(self.count, triangles, layers, points, parallel.DASK_MIN_PARALLEL_S)

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any]) -> list[Any]:
        try:
            client = self.pool.client()
            futures = client.map(fn, list(items), pure=False)
            self.pool.map_tasks += len(futures)
            return cast(list[Any], client.gather(futures))
        except Exception:  # the cluster lost a worker or refused the task: compute here
            return [fn(it) for it in items]

    def submit(self, fn: Callable[[Any], Any], item: Any) -> Any:
        """fn(item) started on the cluster: a Dask future (its `result()` waits for it), or None."""
        try:
            fut = self.pool.client().submit(fn, item, pure=False)
        except Exception:
            return None
        self.pool.map_tasks += 1
        return fut


def _run_chain_shared(
    shared: tuple[Any, ...], chunk: list[tuple[int, dict[str, Any]]]
) -> list[tuple[int, list[tuple[Any, ...]]]]:
    """Dask worker side: `shared` = (chain, resolver), scattered once per map."""
    chain, resolver = shared
    return parallel.run_chain(chain, resolver, chunk)


@dataclass
class DaskPool:
    """The layer chunks of a run sent to a Dask distributed scheduler (`distributed` is imported
    only here, so users without a cluster never load it). Same `map_layers` as `LayerPool`; the
    workers must run the same waamflow (docker/compose.yml: the app's image)."""

    address: str
    tasks: int = 0
    map_tasks: int = 0
    _client: Any = field(default=None, repr=False)
    kind = "dask"
    started = ready = True  # a cluster's workers are running already
    warming = False

    @property
    def enabled(self) -> bool:
        return True

    @property
    def min_parallel_s(self) -> float:
        return parallel.DASK_MIN_PARALLEL_S

    @property
    def offload_artifacts(self) -> bool:
        """Artifacts are written here: shipping a node's whole outputs to a worker (pickled, over
        TCP) and its files back costs more than writing them (bench_replan, 500 layers on a
        LocalCluster: 6.9-7.9 s with artifacts on the cluster, 5.2-6.1 s without; local pool 4.4-5.0 s)."""
        return False

    def warm(self) -> None:
        """Nothing to start: a cluster's workers are running already."""

    def client(self) -> Any:
        if self._client is None:
            from distributed import Client

            from ..core.errors import RecipeError

            try:
                self._client = Client(
                    self.address,
                    timeout=parallel.DASK_CONNECT_S,  # type: ignore[no-untyped-call]
                    set_as_default=False,
                )  # (distributed's __init__ is not annotated)
            except Exception as exc:  # refused, timed out, or something else answering on that port
                raise RecipeError(
                    f"cannot reach the Dask scheduler at {self.address!r}: {type(exc).__name__}: {exc}"[:500]
                ) from None
        return self._client

    @property
    def workers(self) -> int:
        """Workers the scheduler knows now (0 before the first use)."""
        if self._client is None:
            return 0
        return len(self._client.scheduler_info(n_workers=-1).get("workers", {}))

    def info(self) -> dict[str, Any]:
        return {"kind": self.kind, "address": self.address, "workers": self.workers, "tasks": self.tasks}

    def map_layers(
        self,
        chain: tuple[ChainLink, ...],
        resolver: FileResolver,
        todo: list[tuple[int, dict[str, Any]]],
        on_done: Callable[[int, list[Any]], None],
        cancelled: Callable[[], bool],
    ) -> None:
        from distributed import as_completed

        client = self.client()
        # one object (a list would be scattered item by item), on every worker once
        shared = client.scatter([(chain, resolver)], broadcast=True, hash=False)[0]
        futures = [
            client.submit(_run_chain_shared, shared, c, pure=False)
            for c in parallel._chunks(todo, max(1, self.workers))
        ]
        self.tasks += len(futures)
        try:
            for fut in as_completed(futures, loop=client.loop):  # type: ignore[no-untyped-call]  # not annotated
                for i, got in fut.result():
                    on_done(i, got)
                if cancelled():
                    break
        finally:
            client.cancel([f for f in futures if not f.done()])
            client.cancel(shared)

    def close(self, wait: bool = True) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None
