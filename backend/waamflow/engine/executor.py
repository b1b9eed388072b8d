"""Run a validated graph: topological order, signature cache, per-layer mapping, events.

`execute(graph, ...)` is the one entry point used by the CLI, the REST worker, the GUI's one-layer
preview and the benchmarks. Options: `layers` restricts every `LayerNode` to those layer indices
(the GUI re-plans only the layer being edited); `targets` runs only those nodes and what they
depend on.

Why one file: over 600 lines (issue 27), most of it `_Run`, the state of one run — cache,
signatures, events and progress, the layer mapping, the chains and the worker pool, artifacts,
cancel and limits — shared by methods that call each other per node and per layer. Split by
concern, each part would need the whole `_Run` handed to it (the same coupling behind another
import), and the order of the steps a run takes would no longer read top to bottom. The parts
that stand alone already live beside it: parallel.py (worker pool, chains), cache.py
(signatures, tiers), events.py, artifacts.py (the run folder), estimate.py (limits before a
run). FileResolver (sandboxed, size-capped reads, ~100 lines) stays here because every caller
imports it from here (CLI, API, as-built, tests).
"""

from __future__ import annotations

import gc
import hashlib
import json
import os
import re
import sys
import threading
import time
import traceback
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence, TypeVar, cast

import shapely
from pydantic import BaseModel

from .. import __version__
from ..core.errors import CancelledError, InputFileError, PlanningError, WaamflowError
from ..core.files import not_regular, read_regular
from ..core.model import Layer, Layered, LayerPaths, MeshData
from ..core.serialize import dumps_report
from .cache import MISSING, MemoryCache, TieredCache, bytes_signature, signature
from .events import Event, EventSink
from .graph import Graph, GraphNode
from .recipe import Recipe
from .node import Context, LayerNode, Node
from . import parallel
from .daskpool import DaskPool, DaskWorkers
from .parallel import LayerPool, make_pool

MAX_INPUT_FILE_BYTES = 512 * 1024**2  # hard cap for any single file a node reads


def _over_limit(path: str, size: int, limit: int) -> str:
    """The over-size message in the unit of the nodes' `max_file_mb` settings, MB of 2^20 bytes (a
    200 MB setting is 200 here, not the 210 of decimal megabytes)."""
    return (
        f"file {path} is {size / 2**20:.1f} MB, over the {limit / 2**20:g} MB limit (MB of 2^20 bytes: "
        f"the node's 'max_file_mb'; at most {MAX_INPUT_FILE_BYTES // 2**20} MB for any file)"
    )


# Content signatures of files by (path, mtime, size), shared by every resolver in the process so
# the GUI's one-layer preview does not re-hash a large mesh on each request.
_FILE_SIGS: dict[tuple[str | int, ...], str] = {}  # (path, mtime, size) or ("sha256", path, mtime, size)
# A large file a node reads is hashed in a thread beside the node's own work on it (hashlib frees
# the interpreter: a 50 MB mesh's sha256, ~0.1 s, beside its parsing) when the run has no cache to
# look the node up in first (`_Run.run_plain_node` then signs the node after its run).
HASH_BESIDE_BYTES = 4 * 1024**2
_HASHING: dict[tuple[str | int, ...], Future[tuple[str, str]]] = {}  # (path, mtime, size) → its digests, under way
_HASHER: list[ThreadPoolExecutor] = []  # one thread, made on first need
T = TypeVar("T")

# The interpreter's switch interval during a run (Python's default: 5 ms). The run's helper threads
# (the preflight's prefetch feeding the workers, the hash beside a parse, the pool's feeder and
# result threads) release the interpreter in every numpy call and each time waited up to the whole
# interval for the main thread to give it back: the vase's section cuts reached the workers with
# gaps. 6 interleaved CLI pairs on the vase: 3.83 -> 3.68 s (`_runs_enter`).
SWITCH_INTERVAL_S = 0.001
_RUNS = threading.Lock()
_runs_active = 0
_runs_restore: tuple[bool, float] = (False, 0.005)  # (the first run froze, the switch interval before it)


def _runs_enter() -> None:
    """The interpreter set up for runs while at least one runs in this process (runs may overlap
    in threads: the first in sets it up, the last out restores it). What the process holds before
    (modules, a server's state, the caller's objects) outlives the runs: frozen for them, their
    garbage collections scan only their own objects, and unfrozen after, so the process collects it
    again; not when the caller froze already (a server's run process: what it inherited stays
    frozen). The 500-layer cross in process: 3.52 -> 3.32 s serial, 2.42-2.53 -> 2.24-2.29 s on 2
    workers. And the switch interval is `SWITCH_INTERVAL_S`."""
    global _runs_active, _runs_restore
    with _RUNS:
        if _runs_active == 0:
            froze = gc.get_freeze_count() == 0
            if froze:
                gc.freeze()
            switch = sys.getswitchinterval()
            sys.setswitchinterval(min(switch, SWITCH_INTERVAL_S))
            _runs_restore = (froze, switch)
        _runs_active += 1


def _runs_exit() -> None:
    """The end of a run (`_runs_enter`): the last one out restores the interpreter."""
    global _runs_active
    with _RUNS:
        _runs_active -= 1
        if _runs_active == 0:
            froze, switch = _runs_restore
            if froze:
                gc.unfreeze()
            sys.setswitchinterval(switch)


def _hash_beside(k_sig: tuple[str | int, ...], data: bytes) -> Future[tuple[str, str]]:
    """(content signature, sha256 hex) of `data` computed in the hashing thread, memoised under
    k_sig = (path, mtime, size) as `FileResolver._digests` does once done."""
    fut = _HASHING.get(k_sig)
    if fut is not None:
        return fut

    def work() -> tuple[str, str]:
        sha = hashlib.sha256(data).hexdigest()
        _FILE_SIGS[k_sig], _FILE_SIGS[("sha256", *k_sig)] = sha[:32], sha
        return sha[:32], sha

    if not _HASHER:
        _HASHER.append(ThreadPoolExecutor(1, thread_name_prefix="waamflow-hash"))
    fut = _HASHER[0].submit(work)
    _HASHING[k_sig] = fut
    fut.add_done_callback(lambda _f: _HASHING.pop(k_sig, None))
    return fut


# ---- files --------------------------------------------------------------------------------------
class LayerLimitError(WaamflowError):
    """A node made more layers than the run may have (`execute(max_layers=)`): the run stops there."""

    kind = "limit"


