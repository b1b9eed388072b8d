"""The worker side of a chain task (engine/parallel.py, chains): the layer nodes of a chain run
link by link over a chunk of layers (`run_chain`), the chain's tail runs ahead on what the last
link made (`ChainTail`), and a node's artifacts are written where the pool sends them
(`_write_artifacts`). Everything here runs in a worker process (or in the parent for its timed
layers) and travels pickled: no pool, no run state."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

from .node import Context

if TYPE_CHECKING:
    from .executor import FileResolver


class _WorkerContext(Context):
    """What a node may ask of the engine inside a worker: files through the run's resolver,
    warnings collected per layer; progress and cancel are the parent's business."""

    def __init__(self, node_id: str, resolver: FileResolver) -> None:
        self.node_id = node_id
        self._resolver = resolver
        self.warnings: list[dict[str, Any]] = []
        self.layer: int | None = None

    def read_bytes(self, path: str, *, max_bytes: int | None = None) -> bytes:
        return self._resolver.read_bytes(path, max_bytes)

    def exists(self, path: str) -> bool:
        return self._resolver.exists(path)

    def progress(self, fraction: float, message: str = "") -> None:
        pass

    def check_cancelled(self) -> None:
        pass


class _ArtifactContext(_WorkerContext):
    """A node's context while a worker writes its artifacts: the run's trace as it was when the
    node finished (program headers stamp it)."""

    def __init__(self, node_id: str, resolver: FileResolver, trace: dict[str, Any]) -> None:
        super().__init__(node_id, resolver)
        self._trace = trace

    def trace(self) -> dict[str, Any]:
        return self._trace


@dataclass(frozen=True)
class ChainLink:
    """A layer node computed in the same worker task as the node before it: `over` is its input
    fed by that node's output `src_port`; `whole` its other inputs (whole values, computed
    already). The first link of a chain has over = src_port = None (its items are given). Params
    travel as JSON (their models may hold classes made at run time, which do not pickle) and are
    validated again in the worker, exactly as the graph validated them."""

    impl: Any
    node_id: str
    params_json: Any
    over: str | None = None
    src_port: str | None = None
    whole: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class ChainTail:
    """A whole-part node fed, through its `Node.ahead_input`, by the last link's output
    `src_port`: after the links, the worker task runs its `run_ahead` on the chunk's runs of
    consecutive layers (the sequence node orders them ahead: the serial run then only verifies)."""

    impl: Any
    node_id: str
    params_json: Any
    src_port: str


ChainRows = list[tuple[int, list[tuple[Any, ...]]]]


def run_chain(
    chain: tuple[ChainLink, ...],
    resolver: FileResolver,
    chunk: list[tuple[int, dict[str, Any]]],
    tail: ChainTail | None = None,
) -> tuple[ChainRows, list[Any]]:
    """Worker side (and the parent's timed layers): each link over the chunk's layers (the first on
    the items given, the next on the previous one's output of that layer), not layer by layer:
    one node's code over a run of layers keeps the core's caches warm (the 500-layer cross's chain:
    0.72 s of CPU, 0.99 s layer by layer). [(index, [(outputs, warnings, seconds) | (None, error
    text, seconds)] per link computed)]; a failed link ends that layer's chain (the parent
    computes the rest and reports the error with its context); seconds: wall, in the worker.
    Second: what `tail.run_ahead` gave for each run of consecutive layers ([] without a tail)."""
    got: dict[int, list[tuple[Any, ...]]] = {i: [] for i, _ in chunk}
    fed: list[tuple[int, dict[str, Any]]] = list(chunk)  # (index, the link's items) still going on
    for k, link in enumerate(chain):
        params = type(link.impl).Params.model_validate(link.params_json)
        ctx = _WorkerContext(link.node_id, resolver)
        going: list[tuple[int, dict[str, Any]]] = []
        for i, items in fed:
            ctx.layer = i
            ctx.warnings = []
            t0 = time.perf_counter()
            try:
                out = link.impl.run_layer(ctx, params, i, items)
            except Exception as exc:  # re-run in the parent, which reports it with node/layer/section
                got[i].append((None, f"{type(exc).__name__}: {exc}", time.perf_counter() - t0))
                continue
            got[i].append((out, ctx.warnings, time.perf_counter() - t0))
            if k + 1 < len(chain):
                nxt = chain[k + 1]
                value = out[cast(str, nxt.src_port)]  # set on every link after the first
                if value is not None:
                    going.append((i, {**nxt.whole, cast(str, nxt.over): value}))
        fed = going
    rows = [(i, got[i]) for i, _ in chunk]
    return rows, ([] if tail is None else _run_ahead(tail, len(chain) - 1, rows))


def _run_ahead(tail: ChainTail, last: int, rows: ChainRows) -> list[Any]:
    """The tail's `run_ahead` on each run of consecutive layers of the chunk: the last link's
    `tail.src_port` output of each (None where it failed). A run that fails, or params the
    worker cannot validate, give nothing: the node does that work itself, and the chunk's layers
    are kept."""
    runs: list[list[Any]] = []
    prev = None
    for i, got in rows:
        out = got[last][0] if len(got) > last else None
        if prev is None or i != prev + 1:
            runs.append([])
        runs[-1].append(None if out is None else out.get(tail.src_port))
        prev = i
    try:
        params = type(tail.impl).Params.model_validate(tail.params_json)
    except Exception:  # speculative: never the reason a chunk's layers are lost
        return []
    done = []
    for items in runs:
        try:
            done.append(tail.impl.run_ahead(params, items))
        except Exception:  # speculative: the node computes these layers itself
            continue
    return done


def _write_artifacts(
    impl: Any, node_id: str, params_json: Any, resolver: FileResolver, trace: dict[str, Any], outputs: dict[str, Any]
) -> tuple[dict[str, bytes], list[dict[str, Any]]] | tuple[None, str]:
    """Worker side: ({suffix: bytes}, warnings) or (None, error text): the parent re-runs a failed
    node's artifacts itself, so the error is raised with its context."""
    params = type(impl).Params.model_validate(params_json)
    ctx = _ArtifactContext(node_id, resolver, trace)
    try:
        files = impl.artifacts(ctx, params, outputs)
        return {k: (v.encode("utf-8") if isinstance(v, str) else bytes(v)) for k, v in files.items()}, ctx.warnings
    except Exception as exc:
        return None, f"{type(exc).__name__}: {exc}"
