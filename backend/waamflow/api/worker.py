"""Background run execution: a thread pool sized to the machine, cancel flags, live event logs."""

from __future__ import annotations

import logging
import os
import threading
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from ..core.errors import CancelledError, WaamflowError
from ..core.model import LayerPaths, Layered
from ..engine.artifacts import write_run_dir
from ..engine.events import TERMINAL_KINDS, Event
from ..preflight import gate
from ..engine.executor import FileResolver, RunResult, execute
from ..engine.graph import build_graph
from ..engine.estimate import check_estimate, estimate
from ..engine.recipe import Recipe
from .store import Store, valid_file_name

log = logging.getLogger("waamflow.runs")


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

    @classmethod
    def from_settings(cls, s) -> "Limits":
        return cls(wall_s=s.run_timeout_s, layers=s.max_layers, points=s.max_points,
                   artifact_bytes=int(s.max_artifact_mb * 1024 * 1024), memory_bytes=int(s.max_memory_mb * 1024 * 1024),
                   queue=s.max_queued_runs, triangles=s.max_triangles, dxf_entities=s.max_dxf_entities,
                   uncompressed_bytes=int(s.max_uncompressed_mb * 2**20), preview_s=s.preview_timeout_s)

    def check_estimate(self, graph, resolver) -> dict:
        """Before a run or preview: its estimate (layers, triangles, DXF entities, 3MF size) against
        these limits → EstimateError (422) naming the estimate; else the estimate."""
        est = estimate(graph, resolver)
        check_estimate(est, max_layers=self.layers, max_triangles=self.triangles, max_dxf_entities=self.dxf_entities,
                       max_uncompressed_bytes=self.uncompressed_bytes)
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


