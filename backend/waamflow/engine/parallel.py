"""Layer-parallel execution: the uncached layers of a `LayerNode` computed in worker processes.

The parent keeps everything that has to be ordered or shared: cache look-ups and writes, warnings
(added in layer order, so a parallel run reports exactly what a serial one does), progress events
and cancel. Workers only call `impl.run_layer` on chunks of consecutive layers. A node's whole
(non-layered) inputs travel once per chunk, and the chunks are few (about four per worker), so
pickling stays small next to the work.

Start method: `forkserver` with every node module and kernel preloaded (engine/warm.py). Plain
`fork` of a process that has already loaded the kernels (GEOS, BLAS, the pool's own threads) hung
now and then; the fork server starts from a clean interpreter once per process, imports the
kernels once, and forks the workers from it (a fork is cheap: nothing is imported again).

Whether to go parallel is decided by measurement, not by a guess: the first uncached layers of
a node are computed in the parent and timed (CPU seconds of its thread: other processes on a busy
machine slow its wall clock, and going parallel then would cost the most). When the rest is
expected to take longer than `MIN_PARALLEL_S`, the workers are started (`warm`) in a background
thread, so the fork server's imports and the forks overlap the parent, which goes on computing
layers itself until they are up; then the remaining layers go to them (`map_layers`). A run
whose layered value has `WARM_LAYERS` layers or more, with layer nodes to come, starts them
right then instead, so their start-up overlaps the first layer nodes. Once they are up, later nodes hand them
their layers whenever the rest is worth `WARM_MIN_PARALLEL_S` (only the round trips cost).
Results are the same objects either way, so artifacts are byte-identical to a serial run.

Chains. When a layer node's layers go to the workers and the layer node that consumes its
output only needs that output's layer i (plus whole values already computed), the workers compute
both in one task: mask → guide → strategy → zone of a chunk of layers in one worker, link by link
(`run_chain`), so the layers of the whole chain are spread over the cores at once, and each
layer's items cross the process boundary once instead of once per node. The later nodes' results wait in
the parent (`_Run.precomputed`) and are taken up, in layer order, when the run reaches those
nodes: caching, warnings and artifacts are exactly a serial run's. A link requires the upstream
node's `combine` to hand its items on unchanged (`LayerNode.keeps_items`). A chain's tail: the
whole-part node fed by the last link (the sequence node) may run ahead on each chunk's layers in
the same task (`Node.run_ahead`, `ChainTail`), so its own run only checks the guesses instead of
sending every layer to the workers again (the 500-layer cross: its sequence phase 0.94 → 0.37 s).
The worker side of a task is chain.py.

Once the workers are in use, a node's artifacts (JSON, XML, programs: pure functions of its
outputs) wait for the next node's tasks (the run's critical path) and are written by the parent
while it waits for them, or by a worker behind them (`submit_artifacts`); the run collects them
in node order at its end.

`DaskPool` (daskpool.py) sends the same chunks to a Dask distributed cluster (`--scheduler tcp://HOST:PORT`)
instead: its workers are already running, so the threshold to go parallel is lower. Each task's
work travels pickled once, as bytes (the scheduler only copies them), a chain's shared part with
each task unless it is large (then scattered once); a node's artifacts are held and written by the
run while the cluster computes the next node's tasks (sending whole outputs costs more).
The preflight's layer checks and read-backs go to the cluster as they go to local workers
(`DaskWorkers`, `RunWorkers`): run in the parent, they were most of what a Dask run took more.
"""

from __future__ import annotations

import functools
import multiprocessing as mp
import os
import threading
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Sequence

from .chain import ChainLink as ChainLink  # re-exported: the pool's tasks, engine.parallel.* for callers
from .chain import ChainTail as ChainTail
from .chain import _write_artifacts as _write_artifacts
from .chain import run_chain as run_chain

if TYPE_CHECKING:  # executor imports this module; daskpool imports this module
    from .daskpool import DaskPool
    from .executor import FileResolver