class FileResolver:
    """Resolves file params: attachments (server-stored files) first, then paths relative to
    `base_dir`. With `roots`, a resolved path must lie under one of them (server: no escaping the
    graphs/data folders)."""

    def __init__(
        self,
        base_dir: str | Path,
        attachments: dict[str, bytes] | None = None,
        roots: Iterable[str | Path] | None = None,
    ) -> None:
        self.base_dir = Path(base_dir).resolve()
        self.attachments = dict(attachments or {})
        self.roots = [Path(r).resolve() for r in roots] if roots else None
        self._read_hashes: dict[str, str] = {}  # path → sha256 hex of every file read (traceability)
        self._hashing: dict[str, Future[tuple[str, str]]] = {}  # path → its digests being computed beside
        self.hash_beside = False  # large reads hashed in a thread (`_hash_beside`): the run has no cache

    def __getstate__(self) -> dict[str, Any]:
        """What a worker gets (the resolver travels with every chunk, `parallel.run_chain`): no
        hash under way (a Future holds a lock and cannot be pickled; the run's own copy collects
        it for the trace) and no hashing beside (a worker's reads serve its layers only)."""
        state = dict(self.__dict__)
        state["_hashing"] = {}
        state["hash_beside"] = False
        return state

    def resolve(self, path: str) -> Path:
        if not isinstance(path, str) or not path:
            raise InputFileError("empty file path")
        p = Path(path)
        p = (p if p.is_absolute() else self.base_dir / p).resolve()
        if self.roots is not None and not any(p.is_relative_to(r) for r in self.roots):
            raise InputFileError(f"file {path!r} is outside the allowed folders")
        return p

    def exists(self, path: str) -> bool:
        if path in self.attachments:
            return True
        try:
            return self.resolve(path).is_file()
        except (InputFileError, OSError):  # OSError: a name the system cannot take (too long, ...)
            return False

    def read_bytes(self, path: str, max_bytes: int | None = None) -> bytes:
        limit = min(max_bytes or MAX_INPUT_FILE_BYTES, MAX_INPUT_FILE_BYTES)
        known: str | None = None  # the sha256 the run computed already for its cache key and trace (`_digests`)
        if path in self.attachments:
            data = self.attachments[path]
        else:
            p = self.resolve(path)
            try:
                found = p.exists()
            except OSError as exc:  # a name the system cannot take: the reason, not the server's folder
                short = path if len(path) <= 60 else path[:40] + "…" + path[-12:]
                raise InputFileError(f"file {short!r} cannot be opened: {exc.strerror or exc}") from None
            if not found:
                raise InputFileError(f"file not found: {path} (looked in {p.parent})")
            why = not_regular(p)  # a FIFO would block the read, a device never end it
            if why:
                raise InputFileError(f"file {path} refused: {why}")
            st = p.stat()
            if st.st_size > limit:
                raise InputFileError(_over_limit(path, st.st_size, limit))
            data = read_regular(p, limit, label=path)  # one open, checked again on the descriptor
            if len(data) == st.st_size:
                known = _FILE_SIGS.get(("sha256", str(p), st.st_mtime_ns, st.st_size))
                if known is None and self.hash_beside and len(data) >= HASH_BESIDE_BYTES and len(data) <= limit:
                    self._hashing[path] = _hash_beside((str(p), st.st_mtime_ns, st.st_size), data)
                    return data
        if len(data) > limit:
            raise InputFileError(_over_limit(path, len(data), limit))
        self._read_hashes[path] = known or hashlib.sha256(data).hexdigest()
        return data

    @property
    def read_hashes(self) -> dict[str, str]:
        """path → sha256 hex of every file read (traceability); waits for those hashed beside."""
        for path, fut in list(self._hashing.items()):
            self._read_hashes[path] = fut.result()[1]
            self._hashing.pop(path, None)
        return self._read_hashes

    @staticmethod
    def _digests(p: Path, st: os.stat_result) -> tuple[str, str]:
        """(content signature, sha256 hex) of a file, both from one read, memoised on (path,
        mtime, size) (the cache key, the trace and the node's read each hashed a 50 MB mesh).
        Raises InputFileError when it cannot be read."""
        k_sig, k_sha = (str(p), st.st_mtime_ns, st.st_size), ("sha256", str(p), st.st_mtime_ns, st.st_size)
        sig, sha = _FILE_SIGS.get(k_sig), _FILE_SIGS.get(k_sha)
        beside = _HASHING.get(k_sig)
        if (sig is None or sha is None) and beside is not None:  # a read's hash under way: no second read
            sig, sha = beside.result()
        if sig is None or sha is None:
            data = read_regular(p, MAX_INPUT_FILE_BYTES)
            sha = hashlib.sha256(data).hexdigest()
            sig = sha[:32]  # = bytes_signature(data): one hash of the content for both
            if len(_FILE_SIGS) > 4096:
                _FILE_SIGS.clear()
            _FILE_SIGS[k_sig], _FILE_SIGS[k_sha] = sig, sha
        return sig, sha

    def triangles(self, path: str) -> int:
        """About how many triangles the mesh file `path` holds, from its size and first bytes
        (`parallel.file_triangles`); 0 when it cannot be read (the read reports why)."""
        try:
            if path in self.attachments:
                data = self.attachments[path]
                return parallel.file_triangles(len(data), data[:84])
            p = self.resolve(path)
            if not_regular(p):
                return 0
            with open(p, "rb") as fh:
                return parallel.file_triangles(os.fstat(fh.fileno()).st_size, fh.read(84))
        except (InputFileError, OSError):
            return 0

    def sha256(self, path: str) -> str | None:
        """sha256 hex of a file's content (None when missing); memoised on (path, mtime, size)."""
        if path in self.attachments:
            return hashlib.sha256(self.attachments[path]).hexdigest()
        try:
            p = self.resolve(path)
            st = p.stat()
        except (InputFileError, OSError):
            return None
        try:
            return self._digests(p, st)[1]
        except InputFileError:
            return None  # not readable (FIFO, device, too large): the read reports why

    def signature(self, path: str) -> str:
        """Content signature of a file (missing file → 'missing'); memoised on (path, mtime, size)."""
        if path in self.attachments:
            return bytes_signature(self.attachments[path])
        try:
            p = self.resolve(path)
            st = p.stat()
        except (InputFileError, OSError):
            return "missing"
        try:
            return self._digests(p, st)[0]
        except InputFileError as e:  # FIFO, device, too large: the read reports why
            return "unreadable:" + bytes_signature(str(e).encode())


def file_fields(model_cls: type[BaseModel]) -> list[str]:
    """Names of params fields marked as files (`FileRef`)."""
    out = []
    for name, f in model_cls.model_fields.items():
        extra = f.json_schema_extra if isinstance(f.json_schema_extra, dict) else {}
        meta_extra = [m for m in f.metadata if getattr(m, "json_schema_extra", None)]
        if extra.get("x-file") or any(m.json_schema_extra.get("x-file") for m in meta_extra):
            out.append(name)
    return out


# ---- results ------------------------------------------------------------------------------------
@dataclass
class NodeStats:
    type: str
    seconds: float = 0.0
    cached: bool = False
    layers_total: int | None = None
    layers_cached: int | None = None
    layers_computed: int | None = None
    report: dict[str, Any] = field(default_factory=dict)  # the node's `ctx.report(...)`, cached with its outputs
    # layer nodes: seconds spent computing this node's layers, summed over the processes that did
    # (`seconds` is the wall time the run spent in the node: in a chain, the first node's
    # includes its followers' layers, computed in the same worker tasks)
    compute_seconds: float | None = None

    def to_dict(self) -> dict[str, Any]:
        d = {"type": self.type, "seconds": round(self.seconds, 4), "cached": self.cached}
        if self.layers_total is not None:
            d.update(
                layers_total=self.layers_total, layers_cached=self.layers_cached, layers_computed=self.layers_computed
            )
        if self.compute_seconds is not None:
            d["compute_seconds"] = round(self.compute_seconds, 4)
        if self.report:
            d["report"] = self.report
        return d


