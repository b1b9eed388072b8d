"""Previews under the run limits: the queue, the wall time (preview_timeout_s), the client leaving,
and — when runs execute in processes (`run_memory_mb` > 0) — the run memory limit for the
preview's whole process tree.

A process per preview would cost 20–90 ms of fork alone for a 500 MB server (measured on the lab
box), more than a canvas edit may take, and would start with a cold memory cache each time. So
previews compute in long-lived preview worker processes (at most `workers`, one per preview
computing at once), each the leader of a process tree under the budget like a run (worker.Tree):
its memory cache stays warm between previews; one that goes over the budget, or does not stop on
cancel within CANCEL_GRACE_S, is killed and a new one starts with the next preview.
"""

from __future__ import annotations

import asyncio
import logging
import multiprocessing as mp
import signal
import threading
import time
from typing import Any, Callable

from fastapi import HTTPException

from ..core.errors import CancelledError, PlanningError, RecipeError, WaamflowError
from .tree_memory import Tree, start_tree, tree_limit_message
from .worker import (
    CANCEL_GRACE_S,
    PREVIEW_WAIT_S,
    LimitError,
    QueueFullError,
    RunManager,
    _child_cache,
    is_memory_error,
    memory_limit_message,
    rss_bytes,
)

log = logging.getLogger("waamflow.preview")

# a preview's computation: fn(cache, cancel, *args), a module-level function (it is pickled by name)
PreviewFn = Callable[..., Any]


class PreviewStopped(LimitError):
    """A preview stopped by a limit (or its client leaving): 422 naming the limit."""

    http_status = 422


def _answer(fn: PreviewFn, cache: Any, stop: Any, args: tuple) -> tuple:
    """One preview in the worker: ("ok", result) or why not, as the server will answer it."""
    try:
        return ("ok", fn(cache, stop, *args))
    except CancelledError:
        return ("cancelled",)
    except MemoryError:
        return ("memory", None)
    except HTTPException as err:
        return ("http", err.status_code, err.detail)
    except WaamflowError as err:
        if is_memory_error(err):
            return ("memory", err.to_dict())
        status = 422 if isinstance(err, (RecipeError, PlanningError)) else getattr(err, "http_status", 400)
        return ("http", status, err.to_dict())
    except Exception as exc:
        if is_memory_error(exc):
            return ("memory", None)
        log.exception("preview failed")
        return ("internal", repr(exc))


def _preview_child(cache: Any, conn: Any, stop: Any) -> None:
    """A preview worker (a tree's leader, see worker._tree_child): previews one after the other
    with a memory cache of its own over the server's disk cache, until its pipe closes. Nothing is
    frozen here (unlike a run's process, worker._run_child): each preview's `execute` freezes what
    the worker holds, its memory cache included, for the preview's collections only; frozen here
    once, the previews' collections scanned the growing cache (bench_gui: 16 -> 31 ms a preview)."""
    cache = _child_cache(cache)
    while True:
        try:
            fn, args = conn.recv()
        except (EOFError, OSError):
            return
        out = _answer(fn, cache, stop, args)
        try:
            conn.send(out)
        except Exception as exc:  # a result that does not pickle
            conn.send(("internal", f"the preview's result could not be sent back: {exc!r}"))