MIN_PARALLEL_S = 2.0  # expected serial CPU seconds of shareable work that start the workers
# Starting them is not free: the fork server imports the kernels (~0.7 s of CPU), the workers fork,
# artifacts and layers are pickled both ways. graphs/bracket.json (56 triangles, 300 layers, 4,760
# path points: 1.62 s by the cost model) started them at 1.5 and lost at every load measured
# (2026-11-26, load 4-6, medians of 3 interleaved CLI runs: 2 workers 8.14 s wall / 3.55 s CPU
# against 1 worker 4.11 s / 2.19 s; the workers got no layer: the parent had done them all by
# the time they were up). The 500-layer cross (2.5 s by the model, 10 s serial) and the bench
# vases (3.2 s) still start them.
WARM_MIN_PARALLEL_S = 0.2  # the same once the workers are up: pickling round trips only
TIMING_S = 0.05  # the parent computes (and times, in CPU seconds of its thread) uncached layers this long first
BACKGROUND_START = True  # False (tests): `warm` waits for the workers, so who computes what is fixed
_server_up = False  # this process has started workers: its fork server runs (`LayerPool.warm`)
WARM_WAIT_S = 0.06  # what `warm` waits at most for the workers when the fork server runs already
PRELOAD = ["waamflow.engine.warm"]  # not trimesh: see warm.py
CHUNKS_PER_WORKER = 4  # the smallest (last) chunk: 1/(workers · 4 · this) of the layers (`_chunks`)
ARTIFACTS_DEFER_S = 0.2  # a node's artifacts wait this long at most for the next node's tasks (`submit_artifacts`)
DASK_MIN_PARALLEL_S = 0.5  # a cluster's workers are running already: only the round trips cost
DASK_CONNECT_S = 10.0  # seconds to reach the scheduler before the run fails

# The cost model (issue #30): serial CPU seconds of the work the workers can share, per unit of
# what a run holds. Measured on the bench vase (1,008,000 triangles, 133 layers, 68,000 path
# points), CPU seconds of one process: the preflight's sections (plane search, slab cuts, loops)
# ~2.5 µs per triangle cut, its footprints and overlays ~25 µs per path point, and ~5 ms per
# layer of per-layer overhead (a layer's own section, wall path, post-processing, report row).
COST_TRIANGLE_S = 2.5e-6
COST_LAYER_S = 5e-3
COST_POINT_S = 2.5e-5
# A layered value this long (and layer nodes to come) starts the workers at once: as many layers
# as the cost model needs to reach MIN_PARALLEL_S (400; it was 200, which started them for the
# bracket's 300 layers whatever the cost model said).
WARM_LAYERS = round(MIN_PARALLEL_S / COST_LAYER_S)
MESH_SUFFIXES = (".stl", ".obj", ".ply", ".off", ".3mf")  # files whose size says how many triangles


def default_workers() -> int:
    """`WAAMFLOW_LAYER_WORKERS`, else every core (1 = serial)."""
    env = os.environ.get("WAAMFLOW_LAYER_WORKERS")
    if env:
        try:
            return max(1, int(env))
        except ValueError:
            pass
    return max(1, os.cpu_count() or 1)


def parallel_work_s(triangles: int = 0, layers: int = 0, points: int = 0) -> float:
    """Expected serial seconds of the per-layer work a run of this size can spread over workers:
    the cost model (`COST_*`), from the mesh's triangles, the layers and the path points."""
    return triangles * COST_TRIANGLE_S + layers * COST_LAYER_S + points * COST_POINT_S


def wants_workers(
    workers: int, triangles: int = 0, layers: int = 0, points: int = 0, min_s: float | None = None, extra_s: float = 0.0
) -> bool:
    """Whether the workers pay for a run of this size (plus `extra_s`, the nodes to come's `Node.shared_work_s`): more
    than one, and more expected serial seconds than `min_s` (default `MIN_PARALLEL_S`, read at the call: starting them
    costs ~0.7 s of CPU on another core, and more in pickling, see MIN_PARALLEL_S)."""
    limit = MIN_PARALLEL_S if min_s is None else min_s
    return workers > 1 and parallel_work_s(triangles, layers, points) + extra_s > limit


def file_triangles(size: int, head: bytes) -> int:
    """Triangles a mesh file of `size` bytes holds, from its first 84 bytes: exact for a binary
    STL (84 + 50 per triangle), else one per 50 bytes (ASCII STL takes ~250 and OBJ ~60 per
    triangle: an upper bound for them, a lower one for zipped 3MF)."""
    if len(head) >= 84 and size == 84 + 50 * int.from_bytes(head[80:84], "little"):
        return int.from_bytes(head[80:84], "little")
    return size // 50


_all_asked: Any = None  # in a worker: the pool's event, set once every start-up task is submitted
ALL_ASKED_WAIT_S = 5.0  # at most (a parent that failed between its submits must not hang the workers)


def _worker_up() -> int:
    """A start-up task (`LayerPool._spawn`): waits until the parent has submitted all of them, so
    none ends early and leaves its worker idle for the next submit, which then forks no worker of
    its own (the executor forks only when no worker is idle): a pool of 2 came up with 1 now and
    then on a loaded machine."""
    if _all_asked is not None:
        _all_asked.wait(ALL_ASKED_WAIT_S)
    return os.getpid()


