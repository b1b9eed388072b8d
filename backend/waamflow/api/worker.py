"""Background run execution: a thread pool sized to the machine, cancel flags, live event logs.

Each run executes in a process of its own (forked from the server by the run's thread), the leader
of a process group that holds its whole tree: its layer workers come from a fork server of its
own, started by the run's process. The run memory limit (`run_memory_mb`) is one budget for that
tree (tree_memory.py, which also starts the trees): a child cgroup's `memory.max` where the server may create one, else the
server's watchdog summing the group's private memory and killing the group over the budget. Each
process also gets that budget as its address-space cap (RLIMIT_AS), so a single allocation past it
fails at once as a MemoryError that names the node. Events and the result come back over a pipe;
cancel is a shared flag, then SIGKILL to the group when the run does not stop in time. Previews
compute in a long-lived preview worker process under the same budget (preview_worker.py). With
`run_memory_mb` 0 runs and previews execute in the server's process, as before.
"""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import logging
import multiprocessing as mp
from pathlib import Path
import signal
import threading
import time
from typing import TYPE_CHECKING, Any, Callable
import uuid

from ..core.errors import CancelledError, WaamflowError
from ..core.model import LayerPaths, Layered
from ..engine.artifacts import write_run_dir
from ..engine.events import TERMINAL_KINDS, Event, EventKind
from ..engine.executor import FileResolver, RunResult, execute
from ..engine.graph import build_graph
from ..engine.recipe import Recipe
from ..preflight import gate
from .run_limits import LimitError as LimitError
from .run_limits import Limits as Limits
from .run_limits import QueueFullError as QueueFullError
from .run_limits import RUN_PROCESSES as RUN_PROCESSES
from .run_limits import _fork_available as _fork_available
from .run_limits import is_memory_error as is_memory_error
from .run_limits import memory_limit_message as memory_limit_message
from .run_limits import rss_bytes as rss_bytes
from .run_limits import where_text as where_text
from .store import Store, valid_file_name
from .tree_memory import Tree, start_tree, tree_limit_message

if TYPE_CHECKING:
    from .preview_worker import PreviewJob, PreviewPool

log = logging.getLogger("waamflow.runs")


def _child_cache(cache):
    """The run process's cache: a fresh memory tier (the server's may be locked by another thread at
    the fork) over its own connection to the same disk cache."""
    from ..engine.cache import MemoryCache, SqliteCache, TieredCache

    if isinstance(cache, TieredCache):
        disk = SqliteCache(cache.disk.path, max_bytes=cache.disk.max_bytes) if cache.disk is not None else None
        return TieredCache(MemoryCache(cache.memory.max_entries), disk)
    return MemoryCache() if cache is not None else None


PREVIEW_WAIT_S = 10.0  # a preview waits this long for its turn before 429
CANCEL_GRACE_S = 1.5  # a cancelled run whose thread has not ended by then (a blocking read) is ended for it


def point_count(outputs: dict) -> int:
    """Path points of a run's outputs (all LayerPaths of all nodes)."""
    n = 0
    for ports in outputs.values():
        for value in (ports or {}).values():
            if isinstance(value, Layered):
                for it in value.items:
                    if isinstance(it, LayerPaths):
                        n += sum(len(sp.points) for sp in it.sections)
    return n


class LiveRun:
    """Events of a run in memory (for streaming) until it ends; then they are in the store."""

    def __init__(self, run_id: str) -> None:
        self.id = run_id
        self.events: list[dict] = []
        self.cancel = threading.Event()
        self.done = threading.Event()
        self.lock = threading.Lock()
        self.limit: str | None = None  # why a limit stopped the run
        self.finished = False  # _finish ran (once, by the run's thread or the watchdog)
        self.slot = False  # holds one of the manager's run slots
        # the engine's terminal event, streamed by `_finish` once the run's record is stored
        self.held: dict | None = None
        self.where: dict = {}  # the node (and layer) of the last event that named one

    def trip(self, reason: str) -> None:
        if self.limit is None:
            self.limit = reason
        self.cancel.set()

    def add(self, ev: dict) -> None:
        with self.lock:
            self.events.append(ev)

    def since(self, seq: int) -> list[dict]:
        with self.lock:
            return [e for e in self.events if e["seq"] > seq]