@dataclass
class RunResult:
    outputs: dict[str, dict[str, Any]]
    stats: dict[str, NodeStats]
    warnings: list[dict[str, Any]]
    artifacts: dict[str, bytes]
    layer_count: int | None
    seconds: float
    signatures: dict[str, str] = field(default_factory=dict)  # "node.port" → signature
    executor: dict[str, Any] = field(
        default_factory=lambda: {"kind": "local", "address": None, "workers": 1, "tasks": 0}
    )
    trace: dict[str, Any] = field(default_factory=dict)  # see `run_trace`
    preflight: dict[str, Any] | None = None  # see `waamflow.preflight`: the emitted programs checked against the part
    preflight_seconds: float | None = None

    def summary(self, recipe_name: str, status: str = "done") -> dict[str, Any]:
        return {
            "recipe": recipe_name,
            "status": status,
            "waamflow": __version__,
            "seconds": round(self.seconds, 4),
            "layer_count": self.layer_count,
            "nodes": {k: v.to_dict() for k, v in self.stats.items()},
            "warnings": self.warnings,
            "artifacts": sorted(self.artifacts),
            "executor": self.executor,
            "trace": self.trace,
            "programs": self.program_stats(),
            **(
                {"preflight": self.preflight, "preflight_seconds": self.preflight_seconds}
                if self.preflight is not None
                else {}
            ),
        }

    def program_stats(self) -> dict[str, dict[str, Any]]:
        """node id → the statistics of the program it wrote (format, points, motions, lengths in
        mm, dwell and estimated time in s, ...): what independent parsers check programs against."""
        from ..program.program import Program

        return {
            nid: dict(v.stats) for nid, outs in self.outputs.items() for v in outs.values() if isinstance(v, Program)
        }


# A mesh file of this many triangles starts the workers before the first node, whatever the cost
# model makes of its triangles alone: its layers and path points, unknown until the slicer, make the
# run multi-second, and the fork server's imports (~0.5 s of CPU) take the core the mesh read leaves
# idle. An unseen 606,000-triangle ribbed tube (120 layers; 1.5 s by the triangles' cost) started
# them only after slicing: its slicer could not split and its wall-path ran in the parent.
WARM_TRIANGLES = 250_000


# ---- context ------------------------------------------------------------------------------------
class RunContext(Context):
    def __init__(self, run: "_Run", node_id: str) -> None:
        self._run = run
        self.node_id = node_id
        self.warnings: list[dict[str, Any]] = []
        self.layer: int | None = None  # set while a LayerNode maps

    def read_bytes(self, path: str, *, max_bytes: int | None = None) -> bytes:
        try:
            return self._run.resolver.read_bytes(path, max_bytes)
        except InputFileError as e:
            raise e.located(node=self.node_id)

    def exists(self, path: str) -> bool:
        return self._run.resolver.exists(path)

    def progress(self, fraction: float, message: str = "") -> None:
        self._run.node_progress(self.node_id, fraction, message)

    def trace(self) -> dict[str, Any]:
        return self._run.trace()

    def check_cancelled(self) -> None:
        self._run.check_cancelled()

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any], *, layers: int = 0, points: int = 0) -> list[Any]:
        """`Context.map` in the run's workers when they are up (never waiting for them to start)
        and the cost model says it pays (`parallel.wants_workers` against the warm threshold)."""
        got = self.map_in_workers(fn, items, layers=layers, points=points)
        return [fn(x) for x in items] if got is None else got

    def map_in_workers(
        self,
        fn: Callable[[Any], Any],
        items: Sequence[Any],
        *,
        layers: int = 0,
        points: int = 0,
        seconds: float | None = None,
    ) -> list[Any] | None:
        """`Context.map_in_workers`: the map in the workers under `map`'s conditions (the cost
        model's, or `seconds` against the same thresholds), else None."""
        if seconds is not None:  # the kernel's own price replaces the cost model's
            layers = points = 0
        workers = self._run.workers()  # local ones once up, a cluster's always
        if workers is not None and len(items) > 1 and workers.pays(0, layers, points, seconds or 0.0):
            return workers.map(fn, items)
        return None

    def ahead(self) -> list[Any]:
        return self._run.ahead.pop(self.node_id, [])

    def can_submit(self) -> bool:
        pool = self._run.pool
        return isinstance(pool, LayerPool) and pool.enabled and pool.ready

    def start_workers(self, work_s: float) -> None:
        """`Context.start_workers`: `LayerPool.warm` when the cost model says `work_s` pays."""
        pool = self._run.pool
        if isinstance(pool, LayerPool) and pool.enabled and parallel.wants_workers(pool.workers, extra_s=work_s):
            pool.warm()

    def submit(self, fn: Callable[[Any], Any], item: Any) -> Future[Any] | None:
        """`Context.submit` to the run's local workers when they are up."""
        pool = self._run.pool
        if isinstance(pool, LayerPool) and pool.enabled and pool.ready:
            try:
                return pool.submit(fn, item)
            except RuntimeError:  # the pool closed or broke: the node computes it itself
                return None
        return None


# Cores free (cpu count − 1-min load average) that a node's declared shared work needs to count:
# it runs beside the node's own work, so it pays only on a core of its own. curved-bracket at
# load 4.7-6.0 (3 interleaved pairs): whole run 15.6/20.0/19.3 -> 21.7/21.8/23.9 s wall with it
# counted, while the runs' main thread waited 1.3-2.9 -> 4.1-5.2 s for a core in its sim node;
# at load 2.5-3.3 the sim node 3.10/3.10/3.09 -> 3.40/3.40/2.07 s. A quarter of a core, not a
# half: the run itself is in the average by then (back-to-back runs at others' load 1 read ~1.3-1.5).
SPARE_CORES_FOR_SHARED_WORK = 0.25


def spare_core() -> bool:
    """Whether the machine has a core to spare (`SPARE_CORES_FOR_SHARED_WORK`)."""
    try:
        return (os.cpu_count() or 1) - os.getloadavg()[0] >= SPARE_CORES_FOR_SHARED_WORK
    except OSError:  # no load average on this platform
        return True