def _die_with_parent(all_asked: Any = None) -> None:
    """Worker initializer (Linux): SIGKILL when the process that forked it ends. Workers are
    forked by the fork server, which exits when the server does, so no worker outlives the
    server computing on (an orphaned worker grew to 2.3 GB). `all_asked`: the pool's start-up
    event (`_worker_up`)."""
    global _all_asked
    _all_asked = all_asked
    try:
        import ctypes
        import signal

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


class _Held(Future[Any]):
    """A task held back by the pool (`LayerPool.submit_artifacts`): asking for its result while
    held computes it here, the other held tasks going to the workers."""

    def __init__(self, pool: LayerPool) -> None:
        super().__init__()
        self._pool = pool

    def result(self, timeout: float | None = None) -> Any:
        self._pool._take_here(self)
        return super().result(timeout)


def _settle(fut: Future[Any], done: Future[Any]) -> None:
    """`fut` gets what the worker's future `done` got."""
    exc = done.exception() if not done.cancelled() else RuntimeError("cancelled")
    fut.set_exception(exc) if exc is not None else fut.set_result(done.result())


def _compute_here(fut: Future[Any], fn: Callable[..., Any], args: tuple[Any, ...]) -> None:
    """A held task computed in this process (the parent), its result or error into `fut`."""
    if fut.set_running_or_notify_cancel():
        try:
            fut.set_result(fn(*args))
        except Exception as exc:  # the run re-raises it where it collects the task (`_Run.run`)
            fut.set_exception(exc)


