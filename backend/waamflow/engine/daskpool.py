"""The run's layers on a Dask distributed cluster (`--scheduler tcp://HOST:PORT`): `DaskPool`, the
same `map_layers` as parallel.LayerPool, and `DaskWorkers`, the cluster as the preflight and
`Context.map_in_workers` see it (parallel.RunWorkers' interface). `distributed` is imported only
here, when a run names a scheduler. The thresholds and the chunking are parallel.py's (read at the
call: tests set them there).

Every task's work travels pickled once, as bytes (`_dumps`), and its result comes back the same way:
the scheduler (its own process, docker/compose.yml) unpickles a task's arguments to read the graph
and pickles them again for the worker, and it relays results to the client; bytes it only copies.
Measured on the 500-layer cross's maps (the sequence node's 8 runs of layers and the preflight's 11
slab tasks as no-op tasks, `dask scheduler` + 2 `dask worker` processes, 2026-11-26, load 4-5):
0.52-1.02 s wall and 0.22-0.38 s of the scheduler's CPU with the objects as arguments, 0.15-0.37 s
wall and 0.02-0.04 s as bytes; with the real tasks the scheduler's CPU 0.30-0.43 s -> 0.09-0.19 s.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Sequence, cast

from . import parallel

# `work_held` waits for the first of a map's tasks to end, polling (sleeping frees the interpreter
# lock the client's thread needs to send them), this long at most: by then they have gone out.
WAIT_FIRST_S = 1.0
WAIT_POLL_S = 0.005
WORKERS_TTL_S = 1.0  # how long `DaskPool.workers` trusts the count the scheduler last gave

if TYPE_CHECKING:  # executor imports parallel, which imports this module only in make_pool
    from .executor import FileResolver
    from .chain import ChainLink, ChainTail


@dataclass
class DaskWorkers:
    """A Dask cluster's workers as the preflight sees them (`RunWorkers`' interface): the cost
    model against `DASK_MIN_PARALLEL_S` (its workers run already), and a map that falls back to
    this process when the cluster fails (a task's own error is raised again here)."""

    pool: DaskPool

    @property
    def count(self) -> int:
        return self.pool.workers

    def pays(self, triangles: int, layers: int, points: int, extra_s: float = 0.0) -> bool:
        return parallel.wants_workers(self.count, triangles, layers, points, parallel.DASK_MIN_PARALLEL_S, extra_s)

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any]) -> list[Any]:
        try:
            client = self.pool.client()
            futures = client.map(_call_pickled, [_dumps((fn, it)) for it in items], pure=False)
            self.pool.map_tasks += len(futures)
            self.pool.work_held(futures)
            return [_loads(b) for b in client.gather(futures)]
        except Exception:  # the cluster lost a worker or refused the task: compute here
            return [fn(it) for it in items]

    def submit(self, fn: Callable[[Any], Any], item: Any) -> PickledFuture | None:
        """fn(item) started on the cluster: a future (its `result()` waits for it), or None."""
        try:
            fut = self.pool.client().submit(_call_pickled, _dumps((fn, item)), pure=False)
        except Exception:
            return None
        self.pool.map_tasks += 1
        return PickledFuture(fut)


class HeldArtifacts:
    """A node's artifacts held by `DaskPool.submit_artifacts`: written in this process while it
    waits for the cluster's next tasks (`DaskPool.work_held`), or when asked for (`result`), or on
    the cluster once sent there (`send`: this process computes meanwhile, the cluster idles)."""

    def __init__(self, args: tuple[Any, ...]) -> None:
        self._args: tuple[Any, ...] | None = args
        self._value: Any = None
        self._future: Any = None

    @property
    def held(self) -> bool:
        return self._args is not None and self._future is None

    def send(self, client: Any) -> None:
        """To the cluster (a task of `_write_held`); kept here too, in case the cluster fails it."""
        if self.held:
            try:
                self._future = client.submit(_call_pickled, _dumps((_write_held, self._args)), pure=False)
            except Exception:  # refused: written here when asked for
                self._future = None

    def result(self, timeout: float | None = None) -> Any:
        """`parallel._write_artifacts`' result: ({suffix: bytes}, warnings) or (None, error)."""
        if self._future is not None:
            fut, self._future = self._future, None
            try:
                self._value, self._args = _loads(fut.result(timeout)), None
            except Exception:  # the cluster lost it: written here
                pass
        if self._args is not None:
            args, self._args = self._args, None
            self._value = parallel._write_artifacts(*args)
        return self._value