def run_date_utc() -> str:
    """The run's date for traces, ISO 8601 UTC to the second: now, or SOURCE_DATE_EPOCH (seconds,
    the reproducible-builds convention) when set, so identical runs can give byte-identical files."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH", "").strip()
    when = datetime.fromtimestamp(int(epoch), timezone.utc) if epoch.isdigit() else datetime.now(timezone.utc)
    return when.replace(microsecond=0).isoformat().replace("+00:00", "Z")


def recipe_sha256(recipe: Recipe) -> str:
    """sha256 of the canonical recipe JSON (sorted keys, compact separators, editor-only `ui`
    state left out): the same recipe gives the same hash whatever the key order or layout."""
    doc = {k: v for k, v in recipe.to_json().items() if k != "ui"}
    text = json.dumps(doc, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def artifact_name(node_id: str, key: str) -> str:
    """The file name of a node's artifact: `<node id>.<key>` for a suffix key, or the key itself
    (without its "/") for a key "/<file name>" (a program file named after its controller
    identifier, e.g. `duct_post.src` of node `duct-post`: KRL requires file name = DEF name)."""
    return key[1:] if key.startswith("/") else f"{node_id}.{key}"


def run_trace(recipe: Recipe, files: dict[str, str], date_utc: str) -> dict[str, Any]:
    """{"date": ISO UTC, "waamflow": version, "revision": source revision (git describe),
    "recipe": name, "recipe_sha256": …, "inputs": {path: sha256}} for program headers and
    summary.json."""
    from ..buildinfo import source_revision

    return {
        "date": date_utc,
        "waamflow": __version__,
        "revision": source_revision(),
        "recipe": recipe.name,
        "recipe_sha256": recipe_sha256(recipe),
        "inputs": dict(sorted(files.items())),
    }


def _code_signature() -> str:
    """Hash of every kernel/node source file and shipped data file (robot profiles and
    descriptions): part of every cache key (Hamilton's code version), so a changed kernel or
    profile never serves results computed by the old one. api/, viewer/ and the CLI do not
    compute results and are left out."""
    import hashlib

    root = Path(__file__).resolve().parents[1]
    h = hashlib.blake2b(digest_size=12)
    files = list(root.rglob("*.py")) + [p for p in (root / "data").rglob("*") if p.is_file()]
    for p in sorted(files):
        rel = p.relative_to(root).as_posix()
        if rel.startswith(("api/", "viewer/")) or rel == "cli.py":
            continue
        h.update(rel.encode())
        h.update(p.read_bytes())
    return __version__ + "+" + h.hexdigest()


CODE_VERSION = _code_signature()


def _layer_item_signature(item: Any, fallback: str) -> str:
    """Content signature of a layer produced by a non-layer node (e.g. slice): unchanged layers
    keep their signature when another layer changes, so downstream layers stay cached."""
    if isinstance(item, Layer):
        return signature(
            "layer",
            item.index,
            round(item.z, 9),
            round(item.thickness, 9),
            bytes_signature(shapely.to_wkb(item.region)),
            [bytes_signature(shapely.to_wkb(c)) for c in item.curves],
            None if item.frame is None else item.frame.round(9).tolist(),
            *([[list(map(float, j)) for j in item.joints]] if getattr(item, "joints", ()) else []),
        )
    return fallback


# ---- the run ------------------------------------------------------------------------------------
class _Run:
    def __init__(
        self,
        graph: Graph,
        resolver: FileResolver,
        cache: TieredCache | MemoryCache | None,
        on_event: EventSink | None,
        cancel: threading.Event | None,
        layers: set[int] | None,
        active: list[str],
        write_artifacts: bool,
        pool: LayerPool | DaskPool | None = None,
    ) -> None:
        self.graph = graph
        self.pool = pool
        self.resolver = resolver
        resolver.hash_beside = cache is None  # no cache look-up waits for a file's hash (run_plain_node)
        self.cache = cache
        self.on_event = on_event
        self.cancel = cancel
        self.layers = layers
        self.active = active
        self.write_artifacts = write_artifacts
        self.seq = 0
        self.done_nodes = 0
        self.last_progress_emit = 0.0
        self.outputs: dict[str, dict[str, Any]] = {}
        self.sigs: dict[tuple[str, str], str] = {}
        self.stats: dict[str, NodeStats] = {}
        self.warnings: list[dict[str, Any]] = []
        self.artifacts: dict[str, bytes] = {}
        self.layer_count: int | None = None
        self.started_utc = run_date_utc()
        self.input_hashes: dict[str, str] = {}
        # (node id, layer) → (outputs, warnings) computed by a worker as part of a chain
        # (engine/parallel.py), taken up when the run reaches that node
        self.precomputed: dict[tuple[str, int], tuple[dict[str, Any], list[Any]]] = {}
        self.ahead: dict[str, list[Any]] = {}  # node id → what its `run_ahead` gave in chain tasks (`chain_tail`)
        self.compute_s: dict[str, float] = {}  # node id → seconds computing its layers, in any process
        self.max_layers = 0  # 0: no limit (see execute)
        self.size = [0, 0, 0]  # the run's triangles, layers and path points so far (the cost model)
        self.prefetch: Any = None  # preflight.prefetch.SectionPrefetch of a run whose preflight will run (execute)

    # events
    def emit(self, kind: str, **kw: Any) -> None:
        if self.on_event is None:
            return
        self.seq += 1
        kw.setdefault("progress", self.done_nodes / max(len(self.active), 1))
        self.on_event(Event(kind=kind, seq=self.seq, **kw))  # type: ignore[arg-type]

    def node_progress(self, node_id: str, fraction: float, message: str = "", layer: int | None = None) -> None:
        now = time.monotonic()
        if now - self.last_progress_emit < 0.1 and fraction < 1.0:
            return
        self.last_progress_emit = now
        frac = max(0.0, min(1.0, float(fraction)))
        self.emit(
            "node_progress",
            node=node_id,
            message=message,
            layer=layer,
            progress=(self.done_nodes + frac) / max(len(self.active), 1),
        )

    def check_cancelled(self) -> None:
        if self.cancel is not None and self.cancel.is_set():
            raise CancelledError("run cancelled")

    def file_sigs(self, gnode: GraphNode) -> list[tuple[str, ...]]:
        out: list[tuple[str, ...]] = []
        for f in file_fields(type(gnode.params)):
            path = getattr(gnode.params, f, None)
            if path:
                out.append((f, self.resolver.signature(path)))
                self._hash_input(path)
        for path in gnode.impl.read_files(gnode.params, self._read_or_none):  # e.g. a cell and its meshes
            out.append(("read", path, self.resolver.signature(path)))
            self._hash_input(path)
        return out

    def _hash_input(self, path: str) -> None:
        digest = self.resolver.sha256(path)  # cached nodes do not read: hash here too
        if digest is not None:
            self.input_hashes[path] = digest

    def _read_or_none(self, path: str) -> bytes | None:
        try:
            return self.resolver.read_bytes(path, 1_000_000)
        except (WaamflowError, OSError):
            return None

    def trace(self) -> dict[str, Any]:
        """What a program needs to be traced back to its origin: see `run_trace`. Not part of any
        cache key (the date changes every run); stamped when artifacts are written."""
        files = {**self.input_hashes, **self.resolver.read_hashes}
        return run_trace(self.graph.recipe, files, self.started_utc)

    def add_compute(self, node_id: str, seconds: float) -> None:
        self.compute_s[node_id] = self.compute_s.get(node_id, 0.0) + seconds

    def add_warnings(self, ws: list[dict[str, Any]]) -> None:
        for w in ws:
            self.warnings.append(w)
            self.emit(
                "warning", node=w.get("node"), layer=w.get("layer"), section=w.get("section"), message=w["message"]
            )

    # execution
    def run(self) -> None:
        self.emit("run_started", progress=0.0, message=f"{len(self.active)} nodes")
        self.warm_by_cost()
        jobs: list[tuple[GraphNode, RunContext, Any]] = []  # artifacts: (node, ctx, files | worker future)
        for pos, node_id in enumerate(self.active):
            self.check_cancelled()
            gnode = self.graph.nodes[node_id]
            t0 = time.perf_counter()
            self.emit("node_started", node=node_id, message=gnode.type)
            ctx = RunContext(self, node_id)

            def compute() -> None:
                inputs = {port: self.outputs[src][sport] for port, (src, sport) in gnode.inputs.items()}
                in_sigs = {port: self.sigs[(src, sport)] for port, (src, sport) in gnode.inputs.items()}
                if isinstance(gnode.impl, LayerNode):
                    self.run_layer_node(gnode, ctx, inputs, in_sigs)
                else:
                    self.run_plain_node(gnode, ctx, inputs, in_sigs)
                self.check_layer_limit(node_id)
                self.maybe_warm(pos)
                if self.write_artifacts and self.layers is None:
                    pool = self.pool
                    # to a worker while the parent goes on with later nodes; the last node's here
                    # (nothing to overlap: shipping its outputs would only add the transfer), and a
                    # node that writes none here (the mesh node's million triangles would travel for {})
                    if (
                        isinstance(pool, (LayerPool, DaskPool))
                        and pool.enabled
                        and pool.offload_artifacts
                        and pos < len(self.active) - 1
                        and type(gnode.impl).artifacts is not Node.artifacts
                    ):
                        jobs.append(
                            (
                                gnode,
                                ctx,
                                pool.submit_artifacts(
                                    gnode.impl,
                                    node_id,
                                    gnode.params,
                                    self.resolver,
                                    self.trace(),
                                    self.outputs[node_id],
                                ),
                            )
                        )
                    else:
                        jobs.append((gnode, ctx, self.node_artifacts(gnode, ctx)))

            if self.ahead.get(node_id) and isinstance(self.pool, (LayerPool, DaskPool)):
                # its layers were made ahead in the chain tasks: it computes here while the workers
                # idle, so the artifacts held for the next map go to them now (the 500-layer cross:
                # the strategy's and zone's, ~0.2 s the run had waited for after the last node)
                self.pool.release_held()
            self.located(node_id, ctx, compute)
            if self.prefetch is not None:  # the preflight's sections, cut while the later nodes run
                self.prefetch.offer(self.outputs[node_id], self.workers)
            st = self.stats[node_id]
            st.seconds = time.perf_counter() - t0
            self.done_nodes += 1
            self.emit(
                "node_cached" if st.cached else "node_finished",
                node=node_id,
                seconds=st.seconds,
                cached=st.cached,
                message=gnode.type,
                compute_seconds=None if st.cached or st.compute_seconds is None else round(st.compute_seconds, 4),
            )
            for value in self.outputs[node_id].values():
                if isinstance(value, Layered) and self.layer_count is None:
                    self.layer_count = len(value)
        for gnode, ctx, files in jobs:  # in node order, whoever wrote them
            if not isinstance(files, dict):
                self.check_cancelled()
                try:
                    written, extra = files.result()
                except Exception:  # the worker died (or the cluster lost it): write them here
                    written, extra = None, []
                if written is None:  # failed in a worker: again here, raised with its node
                    files = self.located(gnode.id, ctx, lambda: self.node_artifacts(gnode, ctx))
                else:
                    files = written
                    ctx.warnings.extend(extra)
            self.artifacts.update({artifact_name(gnode.id, suffix): data for suffix, data in files.items()})

    def workers(self) -> parallel.RunWorkers | DaskWorkers | None:
        """The run's workers as the preflight uses them: a Dask cluster's, or local ones once up."""
        pool = self.pool
        if isinstance(pool, DaskPool):
            return DaskWorkers(pool)
        if isinstance(pool, LayerPool) and pool.enabled and pool.ready:
            return parallel.RunWorkers(pool)
        return None

    def node_artifacts(self, gnode: GraphNode, ctx: RunContext) -> dict[str, bytes]:
        files = gnode.impl.artifacts(ctx, gnode.params, self.outputs[gnode.id])
        return {k: (v.encode("utf-8") if isinstance(v, str) else bytes(v)) for k, v in files.items()}

    def check_layer_limit(self, node_id: str) -> None:
        """`max_layers`: a node that made more layers stops the run before anything uses them."""
        for value in self.outputs[node_id].values():
            if isinstance(value, Layered) and self.max_layers and len(value) > self.max_layers:
                raise LayerLimitError(
                    f"{len(value)} layers, over the limit of {self.max_layers} (max_layers): "
                    "stopped before the nodes after it ran",
                    node=node_id,
                )

    def warm_by_cost(self) -> None:
        """Start the workers before the first node when the run's mesh files alone say they pay
        (the cost model, `parallel.wants_workers`, on the triangles their sizes give): the fork
        server's imports and the forks then overlap the mesh read."""
        pool = self.pool
        if not isinstance(pool, LayerPool) or not pool.enabled or pool.started or self.layers is not None:
            return
        for nid in self.active:
            params = self.graph.nodes[nid].params
            for f in file_fields(type(params)):
                path = getattr(params, f, None)
                if isinstance(path, str) and path.lower().endswith(parallel.MESH_SUFFIXES):
                    self.size[0] += self.resolver.triangles(path)
        if parallel.wants_workers(pool.workers, *self.size) or self.size[0] >= WARM_TRIANGLES:
            pool.warm()

    def maybe_warm(self, pos: int) -> None:
        """Start the layer workers ahead of need when the run grew big enough for them (the cost
        model on the triangles, layers and path points its nodes made so far), or when this node
        made a long layered value and layer nodes follow: their start-up then overlaps what comes."""
        pool = self.pool
        if pool is None or not pool.enabled or pool.started or self.layers is not None:
            return
        self.grow_size(self.outputs[self.active[pos]])
        later = [self.graph.nodes[n] for n in self.active[pos + 1 :]]
        extra = sum(g.impl.shared_work_s(g.params, self.size[2]) for g in later) if spare_core() else 0.0
        tri, lay, pts = self.size
        if parallel.wants_workers(pool.workers, tri, lay, pts, extra_s=extra):
            pool.warm()
            return
        if any(
            isinstance(v, Layered) and len(v) >= parallel.WARM_LAYERS for v in self.outputs[self.active[pos]].values()
        ) and any(isinstance(self.graph.nodes[n].impl, LayerNode) for n in self.active[pos + 1 :]):
            pool.warm()

    def grow_size(self, outputs: dict[str, Any]) -> None:
        """The run's size (`self.size`) with a node's outputs: a mesh's triangles, the longest
        layered value, the most path points a toolpath holds."""
        for v in outputs.values():
            if isinstance(v, MeshData):
                self.size[0] = max(self.size[0], len(v.faces))
            elif isinstance(v, Layered):
                self.size[1] = max(self.size[1], len(v))
                pts = sum(len(sp.points) for lp in v.items if isinstance(lp, LayerPaths) for sp in lp.sections)
                self.size[2] = max(self.size[2], pts)

    def located(self, node_id: str, ctx: RunContext, fn: Callable[[], T]) -> T:
        """fn() with its errors located at the node (and layer), reported as events: never a traceback."""
        try:
            return fn()
        except WaamflowError as err:
            err.located(node=node_id, layer=ctx.layer)
            self.emit(
                "node_error", node=node_id, layer=err.layer, section=err.section, message=str(err), error=err.to_dict()
            )
            raise
        except Exception as exc:  # a kernel bug or unexpected geometry: report where, never a traceback
            perr = PlanningError(_unexpected(exc), node=node_id, layer=ctx.layer)
            perr.__cause__ = exc
            perr.debug_traceback = traceback.format_exc()
            self.emit("node_error", node=node_id, layer=perr.layer, message=str(perr), error=perr.to_dict())
            raise perr from exc

    def node_key(self, gnode: GraphNode, in_sigs: dict[str, str]) -> str:
        impl = gnode.impl
        return signature(
            "node",
            gnode.type,
            impl.version,
            CODE_VERSION,
            gnode.params.model_dump(mode="json"),
            sorted(in_sigs.items()),
            self.file_sigs(gnode),
            *((gnode.id,) if impl.uses_node_id else ()),
        )

    def run_plain_node(
        self, gnode: GraphNode, ctx: RunContext, inputs: dict[str, Any], in_sigs: dict[str, Any]
    ) -> bool:
        # without a cache to look the node up in, it is signed after its run: the large files it
        # read were hashed beside it meanwhile (FileResolver.hash_beside)
        key = self.node_key(gnode, in_sigs) if self.cache is not None else ""
        hit: Any = self.cache.get(key) if self.cache is not None else MISSING
        if hit is not MISSING:
            outputs, warnings = dict(hit[0]), hit[1]
            report = hit[2] if len(hit) > 2 else {}
            cached = True
        else:
            outputs = gnode.impl.run(ctx, gnode.params, inputs)
            self._check_outputs(gnode, outputs)
            warnings = ctx.warnings
            report = ctx.take_report()
            cached = False
        key = key or self.node_key(gnode, in_sigs)
        self.outputs[gnode.id] = outputs
        for port, value in outputs.items():
            psig = signature(key, port)
            if isinstance(value, Layered):
                # signed once, when computed: a hit carries them (the same key, the same items)
                items_sigs = value.sigs if cached and len(value.sigs) == len(value.items) else ()
                if not items_sigs:
                    items_sigs = tuple(
                        _layer_item_signature(it, signature(psig, i)) for i, it in enumerate(value.items)
                    )
                    value = Layered(value.items, items_sigs)
                    outputs[port] = value
                psig = signature("layered", items_sigs)
            self.sigs[(gnode.id, port)] = psig
        if not cached and self.cache is not None:
            self.cache.put(key, (dict(outputs), warnings, report))
        self.add_warnings(warnings)
        self.stats[gnode.id] = NodeStats(gnode.type, cached=cached, report=report)
        return cached

    def run_layer_node(
        self, gnode: GraphNode, ctx: RunContext, inputs: dict[str, Any], in_sigs: dict[str, Any]
    ) -> bool:
        impl: LayerNode = gnode.impl  # type: ignore[assignment]
        over = inputs.get(impl.over)
        if not isinstance(over, Layered):
            raise PlanningError(f"input '{impl.over}' is not a layered value")
        n = len(over)
        layered = {p: v for p, v in inputs.items() if isinstance(v, Layered)}
        whole_sigs = sorted((p, s) for p, s in in_sigs.items() if p not in layered)
        for p, v in layered.items():
            if len(v) != n:
                raise PlanningError(f"input '{p}' has {len(v)} layers, '{impl.over}' has {n}")
        wanted = range(n) if self.layers is None else sorted(i for i in self.layers if 0 <= i < n)
        per_layer: dict[str, list[Any]] = {p.name: [None] * n for p in impl.outputs}
        item_keys: list[str] = [""] * n
        results: dict[int, tuple[dict[str, Any], list[Any]]] = {}  # index → (outputs, warnings)
        todo: list[tuple[int, dict[str, Any], str]] = []  # uncached: (index, items, key)
        prefetched: list[tuple[int, str, tuple[Any, ...]]] = []  # (index, key, (outputs, warnings)) from a chain
        for i in wanted:
            items = {p: (v.items[i] if isinstance(v, Layered) else v) for p, v in inputs.items()}
            if items[impl.over] is None:
                continue
            isigs = sorted((p, (v.sigs[i] if v.sigs else signature(in_sigs[p], i))) for p, v in layered.items())
            key = signature(
                "layer",
                gnode.type,
                impl.version,
                CODE_VERSION,
                impl.layer_params(gnode.params, i, items),
                isigs,
                whole_sigs,
            )
            item_keys[i] = key
            hit: Any = self.cache.get(key) if self.cache is not None else MISSING
            pre = self.precomputed.pop((gnode.id, i), None)
            if hit is not MISSING:
                results[i] = hit
            elif pre is not None:  # computed in a worker right after the layer it depends on
                prefetched.append((i, key, pre))
            else:
                todo.append((i, items, key))
        n_cached = len(results)
        for i, key, (out, warnings) in prefetched:
            self.keep_layer(gnode, results, i, key, out, warnings)
        self.compute_layers(gnode, ctx, todo, results, n_total=len(results) + len(todo))
        for i in wanted:  # warnings and outputs in layer order, whoever computed them
            if i not in results:
                continue
            out, warnings = results[i]
            self.add_warnings(warnings)
            for port, value in out.items():
                per_layer[port][i] = value
        n_computed = len(todo) + len(prefetched)
        ctx.layer = None
        ctx.warnings = []
        ctx.take_report()
        outputs = impl.combine(ctx, gnode.params, per_layer, inputs)
        report = ctx.take_report()
        self._check_outputs(gnode, outputs)
        self.add_warnings(ctx.warnings)
        fsig = self.file_sigs(gnode)
        node_key = signature(
            "layernode",
            gnode.type,
            impl.version,
            CODE_VERSION,
            item_keys,
            fsig,
            gnode.params.model_dump(mode="json"),
            whole_sigs,
        )
        for port, value in list(outputs.items()):
            if isinstance(value, Layered):
                sigs = tuple(
                    signature(item_keys[i], port, fsig) if value.items[i] is not None else "" for i in range(len(value))
                )
                outputs[port] = Layered(value.items, sigs)
                self.sigs[(gnode.id, port)] = signature("layered", sigs)
            else:
                self.sigs[(gnode.id, port)] = signature(node_key, port)
        self.outputs[gnode.id] = outputs
        self.stats[gnode.id] = NodeStats(
            gnode.type,
            cached=(n_computed == 0),
            layers_total=n,
            layers_cached=n_cached,
            layers_computed=n_computed,
            report=report,
            compute_seconds=self.compute_s.pop(gnode.id, 0.0),
        )
        return n_computed == 0

    def compute_layers(
        self,
        gnode: GraphNode,
        ctx: RunContext,
        todo: list[tuple[int, dict[str, Any], str]],
        results: dict[int, tuple[dict[str, Any], list[Any]]],
        n_total: int,
    ) -> None:
        """Compute the uncached layers into `results` and the cache: the first in this process
        (timed), the rest in worker processes when the timing says they pay (engine/parallel.py)."""
        impl: LayerNode = gnode.impl  # type: ignore[assignment]
        done = [n_total - len(todo)]

        def finish(i: int, key: str, out: dict[str, Any], warnings: list[Any]) -> None:
            self.keep_layer(gnode, results, i, key, out, warnings)
            done[0] += 1
            self.node_progress(gnode.id, done[0] / max(n_total, 1), f"layer {i}", layer=i)

        def here(i: int, items: dict[str, Any], key: str) -> None:
            self.check_cancelled()
            ctx.layer = i
            ctx.warnings = []
            t0 = time.perf_counter()
            out = impl.run_layer(ctx, gnode.params, i, items)
            self.add_compute(gnode.id, time.perf_counter() - t0)
            finish(i, key, out, ctx.warnings)

        rest = list(todo)
        pool = self.pool
        chain = self.chain_from(gnode) if pool is not None and pool.enabled and len(todo) > 1 else ()

        def timed(i: int, items: dict[str, Any], key: str) -> None:
            """A layer of this node and of the nodes chained to it: what the workers would be sent
            is what gets timed (its later links wait in `precomputed`, as a worker's would)."""
            here(i, items, key)
            if len(chain) < 2:
                return
            nxt = chain[1]
            fed = results[i][0].get(cast(str, nxt.src_port))  # set on every link after the first
            if fed is None:
                return
            ((_i, got),), _ = parallel.run_chain(
                chain[1:], self.resolver, [(i, {**nxt.whole, cast(str, nxt.over): fed})]
            )
            self.keep_later_links(chain[1:], i, got)

        t0 = time.thread_time()  # CPU seconds: a busy machine must not make the layers look costly
        if rest:
            timed(*rest.pop(0))
        while rest and time.thread_time() - t0 < parallel.TIMING_S:  # time one layer, more if tiny
            timed(*rest.pop(0))
        per_layer_s = (time.thread_time() - t0) / max(len(todo) - len(rest), 1)
        if pool is not None and pool.enabled and per_layer_s * len(rest) > pool.min_parallel_s:
            pool.warm()  # no-op once started
        # workers on their way: go on here meanwhile, a layer through the whole chain (its later
        # links done too, they need no second round of tasks to the workers after this map)
        while rest and pool is not None and pool.warming:
            timed(*rest.pop(0))
        if (
            pool is not None
            and pool.enabled
            and pool.ready
            and len(rest) > 1
            and per_layer_s * len(rest) > pool.min_parallel_s
        ):
            keys = {i: key for i, _, key in rest}
            failed: list[int] = []

            def collect(i: int, got: list[Any]) -> None:
                out, extra, sec = got[0]
                self.add_compute(gnode.id, sec)
                if out is None:  # the chain ended there: no later links
                    failed.append(i)
                    return
                finish(i, keys[i], out, extra)
                self.keep_later_links(chain[1:], i, got[1:])

            tail = self.chain_tail(chain)
            pool.map_layers(
                chain,
                self.resolver,
                [(i, items) for i, items, _ in rest],
                collect,
                lambda: self.cancel is not None and self.cancel.is_set(),
                tail,
                None if tail is None else self.ahead.setdefault(tail.node_id, []).extend,
            )
            self.check_cancelled()
            # a layer that failed in a worker is re-run here: the error is raised with its context
            rest = [t for t in rest if t[0] in set(failed) or t[0] not in results]
        for t in rest:
            here(*t)

    def keep_layer(
        self,
        gnode: GraphNode,
        results: dict[int, tuple[dict[str, Any], list[Any]]],
        i: int,
        key: str,
        out: dict[str, Any],
        warnings: list[Any],
    ) -> None:
        """A computed layer of `gnode` (here, in a worker, or ahead in a chain) into `results`
        and the cache."""
        self._check_outputs(gnode, out)
        results[i] = (out, warnings)
        if self.cache is not None:
            self.cache.put(key, (out, warnings))

    def keep_later_links(self, links: tuple[parallel.ChainLink, ...], i: int, got: list[Any]) -> None:
        """Layer i of a chain's later links, computed right after the first one's: their time is
        counted, their results wait in `precomputed` until the run reaches their node (a failed
        link is absent: that node computes the layer itself and reports the error)."""
        for link, (out, warnings, sec) in zip(links, got):
            self.add_compute(link.node_id, sec)
            if out is not None:
                self.precomputed[(link.node_id, i)] = (out, warnings)

    def chain_from(self, gnode: GraphNode) -> tuple[parallel.ChainLink, ...]:
        """`gnode` and the layer nodes that can compute their layer i in the same worker task
        right after it (engine/parallel.py, chains): each fed, through its `over` input, by the
        previous one's output, whose `combine` hands items on unchanged; its other inputs whole
        values computed already. Only for whole-part runs (a GUI preview of a few layers stays
        node by node)."""
        links = [parallel.ChainLink(gnode.impl, gnode.id, gnode.params.model_dump(mode="json"))]
        if self.layers is not None:
            return tuple(links)
        cur = gnode
        pos = self.active.index(gnode.id)
        while True:
            if not cast(LayerNode, cur.impl).keeps_items(cur.params):  # gnode, then a cand checked below
                break
            nxt = None
            for nid in self.active[pos + 1 :]:
                cand = self.graph.nodes[nid]
                if not isinstance(cand.impl, LayerNode):
                    continue
                src = cand.inputs.get(cand.impl.over)
                if src is None or src[0] != cur.id:
                    continue
                others = {p: s for p, s in cand.inputs.items() if p != cand.impl.over}
                if all(
                    s[0] in self.outputs and not isinstance(self.outputs[s[0]][s[1]], Layered) for s in others.values()
                ):
                    nxt = (cand, src[1], {p: self.outputs[s[0]][s[1]] for p, s in others.items()})
                break
            if nxt is None:
                break
            cand, port, whole = nxt
            links.append(
                parallel.ChainLink(
                    cand.impl,
                    cand.id,
                    cand.params.model_dump(mode="json"),
                    cast(LayerNode, cand.impl).over,
                    port,
                    whole,
                )
            )
            cur, pos = cand, self.active.index(cand.id)
        return tuple(links)

    def chain_tail(self, chain: tuple[parallel.ChainLink, ...]) -> parallel.ChainTail | None:
        """The whole-part node that runs ahead in the chain's tasks (`Node.run_ahead`): the first
        node to come with an `ahead_input` fed by the last link, whose combine keeps its items
        (the node is then given the very layers the tasks made). Whole-part runs only."""
        last = self.graph.nodes[chain[-1].node_id]
        if self.layers is not None or not cast(LayerNode, last.impl).keeps_items(last.params):
            return None
        for nid in self.active[self.active.index(last.id) + 1 :]:
            cand = self.graph.nodes[nid]
            port = cand.impl.ahead_input
            src = cand.inputs.get(port) if port is not None else None
            if src is not None and src[0] == last.id and not isinstance(cand.impl, LayerNode):
                return parallel.ChainTail(cand.impl, cand.id, cand.params.model_dump(mode="json"), src[1])
        return None

    @staticmethod
    def _check_outputs(gnode: GraphNode, outputs: dict[str, Any]) -> None:
        expected = {p.name for p in gnode.impl.outputs}
        if not isinstance(outputs, dict) or set(outputs) != expected:
            got = sorted(outputs) if isinstance(outputs, dict) else type(outputs).__name__
            raise PlanningError(f"node returned outputs {got}, expected {sorted(expected)}")


def _unexpected(exc: Exception) -> str:
    """The message of an exception no kernel anticipated: its kind and text, and for the geometry
    kernel's (GEOS: shapely.errors.GEOSException) what to look at and where."""
    text = f"{type(exc).__name__}: {exc}"
    if type(exc).__name__ != "GEOSException":
        return text
    at = re.search(r" at (-?\d+(?:\.\d+)?(?:e-?\d+)?) (-?\d+(?:\.\d+)?(?:e-?\d+)?)", str(exc))
    where = f" near ({float(at[1]):.2f}, {float(at[2]):.2f}) mm" if at else ""
    return (
        f"{text} — the geometry kernel could not compute this layer's outline{where}: a self-crossing, "
        "paper-thin or degenerate outline there; check the part or sketch at that point (repair the mesh, "
        "thicken the feature) or change the bead width or pattern"
    )


def _preflight(run: "_Run", graph: Graph) -> tuple[dict[str, Any] | None, float | None]:
    """The preflight of a full run (`waamflow.preflight`) and the seconds it took (for the summary
    only: the artifacts stay reproducible); the report is also the artifact `preflight.json`. An
    internal error of the check itself is a failed check, never a silent pass. The run's workers,
    when started (a Dask cluster's: always), check the layers of a large part and read back what
    the conservation check compares (the report is the same)."""
    from ..preflight import run_preflight

    if run.prefetch is not None:  # the nodes are done: the rest of the cuts go while the programs are read back
        run.prefetch.hurry()
    pool = run.pool
    workers: parallel.RunWorkers | DaskWorkers | None = None
    if isinstance(pool, LayerPool) and pool.enabled and pool.started:
        workers = parallel.RunWorkers(pool)
    elif isinstance(pool, DaskPool):  # the cluster's workers run already
        workers = DaskWorkers(pool)
    t0 = time.perf_counter()
    try:
        report = run_preflight(
            graph, run.outputs, run.artifacts, getattr(graph.recipe, "preflight", None), workers, run.prefetch
        )
    except Exception as exc:  # noqa: BLE001 - reported, never swallowed
        report = {
            "verdict": "fail",
            "accepted": False,
            "programs": [],
            "layers": [],
            "problems": [
                {
                    "check": "preflight",
                    "severity": "fail",
                    "node": None,
                    "layer": None,
                    "section": None,
                    "message": f"the preflight itself failed: {type(exc).__name__}: {exc}",
                    "value": None,
                    "limit": None,
                    "point": None,
                }
            ],
        }
    if report is None:
        return None, None
    run.artifacts["preflight.json"] = dumps_report(report)
    return report, round(time.perf_counter() - t0, 3)


def execute(
    graph: Graph,
    *,
    resolver: FileResolver,
    cache: TieredCache | MemoryCache | None = None,
    on_event: EventSink | None = None,
    cancel: threading.Event | None = None,
    layers: Iterable[int] | None = None,
    targets: Iterable[str] | None = None,
    artifacts: bool = True,
    workers: int | None = None,
    scheduler: str | None = None,
    preflight: bool = True,
    max_layers: int = 0,
) -> RunResult:
    """Run `graph`. Raises WaamflowError subclasses (with node/layer/section) on failure after
    emitting `node_error` and `run_failed`/`run_cancelled`. `workers`: processes for the layers of
    layer nodes (None: `WAAMFLOW_LAYER_WORKERS`, else every core; 1: serial). `scheduler`: a Dask
    scheduler address (tcp://HOST:PORT) to send the layers to instead of local processes. `max_layers`
    (0 = none): a node that makes more layers stops the run at once (LayerLimitError), before any
    layer of the nodes after it is computed."""
    t0 = time.perf_counter()
    active = list(graph.order)
    if targets is not None:
        keep: set[str] = set()
        for t in targets:
            if t not in graph.nodes:
                from ..core.errors import RecipeError

                raise RecipeError(f"no node with id {t!r}", node=t)
            keep |= {t} | graph.ancestors(t)
        active = [n for n in active if n in keep]
    pool = make_pool(workers, scheduler)
    run = _Run(
        graph, resolver, cache, on_event, cancel, None if layers is None else set(layers), active, artifacts, pool
    )
    run.max_layers = max_layers
    if preflight and targets is None and layers is None and artifacts and pool.workers > 1:
        from ..preflight.prefetch import SectionPrefetch

        run.prefetch = SectionPrefetch()
    finished = False
    report, report_s = None, None
    _runs_enter()
    try:
        run.run()
        if preflight and targets is None and layers is None and artifacts:
            report, report_s = _preflight(run, graph)  # before the workers close: they may share it
        finished = True
    except CancelledError as err:
        run.emit("run_cancelled", message=str(err), error=err.to_dict())
        raise
    except WaamflowError as err:
        run.emit(
            "run_failed", message=str(err), error=err.to_dict(), node=err.node, layer=err.layer, section=err.section
        )
        raise
    finally:
        if run.prefetch is not None:  # a failed or cancelled run: its thread ends, its cuts are dropped
            run.prefetch.close()
        info = pool.info()
        pool.close(wait=finished)
        _runs_exit()
    if cache is not None and hasattr(cache, "flush"):
        cache.flush()
    result = RunResult(
        run.outputs,
        run.stats,
        run.warnings,
        run.artifacts,
        run.layer_count,
        time.perf_counter() - t0,
        {f"{n}.{p}": s for (n, p), s in run.sigs.items()},
        info,
        run.trace(),
        report,
        report_s,
    )
    run.emit("run_finished", progress=1.0, seconds=result.seconds, message="done")
    return result