@dataclass
class LayerPool:
    """One process pool per run, started on first need and shared by the run's layer nodes."""

    workers: int
    tasks: int = 0
    map_tasks: int = 0
    started: bool = False  # workers asked for (by `warm` or a first map)
    _pool: ProcessPoolExecutor | None = field(default=None, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)
    _ready: threading.Event = field(default_factory=threading.Event, repr=False)
    _closed: bool = field(default=False, repr=False)
    _starter: threading.Thread | None = field(default=None, repr=False)
    _deferred: list[tuple[Future[Any], Callable[..., Any], tuple[Any, ...]]] = field(default_factory=list, repr=False)
    _timers: list[threading.Timer] = field(default_factory=list, repr=False)
    _holder: int = field(default=0, repr=False)  # the thread that holds artifacts: the run's, which writes them
    _all_asked: Any = field(default=None, repr=False)  # the start-up event the workers get (`_worker_up`)

    kind = "local"
    address = None

    @property
    def enabled(self) -> bool:
        return self.workers > 1

    @property
    def ready(self) -> bool:
        """Workers running: handing them work costs only the round trips."""
        return self._ready.is_set()

    @property
    def warming(self) -> bool:
        """Workers on their way (`warm`): until they are up, the parent computes layers itself
        (a submit now would wait for the fork server with the parent idle)."""
        return self.started and not self._ready.is_set()

    @property
    def min_parallel_s(self) -> float:
        return WARM_MIN_PARALLEL_S if self.ready else MIN_PARALLEL_S

    @property
    def offload_artifacts(self) -> bool:
        """Artifacts go to workers once the workers are up anyway."""
        return self.ready

    def info(self) -> dict[str, Any]:
        return {"kind": self.kind, "address": self.address, "workers": self.workers, "tasks": self.tasks}

    def warm(self) -> None:
        """Start the workers in the background (once): the fork server's imports and the forks run
        while the parent goes on. With this process's fork server up already, first wait up to
        `WARM_WAIT_S`: the forks alone take ~0.05 s, beside a parent computing (holding the
        interpreter lock the starting threads need) 0.15-0.3 s on the 500-layer cross."""
        if not self.enabled or self.started:
            return
        self.started = True
        if BACKGROUND_START:
            self._starter = threading.Thread(target=self._spawn, name="waamflow-layer-pool", daemon=True)
            self._starter.start()
            if _server_up:
                self._ready.wait(WARM_WAIT_S)
        else:
            self._spawn()

    def _spawn(self) -> None:
        try:
            pool = self._executor()
            futures = [pool.submit(_worker_up) for _ in range(self.workers)]  # no idle worker yet: each forks one
            self._all_asked.set()
            for f in futures:
                f.result()
        except Exception:  # the workers could not start: the parent computes alone
            return
        global _server_up
        _server_up = True
        self._ready.set()

    def _executor(self) -> ProcessPoolExecutor:
        with self._lock:
            if self._closed:
                raise RuntimeError("layer pool closed")
            if self._pool is None:
                ctx = mp.get_context("forkserver")
                ctx.set_forkserver_preload(PRELOAD)
                self._all_asked = ctx.Event()
                self._pool = ProcessPoolExecutor(
                    max_workers=self.workers,
                    mp_context=ctx,
                    initializer=_die_with_parent,
                    initargs=(self._all_asked,),
                )
                self.started = True
            return self._pool

    def submit_artifacts(
        self,
        impl: Any,
        node_id: str,
        params: Any,
        resolver: FileResolver,
        trace: dict[str, Any],
        outputs: dict[str, Any],
    ) -> Future[Any]:
        """A node's artifacts off the parent's path: a future of `_write_artifacts`' result, held
        until the next computing tasks are submitted. A map's wait has the parent write them
        (`_work_held`: nothing pickled to a worker and back); the rest, or those behind a single
        submit, go to the workers behind the tasks (`_release`); after `ARTIFACTS_DEFER_S` when no
        task comes. (The cross's sequence chunks had waited 0.13-0.24 s behind the strategy's and
        zone's toolpath artifacts: 1.3/1.5 MB pickled, unpickled in a worker, then written.)"""
        if self._closed:
            raise RuntimeError("layer pool closed")
        fut: Future[Any] = _Held(self)
        args = (impl, node_id, params.model_dump(mode="json"), resolver, trace, outputs)
        timer = threading.Timer(ARTIFACTS_DEFER_S, self._release)
        timer.daemon = True
        with self._lock:
            self._deferred.append((fut, _write_artifacts, args))
            self._timers.append(timer)
            self._holder = threading.get_ident()
        timer.start()
        return fut

    def release_held(self) -> None:
        """The held tasks to the workers now, not when a map comes or their timer ends: the run is
        about to compute with the workers idle (a node whose layers its chain tasks made ahead)."""
        self._cancel_timers()
        self._release()

    def _cancel_timers(self) -> None:
        """The held tasks' timers stopped: something sooner sends or writes them."""
        with self._lock:
            timers, self._timers = self._timers, []
        for timer in timers:
            timer.cancel()

    def _release(self) -> None:
        """The held tasks to the workers, in the order they were held (behind whatever was
        submitted before this call). A held task that cannot be submitted fails with the reason."""
        with self._lock:
            held, self._deferred = self._deferred, []
        for fut, fn, args in held:
            if not fut.set_running_or_notify_cancel():
                continue
            try:
                inner = self._executor().submit(fn, *args)
            except Exception as exc:  # closed or broken: the run writes them itself
                fut.set_exception(exc)
                continue
            inner.add_done_callback(functools.partial(_settle, fut))

    def _work_held(self, pending: Sequence[Future[Any]]) -> None:
        """The parent's wait for `pending` (tasks just submitted) spent on held tasks, one by one
        from the first task's end while any is unfinished (before, this process's threads pickle
        the tasks and need the interpreter lock: the cross's sequence chunks started 0.23 s late);
        the rest go to the workers behind them."""
        self._cancel_timers()  # a map came: the held tasks wait for the map's tasks, not for a timer
        if threading.get_ident() != self._holder:  # another thread's map (a node's own): not the run's to write
            return self._release()
        if self._deferred:
            wait(pending, return_when=FIRST_COMPLETED)
        while not all(f.done() for f in pending):
            with self._lock:
                if not self._deferred:
                    break
                fut, fn, args = self._deferred.pop(0)
            _compute_here(fut, fn, args)
        self._release()

    def _take_here(self, fut: Future[Any]) -> None:
        """`fut`, if still held, computed here now; the other held tasks to the workers first."""
        with self._lock:
            mine = [job for job in self._deferred if job[0] is fut]
            self._deferred = [job for job in self._deferred if job[0] is not fut]
        self._release()
        for job in mine:
            _compute_here(*job)

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any]) -> list[Any]:
        """fn over the items in the workers, results in item order (the preflight's layer tasks;
        counted in `map_tasks`, not in `tasks`, which are the nodes' layer chunks)."""
        pool = self._executor()
        futures = [pool.submit(fn, it) for it in items]
        self.map_tasks += len(futures)
        self._work_held(futures)
        try:
            return [f.result() for f in futures]
        finally:
            for f in futures:
                f.cancel()
            self._ready.set()

    def submit(self, fn: Callable[[Any], Any], item: Any) -> Future[Any]:
        """fn(item) in a worker (a node's `Context.submit`; counted in `map_tasks`)."""
        fut = self._executor().submit(fn, item)
        self.map_tasks += 1
        self._release()
        return fut

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
        """Compute `todo` [(index, items)] of the chain's first node, and the rest of the chain on
        its outputs, in workers; `on_done(index, [(outputs | None, warnings | error, seconds)] per
        link computed)` (see `run_chain`)
        is called in the parent as chunks finish (any order: the caller orders what must be);
        `on_ahead(results)`: what the `tail` ran ahead in a chunk."""
        chunks = _chunks(todo, self.workers)
        pool = self._executor()
        pending: set[Future[Any]] = {pool.submit(run_chain, chain, resolver, c, tail) for c in chunks}
        self.tasks += len(pending)
        self._work_held(list(pending))
        try:
            while pending:
                done, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
                for fut in done:
                    rows, ahead = fut.result()
                    for i, got in rows:
                        on_done(i, got)
                    if ahead and on_ahead is not None:
                        on_ahead(ahead)
                if cancelled():
                    break
        finally:
            for fut in pending:
                fut.cancel()
            self._ready.set()  # the workers are up now

    def close(self, wait: bool = True) -> None:
        """Shut the workers down; `wait=False` (a failed or cancelled run) kills them: a chunk still
        running ends with the run instead of computing on (and growing) after it. Workers still
        starting are waited for (a process whose parent has gone would fail half-started)."""
        if self._starter is not None:
            self._starter.join(timeout=60)
        with self._lock:
            self._closed = True
            pool, self._pool = self._pool, None
            held, self._deferred = self._deferred, []
        for fut, _fn, _args in held:  # never submitted: the run is over (a finished one collected them)
            fut.cancel()
        if pool is not None:
            procs = list((getattr(pool, "_processes", None) or {}).values())
            pool.shutdown(wait=wait, cancel_futures=True)
            if not wait:  # a cancelled or failed run: its workers end with it, not after their chunk
                for p in procs:
                    try:
                        p.kill()
                    except (OSError, ValueError, AttributeError):
                        pass
                for p in procs:
                    p.join(timeout=1.0)

    def pids(self) -> list[int]:
        """Process ids of the run's workers (for the memory limit and tests)."""
        pool = self._pool
        return [p.pid for p in (getattr(pool, "_processes", None) or {}).values() if p.pid] if pool else []