class RunManager:
    def __init__(
        self,
        store: Store,
        data_dir: Path,
        cache,
        workers: int,
        resolver_for: Callable[[str | None, Recipe, str | None], FileResolver],
        on_done: Callable[[str, str | None, Recipe, RunResult], None] | None = None,
        limits: Limits | None = None,
        layer_workers: int | None = None,
        scheduler: str | None = None,
    ) -> None:
        self.limits = limits or Limits()
        self.layer_workers = layer_workers
        self.scheduler = scheduler
        self.store = store
        self.runs_dir = data_dir / "runs"
        self.runs_dir.mkdir(parents=True, exist_ok=True)
        self.cache = cache
        self.workers = workers
        self.slots = threading.BoundedSemaphore(workers)
        self.threads: dict[str, threading.Thread] = {}
        self.closing = False
        self.previews = 0  # previews waiting or computing (counted in the queue limit)
        self.computing = 0  # previews computing: at most `workers`, the others wait their turn
        self.plock = threading.Lock()
        self.preview_pool: PreviewPool | None = None  # preview workers (with run_memory_mb), made on first use
        self.trees: dict[str, Tree] = {}  # the process trees of runs going on
        self.live: dict[str, LiveRun] = {}
        self.resolver_for = resolver_for
        self.on_done = on_done

    def submit(
        self, graph_name: str | None, recipe: Recipe, params_xml: str | None = None, *, accept_preflight: bool = False
    ) -> str:
        """Validate now (so a bad recipe is a 422, not a failed run), then queue. `params_xml` is a
        draft zone-parameter file used for this run only."""
        graph = build_graph(recipe)
        active = self.active()
        if self.limits.queue and active >= self.limits.queue:
            raise QueueFullError(
                f"{active} runs are queued or running (limit {self.limits.queue}): try again later",
                retry_after=max(1, min(60, int(self.limits.wall_s or 30) // 10 or 5)),
            )
        self.limits.check_estimate(graph, self.resolver_for(graph_name, recipe, params_xml))
        run_id = uuid.uuid4().hex[:12]
        self.store.create_run(run_id, graph_name, recipe.to_json(), recipe.inputs, params_xml)
        live = LiveRun(run_id)
        self.live[run_id] = live
        t = threading.Thread(
            target=self._slot_run,
            args=(run_id, graph_name, recipe, graph, live, params_xml, accept_preflight),
            name=f"waamflow-run-{run_id}",
            daemon=True,
        )
        self.threads[run_id] = t
        t.start()
        return run_id

    def _slot_run(self, *args) -> None:
        """A run's thread: waits for one of the `workers` slots, runs, and gives the slot back when
        the run has ended (by its thread, or by the watchdog for a run that did not stop)."""
        live: LiveRun = args[4]
        while not self.slots.acquire(timeout=0.2):
            if self.closing or live.cancel.is_set():
                break
        else:
            live.slot = True
        try:
            self._run(*args)
        finally:
            self.threads.pop(args[0], None)

    def active(self) -> int:
        """Runs queued or running plus previews computing (the queue limit counts both)."""
        # `finished`, set before the run's record says it ended (a client that saw it end is not refused)
        return sum(1 for lv in list(self.live.values()) if not lv.finished) + self.previews

    def preview(self, fn: Callable[..., Any], args: tuple) -> "PreviewJob":
        """A preview `fn(cache, cancel, *args)` (a module-level function: it may be sent to a preview
        worker) under the run queue's limits: counted in the queue (429 when full), at most `workers`
        at once (429), stopped by `cancel` on wall time (preview_timeout_s) or memory, in a preview
        worker under the run memory limit when runs execute in processes (preview_worker.py)."""
        from .preview_worker import PreviewJob, PreviewPool

        with self.plock:
            if self.limits.queue and self.active() >= self.limits.queue:
                raise QueueFullError(
                    f"{self.active()} runs and previews are queued or running (limit "
                    f"{self.limits.queue}): try again later",
                    retry_after=2,
                )
            self.previews += 1
            if self.limits.run_memory_bytes and self.preview_pool is None:
                self.preview_pool = PreviewPool(self)
        return PreviewJob(self, fn, args)

    def run_dir(self, run_id: str) -> Path:
        return self.runs_dir / run_id

    def cancel(self, run_id: str) -> bool:
        live = self.live.get(run_id)
        if live is None or live.done.is_set():
            return False
        live.cancel.set()
        return True

    def _run(
        self,
        run_id: str,
        graph_name: str | None,
        recipe: Recipe,
        graph,
        live: LiveRun,
        params_xml: str | None = None,
        accept_preflight: bool = False,
    ) -> None:
        if live.cancel.is_set():
            self._finish(
                run_id,
                live,
                "cancelled",
                error={"kind": "cancelled", "message": "cancelled before start", "text": "cancelled before start"},
            )
            return
        self.store.update_run(run_id, status="running", started=time.time())
        last_progress = [0.0]
        lim = self.limits
        watchdog = threading.Thread(target=self._watch, args=(live,), name=f"waamflow-limits-{run_id}", daemon=True)
        watchdog.start()

        def on_dict(d: dict) -> None:
            layer = d.get("layer")
            if d.get("node"):
                live.where = {"node": d["node"], "layer": layer}
            if lim.layers and layer is not None and layer >= lim.layers:
                live.trip(f"more than {lim.layers} layers (limit max_layers)")
            if d.get("kind") in TERMINAL_KINDS:  # streamed by _finish, after the record is stored
                live.held = d
                return
            live.add(d)
            now = time.monotonic()
            if now - last_progress[0] > 0.5:
                last_progress[0] = now
                self.store.update_run(run_id, progress=round(float(d.get("progress") or 0.0), 4))

        def on_event(ev: Event) -> None:
            on_dict(ev.to_dict())

        if lim.run_memory_bytes:
            return self._run_process(run_id, graph_name, recipe, graph, live, params_xml, accept_preflight, on_dict)
        try:
            resolver = self.resolver_for(graph_name, recipe, params_xml)
            result = execute(
                graph,
                resolver=resolver,
                cache=self.cache,
                on_event=on_event,
                cancel=live.cancel,
                workers=self.layer_workers,
                scheduler=self.scheduler,
                max_layers=lim.layers,
            )
            self._check_result(result)
            summary = self._write_result(run_id, recipe, result, accept_preflight)
            self._done(run_id, graph_name, recipe, result, live, summary)
        except CancelledError as err:
            if live.limit is not None:
                self._finish(run_id, live, "failed", error=LimitError(f"stopped: {live.limit}").to_dict())
            else:
                self._finish(run_id, live, "cancelled", error=err.to_dict())
        except WaamflowError as err:
            self._finish(run_id, live, "failed", error=err.to_dict())
        except Exception as exc:  # pragma: no cover - last resort: never leave a run 'running'
            log.exception("run %s crashed", run_id)
            self._finish(run_id, live, "failed", error={"kind": "internal", "message": repr(exc), "text": repr(exc)})

    def _write_result(self, run_id: str, recipe: Recipe, result, accept_preflight: bool) -> dict:
        """The finished run's folder (artifacts the preflight lets out, summary.json); its summary.
        In the run's process or, with run_memory_mb 0, in the server's."""
        summary = result.summary(recipe.name)
        summary["inputs"] = recipe.inputs
        files, _failed = gate(
            result.preflight, result.artifacts, accept_preflight, "accept_preflight in POST /api/runs"
        )
        summary["preflight"] = result.preflight
        summary["artifacts"] = sorted(files)
        write_run_dir(self.run_dir(run_id), files, summary)
        return summary

    def _done(self, run_id: str, graph_name: str | None, recipe: Recipe, result, live: LiveRun, summary: dict) -> None:
        """A run that ended well: the post-run hook (viewer, parameter store), then its record."""
        if self.on_done is not None:
            try:
                self.on_done(run_id, graph_name, recipe, result)
            except Exception:  # the viewer or params store must not fail a finished run
                log.exception("post-run hook failed for run %s", run_id)
        self._finish(run_id, live, "done", summary=summary)

    @contextlib.contextmanager
    def _quiet_sqlite(self):
        """Hold the server's SQLite users (the store, the disk cache) while the run's process is
        forked: SQLite's process-wide mutexes (its allocator's among them) are copied into the child
        in whatever state another thread left them, and a child forked while a store query ran
        hung in its first `sqlite3.connect` (1 run in ~15 under concurrent polling). Every query of
        the store and the cache runs under these locks, so none is inside SQLite at the fork."""
        locks = [
            lk
            for lk in (getattr(self.store, "_lock", None), getattr(getattr(self.cache, "disk", None), "_lock", None))
            if lk is not None
        ]
        with contextlib.ExitStack() as stack:
            for lk in locks:
                stack.enter_context(lk)
            yield

    def _run_process(
        self,
        run_id: str,
        graph_name: str | None,
        recipe: Recipe,
        graph: Any,
        live: LiveRun,
        params_xml: str | None,
        accept_preflight: bool,
        on_dict: Callable[[dict], None],
    ) -> None:
        """The run in a process tree of its own under the memory limit (see the module's doc)."""
        try:
            resolver = self.resolver_for(graph_name, recipe, params_xml)
        except WaamflowError as err:
            self._finish(run_id, live, "failed", error=err.to_dict())
            return
        ctx = mp.get_context("fork")
        reader, writer = ctx.Pipe(duplex=False)
        stop = ctx.Event()
        outcome = None
        tree: Tree | None = None
        try:
            tree = start_tree(
                self._quiet_sqlite,
                self.limits.run_memory_bytes,
                _run_child,
                (self, writer, stop, run_id, recipe, graph, resolver, accept_preflight),
                f"run-{run_id}",
            )
            self.trees[run_id] = tree
            writer.close()
            outcome = self._await_run(tree, reader, stop, live, on_dict)
        except Exception as exc:  # pragma: no cover - never leave a run 'running'
            log.exception("run %s: its process failed", run_id)
            outcome = ("failed", {"kind": "internal", "message": repr(exc), "text": repr(exc)})
        finally:
            reader.close()
            if tree is not None:
                tree.end(patient=outcome is not None)  # whatever is left of the tree ends now
                self.trees.pop(run_id, None)
        self._run_outcome(run_id, graph_name, recipe, live, tree, outcome)

    def _await_run(
        self, tree: Tree, reader: Any, stop: Any, live: LiveRun, on_dict: Callable[[dict], None]
    ) -> tuple | None:
        """The run's events until its outcome (None: it ended without one, or was ended)."""
        proc = tree.proc
        while True:
            if live.cancel.is_set():
                stop.set()
            if live.finished:  # the watchdog ended a run that did not stop: it is killed by the caller
                return None
            if tree.over() is not None:
                return None
            if reader.poll(0.1):
                try:
                    msg = reader.recv()
                except (EOFError, OSError):
                    return None
                if msg[0] != "event":
                    return msg
                on_dict(msg[1])
            elif not proc.is_alive() and not reader.poll(0):
                return None

    def _run_outcome(
        self,
        run_id: str,
        graph_name: str | None,
        recipe: Recipe,
        live: LiveRun,
        tree: Tree | None,
        outcome: tuple | None,
    ) -> None:
        """The run's record from what its process sent (or did not send)."""
        budget = self.limits.run_memory_bytes
        if tree is not None and tree.out_of_memory() and (outcome is None or outcome[0] != "done"):
            used = tree.over_by or (tree.cgroup.peak() if tree.cgroup is not None else 0)
            msg = tree_limit_message("the run", budget, used, tree.watch.processes, where_text(live.where))
            err = LimitError(msg, node=live.where.get("node"), layer=live.where.get("layer"))
            self._finish(run_id, live, "failed", error=err.to_dict())
            return
        if outcome is None:
            if live.finished:
                return
            if live.cancel.is_set() and live.limit is None:
                why = "cancelled"
                self._finish(run_id, live, "cancelled", error={"kind": "cancelled", "message": why, "text": why})
                return
            code = tree.proc.exitcode if tree is not None else None
            how = f"signal {signal.Signals(-code).name}" if code is not None and code < 0 else f"exit code {code}"
            msg = (
                f"the run's process ended without a result ({how}); it may have used more than "
                f"{budget / 2**20:.0f} MB, its memory limit (run_memory_mb): raise --run-memory-mb / "
                "WAAMFLOW_RUN_MEMORY_MB"
            )
            if live.limit is not None:
                msg = f"stopped: {live.limit}"
            self._finish(run_id, live, "failed", error=LimitError(msg).to_dict())
            return
        kind = outcome[0]
        if kind == "done":
            self._done(run_id, graph_name, recipe, outcome[2], live, outcome[1])
        elif kind == "cancelled":
            if live.limit is not None:
                self._finish(run_id, live, "failed", error=LimitError(f"stopped: {live.limit}").to_dict())
            else:
                self._finish(run_id, live, "cancelled", error=outcome[1])
        elif kind == "memory":
            where = outcome[1] or {}
            err = LimitError(memory_limit_message(budget, where), node=where.get("node"), layer=where.get("layer"))
            self._finish(run_id, live, "failed", error=err.to_dict())
        else:
            self._finish(run_id, live, "failed", error=outcome[1])

    def _watch(self, live: LiveRun) -> None:
        """Wall-time and memory limits of one run, checked twice a second until it ends."""
        t0 = time.monotonic()
        lim = self.limits
        cancelled_at = None
        while not live.done.wait(0.25):
            if lim.wall_s and time.monotonic() - t0 > lim.wall_s:
                live.trip(f"ran longer than {lim.wall_s:g} s (limit run_timeout_s)")
            if lim.memory_bytes and rss_bytes() > lim.memory_bytes:
                live.trip(
                    f"server memory over {lim.memory_bytes / 2**20:.0f} MB with its workers (limit max_memory_mb)"
                )
            if live.cancel.is_set():
                cancelled_at = cancelled_at or time.monotonic()
                if time.monotonic() - cancelled_at > CANCEL_GRACE_S:
                    # the run's thread is stuck where cancel is not looked at (a blocking read):
                    # the run ends now; the thread's result, if it ever comes, is dropped
                    why = "cancelled (the run did not stop by itself within 1.5 s and was abandoned)"
                    if live.limit is not None:
                        self._finish(live.id, live, "failed", error=LimitError(f"stopped: {live.limit}").to_dict())
                    else:
                        self._finish(
                            live.id, live, "cancelled", error={"kind": "cancelled", "message": why, "text": why}
                        )
                    return

    def _check_result(self, result: RunResult) -> None:
        lim = self.limits
        if lim.layers and (result.layer_count or 0) > lim.layers:
            raise LimitError(f"{result.layer_count} layers, over the limit of {lim.layers} (max_layers)")
        if lim.points:
            n = point_count(result.outputs)
            if n > lim.points:
                raise LimitError(f"{n} path points, over the limit of {lim.points} (max_points)")
        for name in result.artifacts:
            if not valid_file_name(name):
                raise WaamflowError(f"artifact name {name!r} is not a plain file name (letters, digits, _ . -)")
        size = sum(len(b) for b in result.artifacts.values())
        if lim.artifact_bytes and size > lim.artifact_bytes:
            raise LimitError(
                f"artifacts of {size / 2**20:.1f} MB, over the limit of "
                f"{lim.artifact_bytes / 2**20:.0f} MB (max_artifact_mb)"
            )

    def _finish(
        self, run_id: str, live: LiveRun, status: str, *, summary: dict | None = None, error: dict | None = None
    ) -> None:
        with live.lock:
            if live.finished:  # ended already (the watchdog ended a run that did not stop)
                return
            live.finished = True
        kinds: dict[str, EventKind] = {"done": "run_finished", "failed": "run_failed", "cancelled": "run_cancelled"}
        kind = kinds[status]
        held = live.held
        if held is not None and held.get("kind") == kind:
            terminal = held
        else:  # none, or another (e.g. a limit turns the engine's run_cancelled into run_failed)
            terminal = Event(
                kind=kind,
                seq=len(live.events) + 1,
                progress=1.0 if status == "done" else 0.0,
                message=(error or {}).get("text", status),
                error=error,
            ).to_dict()
        # the record first: whoever sees the terminal event finds the run ended, its summary stored
        fields = dict(status=status, finished=time.time(), summary=summary, error=error)
        if status == "done":
            fields["progress"] = 1.0
        self.store.update_run(run_id, **fields)
        live.add(terminal)
        self.store.add_events(run_id, live.events)
        live.done.set()
        if live.slot:
            live.slot = False
            self.slots.release()
        # the events are in the store now; streams that still hold `live` finish from it
        self.live.pop(run_id, None)

    def events_since(self, run_id: str, seq: int) -> tuple[list[dict], bool]:
        """New events after `seq`, and whether the run has ended."""
        live = self.live.get(run_id)
        if live is not None:
            evs = live.since(seq)
            return evs, live.done.is_set() and not live.since(seq + len(evs))
        return self.store.get_events(run_id, seq), True

    def shutdown(self) -> None:
        self.closing = True
        for live in list(self.live.values()):
            live.cancel.set()
        deadline = time.monotonic() + 10.0
        for t in list(self.threads.values()):
            t.join(timeout=max(0.0, deadline - time.monotonic()))
        for tree in list(self.trees.values()):  # runs that did not end in time end now, with every process
            tree.kill()
        if self.preview_pool is not None:
            self.preview_pool.close()


def _run_child(
    manager: RunManager,
    conn: Any,
    stop: Any,
    run_id: str,
    recipe: Recipe,
    graph: Any,
    resolver: Any,
    accept_preflight: bool,
) -> None:
    """A run's process (a tree's leader, see `_tree_child`): execute, check, write the run folder,
    send the summary and the result (without artifacts: they are in the folder) — or why it failed."""
    lim = manager.limits
    # what this process inherited from the server is frozen: its collections neither scan those
    # objects nor write to their pages, which stay shared with the server (not the run's memory)
    gc.freeze()
    try:
        cache = _child_cache(manager.cache)
        result = execute(
            graph,
            resolver=resolver,
            cache=cache,
            on_event=lambda ev: conn.send(("event", ev.to_dict())),
            cancel=stop,
            workers=manager.layer_workers,
            scheduler=manager.scheduler,
            max_layers=lim.layers,
        )
        manager._check_result(result)
        summary = manager._write_result(run_id, recipe, result, accept_preflight)
        conn.send(("done", summary, dataclasses.replace(result, artifacts={})))
    except CancelledError as err:
        conn.send(("cancelled", err.to_dict()))
    except MemoryError:
        conn.send(("memory", None))
    except WaamflowError as err:
        conn.send(("memory", err.to_dict()) if is_memory_error(err) else ("failed", err.to_dict()))
    except Exception as exc:
        if is_memory_error(exc):
            conn.send(("memory", None))
        else:
            conn.send(("failed", {"kind": "internal", "message": repr(exc), "text": repr(exc)}))
    finally:
        conn.close()