PREVIEW_WAIT_S = 10.0  # a preview waits this long for its turn before 429
CANCEL_GRACE_S = 1.5   # a cancelled run whose thread has not ended by then (a blocking read) is ended for it


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
        self.finished = False   # _finish ran (once, by the run's thread or the watchdog)
        self.slot = False       # holds one of the manager's run slots

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
    def __init__(self, store: Store, data_dir: Path, cache, workers: int,
                 resolver_for: Callable[[str | None, Recipe, str | None], FileResolver],
                 on_done: Callable[[str, str | None, Recipe, RunResult], None] | None = None,
                 limits: Limits | None = None, layer_workers: int | None = None,
                 scheduler: str | None = None) -> None:
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
        self.previews = 0          # previews waiting or computing (counted in the queue limit)
        self.computing = 0         # previews computing: at most `workers`, the others wait their turn
        self.plock = threading.Lock()
        self.live: dict[str, LiveRun] = {}
        self.resolver_for = resolver_for
        self.on_done = on_done

    def submit(self, graph_name: str | None, recipe: Recipe, params_xml: str | None = None, *,
               accept_preflight: bool = False) -> str:
        """Validate now (so a bad recipe is a 422, not a failed run), then queue. `params_xml` is a
        draft zone-parameter file used for this run only."""
        graph = build_graph(recipe)
        active = self.active()
        if self.limits.queue and active >= self.limits.queue:
            raise QueueFullError(f"{active} runs are queued or running (limit {self.limits.queue}): try again later",
                                 retry_after=max(1, min(60, int(self.limits.wall_s or 30) // 10 or 5)))
        self.limits.check_estimate(graph, self.resolver_for(graph_name, recipe, params_xml))
        run_id = uuid.uuid4().hex[:12]
        self.store.create_run(run_id, graph_name, recipe.to_json(), recipe.inputs, params_xml)
        live = LiveRun(run_id)
        self.live[run_id] = live
        t = threading.Thread(target=self._slot_run, args=(run_id, graph_name, recipe, graph, live, params_xml,
                                                          accept_preflight), name=f"waamflow-run-{run_id}", daemon=True)
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
        return sum(1 for lv in list(self.live.values()) if not lv.done.is_set()) + self.previews

    def preview(self, work: Callable[[threading.Event], Any]) -> "PreviewJob":
        """A preview under the run queue's limits: counted in the queue (429 when full), at most
        `workers` at once (429), stopped by `cancel` on wall time (preview_timeout_s) or memory."""
        with self.plock:
            if self.limits.queue and self.active() >= self.limits.queue:
                raise QueueFullError(f"{self.active()} runs and previews are queued or running (limit "
                                     f"{self.limits.queue}): try again later", retry_after=2)
            self.previews += 1
        return PreviewJob(self, work)

    def run_dir(self, run_id: str) -> Path:
        return self.runs_dir / run_id

    def cancel(self, run_id: str) -> bool:
        live = self.live.get(run_id)
        if live is None or live.done.is_set():
            return False
        live.cancel.set()
        return True

    def _run(self, run_id: str, graph_name: str | None, recipe: Recipe, graph, live: LiveRun,
             params_xml: str | None = None, accept_preflight: bool = False) -> None:
        if live.cancel.is_set():
            self._finish(run_id, live, "cancelled", error={"kind": "cancelled", "message": "cancelled before start",
                                                           "text": "cancelled before start"})
            return
        self.store.update_run(run_id, status="running", started=time.time())
        last_progress = [0.0]
        lim = self.limits
        watchdog = threading.Thread(target=self._watch, args=(live,), name=f"waamflow-limits-{run_id}", daemon=True)
        watchdog.start()

        def on_event(ev: Event) -> None:
            if lim.layers and ev.layer is not None and ev.layer >= lim.layers:
                live.trip(f"more than {lim.layers} layers (limit max_layers)")
            d = ev.to_dict()
            live.add(d)
            now = time.monotonic()
            if now - last_progress[0] > 0.5:
                last_progress[0] = now
                self.store.update_run(run_id, progress=round(ev.progress, 4))

        try:
            resolver = self.resolver_for(graph_name, recipe, params_xml)
            result = execute(graph, resolver=resolver, cache=self.cache, on_event=on_event, cancel=live.cancel,
                             workers=self.layer_workers, scheduler=self.scheduler, max_layers=lim.layers)
            self._check_result(result)
            summary = result.summary(recipe.name)
            summary["inputs"] = recipe.inputs
            files, _failed = gate(result.preflight, result.artifacts, accept_preflight,
                                  "accept_preflight in POST /api/runs")
            summary["preflight"] = result.preflight
            summary["artifacts"] = sorted(files)
            write_run_dir(self.run_dir(run_id), files, summary)
            if self.on_done is not None:
                try:
                    self.on_done(run_id, graph_name, recipe, result)
                except Exception:  # the viewer or params store must not fail a finished run
                    log.exception("post-run hook failed for run %s", run_id)
            self._finish(run_id, live, "done", summary=summary)
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

    def _watch(self, live: LiveRun) -> None:
        """Wall-time and memory limits of one run, checked twice a second until it ends."""
        t0 = time.monotonic()
        lim = self.limits
        cancelled_at = None
        while not live.done.wait(0.25):
            if lim.wall_s and time.monotonic() - t0 > lim.wall_s:
                live.trip(f"ran longer than {lim.wall_s:g} s (limit run_timeout_s)")
            if lim.memory_bytes and rss_bytes() > lim.memory_bytes:
                live.trip(f"server memory over {lim.memory_bytes / 2**20:.0f} MB with its workers (limit max_memory_mb)")
            if live.cancel.is_set():
                cancelled_at = cancelled_at or time.monotonic()
                if time.monotonic() - cancelled_at > CANCEL_GRACE_S:
                    # the run's thread is stuck where cancel is not looked at (a blocking read):
                    # the run ends now; the thread's result, if it ever comes, is dropped
                    why = "cancelled (the run did not stop by itself within 1.5 s and was abandoned)"
                    if live.limit is not None:
                        self._finish(live.id, live, "failed", error=LimitError(f"stopped: {live.limit}").to_dict())
                    else:
                        self._finish(live.id, live, "cancelled", error={"kind": "cancelled", "message": why, "text": why})
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
            raise LimitError(f"artifacts of {size / 2**20:.1f} MB, over the limit of "
                             f"{lim.artifact_bytes / 2**20:.0f} MB (max_artifact_mb)")

    def _finish(self, run_id: str, live: LiveRun, status: str, *, summary: dict | None = None,
                error: dict | None = None) -> None:
        with live.lock:
            if live.finished:   # ended already (the watchdog ended a run that did not stop)
                return
            live.finished = True
        kind = {"done": "run_finished", "failed": "run_failed", "cancelled": "run_cancelled"}[status]
        terminal = [e.get("kind") for e in live.events if e.get("kind") in TERMINAL_KINDS]
        if not terminal or terminal[-1] != kind:  # e.g. a limit turns the engine's run_cancelled into run_failed
            live.add(Event(kind=kind, seq=len(live.events) + 1, progress=1.0 if status == "done" else 0.0,
                           message=(error or {}).get("text", status), error=error).to_dict())
        self.store.add_events(run_id, live.events)
        fields = dict(status=status, finished=time.time(), summary=summary, error=error)
        if status == "done":
            fields["progress"] = 1.0
        self.store.update_run(run_id, **fields)
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


class PreviewStopped(LimitError):
    """A preview stopped by a limit (or its client leaving): 422 naming the limit."""

    http_status = 422


class PreviewJob:
    """One preview: `run()` computes `work(cancel)` in a thread while the caller watches for the
    client leaving (`cancel`), with the preview's wall-time and memory limits."""

    def __init__(self, manager: RunManager, work: Callable[[threading.Event], Any]) -> None:
        self.manager = manager
        self.work = work
        self.cancel = threading.Event()
        self.limit: str | None = None

    def _result(self, fut):
        try:
            return fut.result()
        except CancelledError:
            if self.limit is not None:
                raise PreviewStopped(f"preview stopped: {self.limit}") from None
            raise

    async def run(self, disconnected: Callable[[], Any]) -> Any:
        import asyncio

        lim = self.manager.limits
        m = self.manager
        t0 = time.monotonic()
        computing = False
        try:
            while True:   # a turn among the `workers` previews computing at once
                with m.plock:
                    if m.computing < m.workers:
                        m.computing += 1
                        computing = True
                        break
                if await disconnected():
                    raise PreviewStopped("preview stopped: the client left before its turn")
                if time.monotonic() - t0 > PREVIEW_WAIT_S:
                    raise QueueFullError(f"{m.workers} previews are computing and others wait: try again in a moment",
                                         retry_after=1)
                await asyncio.sleep(0.02)
            loop = asyncio.get_running_loop()
            fut = loop.run_in_executor(None, self.work, self.cancel)
            t0 = time.monotonic()   # the time limit counts from the preview's turn
            while True:
                done, _ = await asyncio.wait({fut}, timeout=0.1)
                if done:
                    return self._result(fut)
                if await disconnected():
                    self.cancel.set()
                    self.limit = "the client left"
                elif lim.preview_s and time.monotonic() - t0 > lim.preview_s:
                    self.limit = f"ran longer than {lim.preview_s:g} s (limit preview_timeout_s)"
                    self.cancel.set()
                elif lim.memory_bytes and rss_bytes() > lim.memory_bytes:
                    self.limit = f"server memory over {lim.memory_bytes / 2**20:.0f} MB (limit max_memory_mb)"
                    self.cancel.set()
                if self.cancel.is_set():
                    # give the computation its grace to see cancel, then answer without it
                    done, _ = await asyncio.wait({fut}, timeout=CANCEL_GRACE_S)
                    if done:
                        return self._result(fut)
                    raise PreviewStopped(f"preview stopped: {self.limit}")
        finally:
            with m.plock:
                m.previews -= 1
                if computing:
                    m.computing -= 1