def _write_held(args: tuple[Any, ...]) -> Any:
    """Cluster side of `HeldArtifacts.send`."""
    return parallel._write_artifacts(*args)


@dataclass
class PickledFuture:
    """A Dask future of `_call_pickled`: `result()` is fn(item), unpickled here."""

    future: Any

    def result(self, timeout: float | None = None) -> Any:
        return _loads(self.future.result(timeout))

    def done(self) -> bool:
        return bool(self.future.done())

    def cancel(self) -> None:
        self.future.cancel()


SHARED_INLINE_BYTES = 1 << 18  # a chain's shared part (links, whole inputs) above this is scattered once
# Layer chunks as for this many times the workers (`parallel._chunks`: guided, large first): the
# scheduler hands a worker its next task before the running one ends (`worker-saturation` 1.1: two
# tasks for a 1-thread worker), so a map ends with the last two chunks of one worker while the
# other may have none left. The 500-layer cross, 2 workers: 11 chunks of 125 down to 16 layers
# (the last worker computed on 0.13-0.27 s after the other had finished, 3 traced runs); 23 of 63
# down to 8 layers with 2.
CHUNK_SPLIT = 2


def _dumps(value: Any) -> bytes:
    """`value` pickled as Dask pickles a task's arguments (pickle, cloudpickle for what pickle
    cannot), in one piece."""
    from distributed.protocol.pickle import dumps

    return cast(bytes, dumps(value))  # type: ignore[no-untyped-call]  # distributed: not annotated


def _loads(blob: bytes) -> Any:
    from distributed.protocol.pickle import loads

    return loads(blob)  # type: ignore[no-untyped-call]  # distributed: not annotated


def _call_pickled(blob: bytes) -> bytes:
    """Worker side: fn(item) of a pickled (fn, item), pickled (a task's error is raised as is)."""
    fn, item = _loads(blob)
    return _dumps(fn(item))


def _run_chain_pickled(shared: bytes, chunk: bytes) -> bytes:
    """Dask worker side: `shared` = (chain, resolver, tail) pickled, sent with each task or scattered
    once per map when large; `chunk` = [(index, items)] pickled; the chain's results pickled."""
    chain, resolver, tail = _loads(shared)
    return _dumps(parallel.run_chain(chain, resolver, _loads(chunk), tail))