def _chunks(todo: list[Any], workers: int) -> list[list[Any]]:
    """Guided chunks: each takes 1/(2·workers) of what is left, down to 1/(workers·
    CHUNKS_PER_WORKER·4) of the whole, so the first are large (few round trips) and the last
    small (a worker finishing early waits for little: the run's tail is one small chunk, not one
    of equal size)."""
    w = max(1, workers)
    smallest = max(1, -(-len(todo) // (w * CHUNKS_PER_WORKER * 4)))
    out, k = [], 0
    while k < len(todo):
        size = max(smallest, -(-(len(todo) - k) // (2 * w)))
        out.append(todo[k : k + size])
        k += size
    return out


@dataclass
class RunWorkers:
    """A run's local workers as the preflight sees them (`preflight.slabs.Workers`): the cost
    model's verdict on a piece of work, and a map that falls back to this process when the
    workers fail (a task's own error is raised again here, where it is reported)."""

    pool: LayerPool

    @property
    def count(self) -> int:
        return self.pool.workers

    def pays(self, triangles: int, layers: int, points: int, extra_s: float = 0.0) -> bool:
        return wants_workers(self.count, triangles, layers, points, self.pool.min_parallel_s, extra_s)

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any]) -> list[Any]:
        try:
            return self.pool.map(fn, items)
        except Exception:  # a worker died or the pool could not start: compute here
            return [fn(it) for it in items]

    def submit(self, fn: Callable[[Any], Any], item: Any) -> Future[Any] | None:
        """fn(item) started in a worker (a future), when the workers are up; None otherwise (the
        caller computes it: waiting for them to start would leave it idle)."""
        if not self.pool.ready:
            return None
        try:
            fut = self.pool._executor().submit(fn, item)
        except RuntimeError:  # the pool closed or broke
            return None
        self.pool.map_tasks += 1
        self.pool._release()
        return fut


def make_pool(workers: int | None = None, scheduler: str | None = None) -> LayerPool | DaskPool:
    """The run's pool: a Dask cluster when `scheduler` is given, else local processes."""
    if scheduler:
        from .daskpool import DaskPool

        pool = DaskPool(scheduler)
        pool.client()  # a wrong address fails here, before any planning
        return pool
    return LayerPool(default_workers() if workers is None else max(1, int(workers)))