class PreviewWorker:
    """One preview worker process and its pipe; started on first use, again after it died."""

    def __init__(self, manager: RunManager, k: int) -> None:
        self.manager = manager
        self.k = k
        self.busy = False
        self.tree: Tree | None = None
        self.conn: Any = None
        self.stop: Any = None
        self.started = 0  # processes started (1 + restarts)

    def _ensure(self) -> Tree:
        if self.tree is not None and self.tree.proc.is_alive():
            return self.tree
        self.close()
        ctx = mp.get_context("fork")
        mine, theirs = ctx.Pipe()
        self.stop = ctx.Event()
        self.tree = start_tree(
            self.manager._quiet_sqlite,
            self.manager.limits.run_memory_bytes,
            _preview_child,
            (self.manager.cache, theirs, self.stop),
            f"preview-{self.k}",
        )
        theirs.close()
        self.conn = mine
        self.started += 1
        return self.tree

    def close(self) -> None:
        if self.conn is not None:
            self.conn.close()
            self.conn = None
        if self.tree is not None:
            self.tree.end()
            self.tree = None

    def call(self, fn: PreviewFn, args: tuple, cancel: threading.Event) -> Any:
        """`fn(cache, cancel, *args)` in the worker; its result, or the error the server answers."""
        tree = self._ensure()
        self.stop.clear()
        try:
            self.conn.send((fn, args))
        except OSError:  # it ended since (killed while idle): a new one takes the preview
            self.close()
            tree = self._ensure()
            self.stop.clear()
            self.conn.send((fn, args))
        cancelled_at = None
        while True:
            if self.conn.poll(0.05):
                try:
                    return self._unpack(self.conn.recv())
                except (EOFError, OSError):
                    break
            if not tree.proc.is_alive():
                break
            if tree.over() is not None:
                break
            if cancel.is_set():
                self.stop.set()
                cancelled_at = cancelled_at or time.monotonic()
                if time.monotonic() - cancelled_at > CANCEL_GRACE_S:  # it did not stop: it ends, a new one starts
                    self.close()
                    raise CancelledError("preview cancelled")
        return self._died(tree)

    def _died(self, tree: Tree) -> Any:
        """The worker ended without an answer: over the memory limit, or otherwise; it is replaced."""
        budget = self.manager.limits.run_memory_bytes
        self.close()
        if tree.out_of_memory():
            used = tree.over_by or (tree.cgroup.peak() if tree.cgroup is not None else 0)
            raise PreviewStopped(
                "preview stopped: " + tree_limit_message("the preview", budget, used, tree.watch.processes)
            )
        code = tree.proc.exitcode
        how = f"signal {signal.Signals(-code).name}" if code is not None and code < 0 else f"exit code {code}"
        raise PreviewStopped(
            f"preview stopped: its process ended without a result ({how}); it may have used more "
            f"than {budget / 2**20:.0f} MB, its memory limit (run_memory_mb)"
        )

    def _unpack(self, msg: tuple) -> Any:
        kind = msg[0]
        if kind == "ok":
            return msg[1]
        if kind == "cancelled":
            raise CancelledError("preview cancelled")
        if kind == "memory":
            budget = self.manager.limits.run_memory_bytes
            err = msg[1] or {}
            raise PreviewStopped(
                "preview stopped: " + memory_limit_message(budget, err, "the preview"),
                node=err.get("node"),
                layer=err.get("layer"),
            )
        if kind == "http":
            raise HTTPException(msg[1], detail=msg[2])
        raise RuntimeError(f"preview failed in its worker: {msg[1]}")


class PreviewPool:
    """The preview workers: at most one per preview computing at once (RunManager.computing)."""

    def __init__(self, manager: RunManager) -> None:
        self.manager = manager
        self.lock = threading.Lock()
        self.workers: list[PreviewWorker] = []

    def call(self, fn: PreviewFn, args: tuple, cancel: threading.Event) -> Any:
        with self.lock:
            w = next((w for w in self.workers if not w.busy), None)
            if w is None:
                w = PreviewWorker(self.manager, len(self.workers))
                self.workers.append(w)
            w.busy = True
        try:
            return w.call(fn, args, cancel)
        finally:
            w.busy = False

    def close(self) -> None:
        with self.lock:
            for w in self.workers:
                w.close()

    def pids(self) -> list[int]:
        return [w.tree.proc.pid for w in self.workers if w.tree is not None and w.tree.proc.pid]


class PreviewJob:
    """One preview: `run()` computes `fn(cache, cancel, *args)` — in a preview worker process when
    runs execute in processes, else in a thread of the server — while the caller watches for the
    client leaving (`cancel`), with the preview's wall-time and memory limits."""

    def __init__(self, manager: RunManager, fn: PreviewFn, args: tuple) -> None:
        self.manager = manager
        self.fn = fn
        self.args = args
        self.cancel = threading.Event()
        self.limit: str | None = None

    def _work(self, cancel: threading.Event) -> Any:
        pool = self.manager.preview_pool
        if pool is not None:
            return pool.call(self.fn, self.args, cancel)
        return self.fn(self.manager.cache, cancel, *self.args)

    def _result(self, fut: "asyncio.Future[Any]") -> Any:
        try:
            return fut.result()
        except CancelledError:
            if self.limit is not None:
                raise PreviewStopped(f"preview stopped: {self.limit}") from None
            raise

    async def _turn(self, disconnected: Callable[[], Any]) -> None:
        """Wait for a turn among the `workers` previews computing at once (429 after PREVIEW_WAIT_S)."""
        m = self.manager
        t0 = time.monotonic()
        while True:
            with m.plock:
                if m.computing < m.workers:
                    m.computing += 1
                    return
            if await disconnected():
                raise PreviewStopped("preview stopped: the client left before its turn")
            if time.monotonic() - t0 > PREVIEW_WAIT_S:
                raise QueueFullError(
                    f"{m.workers} previews are computing and others wait: try again in a moment", retry_after=1
                )
            await asyncio.sleep(0.02)

    async def run(self, disconnected: Callable[[], Any]) -> Any:
        lim = self.manager.limits
        m = self.manager
        computing = False
        try:
            await self._turn(disconnected)
            computing = True
            fut = asyncio.get_running_loop().run_in_executor(None, self._work, self.cancel)
            t0 = time.monotonic()  # the time limit counts from the preview's turn
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
                    done, _ = await asyncio.wait({fut}, timeout=CANCEL_GRACE_S + 0.5)
                    if done:
                        return self._result(fut)
                    raise PreviewStopped(f"preview stopped: {self.limit}")
        finally:
            with m.plock:
                m.previews -= 1
                if computing:
                    m.computing -= 1