@dataclass
class DaskPool:
    """The layer chunks of a run sent to a Dask distributed scheduler (`distributed` is imported
    only here, so users without a cluster never load it). Same `map_layers` as `LayerPool`; the
    workers must run the same waamflow (docker/compose.yml: the app's image)."""

    address: str
    tasks: int = 0
    map_tasks: int = 0
    _client: Any = field(default=None, repr=False)
    _workers: tuple[float, int] = field(default=(-1e9, 0), repr=False)  # (monotonic s, count) last asked
    _held: list[HeldArtifacts] = field(default_factory=list, repr=False)  # `submit_artifacts`, not written yet
    _holder: int | None = field(default=None, repr=False)  # the thread that held them
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
        """A node's artifacts are held (`submit_artifacts`), not written at once: this process
        writes them while it waits for the cluster's next tasks. Not sent to the cluster: a node's
        whole outputs pickled there and its files back cost more than writing them (bench_replan,
        500 layers on a LocalCluster: 6.9-7.9 s with artifacts on the cluster, 5.2-6.1 s without)."""
        return True

    def submit_artifacts(
        self,
        impl: Any,
        node_id: str,
        params: Any,
        resolver: FileResolver,
        trace: dict[str, Any],
        outputs: dict[str, Any],
    ) -> HeldArtifacts:
        """A node's artifacts held until this process waits for the cluster (`work_held`) or the
        run asks for them (the 500-layer cross: the strategy's and the zone's, 0.18 and 0.11 s of
        CPU, had been written while the cluster's workers waited for the sequence node's tasks)."""
        held = HeldArtifacts((impl, node_id, params.model_dump(mode="json"), resolver, trace, outputs))
        self._held.append(held)
        self._holder = threading.get_ident()
        return held

    def work_held(self, futures: list[Any]) -> None:
        """The held artifacts written here while `futures` (just submitted) run on the cluster,
        once the first of them has ended (before that, the client's thread is still sending them
        and needs the interpreter lock). Only on the thread that held them: the run's own."""
        if not self._held or threading.get_ident() != self._holder or not futures:
            return
        end = time.monotonic() + WAIT_FIRST_S
        while not any(f.done() for f in futures) and time.monotonic() < end:
            time.sleep(WAIT_POLL_S)  # the interpreter lock free for the client's thread meanwhile
        held, self._held = self._held, []
        for h in held:
            h.result()

    def release_held(self) -> None:
        """The held artifacts to the cluster now: this process is about to compute while the cluster
        idles (a node whose layers its chain tasks made ahead). Their outputs travel pickled and
        their files come back, which costs less than writing them here only when nothing else is
        asked of the cluster meanwhile (all artifacts sent so, beside the runs' tasks, had cost
        the 500-layer cross 1.7 s on a LocalCluster)."""
        if threading.get_ident() != self._holder or not self._held:
            return
        try:
            client = self.client()
        except Exception:  # the cluster is gone: they are written here when asked for
            return
        held, self._held = self._held, []
        for h in held:
            h.send(client)

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
        """Workers the scheduler knows (0 before the first use), asked at most every
        `WORKERS_TTL_S` (a run reads it per node and per preflight step: a round trip each)."""
        if self._client is None:
            return 0
        asked, count = self._workers
        if time.monotonic() - asked > WORKERS_TTL_S:
            count = len(self._client.scheduler_info(n_workers=-1).get("workers", {}))
            self._workers = (time.monotonic(), count)
        return count

    def info(self) -> dict[str, Any]:
        return {"kind": self.kind, "address": self.address, "workers": self.workers, "tasks": self.tasks}

    def map_layers(
        self,
        chain: tuple[ChainLink, ...],
        resolver: FileResolver,
        todo: list[tuple[int, dict[str, Any]]],
        on_done: Callable[[int, list[Any]], None],
        cancelled: Callable[[], bool],
        tail: ChainTail | None = None,
        on_ahead: Callable[[list[Any]], None] | None = None,
    ) -> None:
        from distributed import as_completed

        client = self.client()
        shared: Any = _dumps((chain, resolver, tail))
        scattered = len(shared) > SHARED_INLINE_BYTES
        if scattered:  # on every worker once, not with each task
            shared = client.scatter([shared], broadcast=True, hash=False)[0]
        chunks = [_dumps(c) for c in parallel._chunks(todo, CHUNK_SPLIT * max(1, self.workers))]
        futures = client.map(_run_chain_pickled, [shared] * len(chunks), chunks, pure=False)  # one graph
        self.tasks += len(futures)
        try:
            self.work_held(futures)
            for fut in as_completed(futures, loop=client.loop):  # type: ignore[no-untyped-call]  # not annotated
                rows, ahead = _loads(fut.result())
                for i, got in rows:
                    on_done(i, got)
                if ahead and on_ahead is not None:
                    on_ahead(ahead)
                if cancelled():
                    break
        finally:
            left = [f for f in futures if not f.done()]
            if left:
                client.cancel(left)
            if scattered:
                client.cancel(shared)

    def close(self, wait: bool = True) -> None:
        self._workers = (-1e9, 0)
        self._held = []
        if self._client is not None:
            self._client.close()
            self._client = None
