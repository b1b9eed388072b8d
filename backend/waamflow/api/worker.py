"""Background run execution: a thread pool sized to the machine, cancel flags, live event logs."""

from __future__ import annotations

import logging
import threading
import time
import uuid
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, Callable

from ..core.errors import CancelledError, WaamflowError
from ..engine.artifacts import write_run_dir
from ..engine.events import TERMINAL_KINDS, Event
from ..engine.executor import FileResolver, RunResult, execute
from ..engine.graph import build_graph
from ..engine.recipe import Recipe
from .store import Store

log = logging.getLogger("waamflow.runs")


class LiveRun:
    """Events of a run in memory (for streaming) until it ends; then they are in the store."""

    def __init__(self, run_id: str) -> None:
        self.id = run_id
        self.events: list[dict] = []
        self.cancel = threading.Event()
        self.done = threading.Event()
        self.lock = threading.Lock()

    def add(self, ev: dict) -> None:
        with self.lock:
            self.events.append(ev)

    def since(self, seq: int) -> list[dict]:
        with self.lock:
            return [e for e in self.events if e["seq"] > seq]


class RunManager:
    def __init__(self, store: Store, data_dir: Path, cache, workers: int,
                 resolver_for: Callable[[str | None, Recipe, str | None], FileResolver],
                 on_done: Callable[[str, str | None, Recipe, RunResult], None] | None = None) -> None:
        self.store = store
        self.runs_dir = data_dir / "runs"
        self.runs_dir.mkdir(parents=True, exist_ok=True)
        self.cache = cache
        self.pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="waamflow-run")
        self.live: dict[str, LiveRun] = {}
        self.resolver_for = resolver_for
        self.on_done = on_done

    def submit(self, graph_name: str | None, recipe: Recipe, params_xml: str | None = None) -> str:
        """Validate now (so a bad recipe is a 422, not a failed run), then queue. `params_xml` is a
        draft zone-parameter file used for this run only."""
        graph = build_graph(recipe)
        run_id = uuid.uuid4().hex[:12]
        self.store.create_run(run_id, graph_name, recipe.to_json(), recipe.inputs)
        live = LiveRun(run_id)
        self.live[run_id] = live
        self.pool.submit(self._run, run_id, graph_name, recipe, graph, live, params_xml)
        return run_id

    def run_dir(self, run_id: str) -> Path:
        return self.runs_dir / run_id

    def cancel(self, run_id: str) -> bool:
        live = self.live.get(run_id)
        if live is None or live.done.is_set():
            return False
        live.cancel.set()
        return True

    def _run(self, run_id: str, graph_name: str | None, recipe: Recipe, graph, live: LiveRun,
             params_xml: str | None = None) -> None:
        if live.cancel.is_set():
            self._finish(run_id, live, "cancelled", error={"kind": "cancelled", "message": "cancelled before start",
                                                           "text": "cancelled before start"})
            return
        self.store.update_run(run_id, status="running", started=time.time())
        last_progress = [0.0]

        def on_event(ev: Event) -> None:
            d = ev.to_dict()
            live.add(d)
            now = time.monotonic()
            if now - last_progress[0] > 0.5:
                last_progress[0] = now
                self.store.update_run(run_id, progress=round(ev.progress, 4))

        try:
            resolver = self.resolver_for(graph_name, recipe, params_xml)
            result = execute(graph, resolver=resolver, cache=self.cache, on_event=on_event, cancel=live.cancel)
            summary = result.summary(recipe.name)
            summary["inputs"] = recipe.inputs
            write_run_dir(self.run_dir(run_id), result.artifacts, summary)
            if self.on_done is not None:
                try:
                    self.on_done(run_id, graph_name, recipe, result)
                except Exception:  # the viewer or params store must not fail a finished run
                    log.exception("post-run hook failed for run %s", run_id)
            self._finish(run_id, live, "done", summary=summary)
        except CancelledError as err:
            self._finish(run_id, live, "cancelled", error=err.to_dict())
        except WaamflowError as err:
            self._finish(run_id, live, "failed", error=err.to_dict())
        except Exception as exc:  # pragma: no cover - last resort: never leave a run 'running'
            log.exception("run %s crashed", run_id)
            self._finish(run_id, live, "failed", error={"kind": "internal", "message": repr(exc), "text": repr(exc)})

    def _finish(self, run_id: str, live: LiveRun, status: str, *, summary: dict | None = None,
                error: dict | None = None) -> None:
        if not any(e.get("kind") in TERMINAL_KINDS for e in live.events):
            kind = {"done": "run_finished", "failed": "run_failed", "cancelled": "run_cancelled"}[status]
            live.add(Event(kind=kind, seq=len(live.events) + 1, progress=1.0 if status == "done" else 0.0,
                           message=(error or {}).get("text", status), error=error).to_dict())
        self.store.add_events(run_id, live.events)
        fields = dict(status=status, finished=time.time(), summary=summary, error=error)
        if status == "done":
            fields["progress"] = 1.0
        self.store.update_run(run_id, **fields)
        live.done.set()
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
        for live in self.live.values():
            live.cancel.set()
        self.pool.shutdown(wait=True, cancel_futures=True)
