"""Declaring a node: once, in Python. The catalog, the API schema and the GUI are generated from it.

A node is a thin adapter from ports to a pure kernel call::

    @register
    class Slice(Node):
        \"\"\"Planar slicing of a part into layers.\"\"\"          # → catalog description
        type = "slice"                                         # stable type id (never renamed)
        title = "Slice"
        category = "slicing"
        inputs = (Port("mesh", "mesh"),)
        outputs = (Port("layers", "layers"),)

        class Params(NodeParams):
            layer_height: float = Field(1.5, gt=0, le=50, description="Layer height", json_schema_extra={"unit": "mm"})

        def run(self, ctx, params, inputs):
            return {"layers": slice_mesh(inputs["mesh"], params.layer_height)}

Nodes that map over layers derive from `LayerNode` and implement `run_layer`; the engine then
caches each layer on its own signature, so an edit that touches one layer recomputes one layer.

Bump `version` whenever a node's results change for the same inputs: it is part of the cache key.
"""

from __future__ import annotations

import builtins
from concurrent.futures import Future
from typing import Annotated, Any, Callable, ClassVar, Sequence

from pydantic import BaseModel, ConfigDict, Field

from .ports import Port

MAX_REPORT_BYTES = 256 * 1024  # a node's report in summary.json (see Context.report)

# A parameter holding a path to a file (mesh, sketch, XML). Relative paths resolve against the
# recipe file. The engine hashes the file's content into the node's signature, and the GUI shows
# a file picker for it.
FileRef = Annotated[str, Field(json_schema_extra={"x-file": True})]


def unit(u: str) -> dict[str, Any]:
    """`json_schema_extra` for a numeric field with a unit: Field(..., json_schema_extra=unit("mm"))."""
    return {"unit": u}


# Fields that name a shipped file carry `json_schema_extra={"x-shipped": KIND}`; the catalog lists
# the shipped names as the field's JSON-Schema `examples`, so the GUI offers them in a picker
# (a user's own file path stays allowed where the field takes one).
SHIPPED_KINDS: dict[str, tuple[str, str]] = {  # kind → (folder in waamflow/data, file pattern)
    "cells": ("cells", "*.json"),
    "machines": ("machines", "*.json"),
    "robots": ("robots", "*.json"),
    "robot-descriptions": ("robots", "*.urdf"),
}


def shipped_names(kind: str) -> list[str]:
    """Names of the shipped files of `kind`: stems of JSON files, full names of URDFs."""
    from pathlib import Path

    folder, pattern = SHIPPED_KINDS[kind]
    root = Path(__file__).resolve().parent.parent / "data" / folder
    return sorted(p.name if pattern == "*.urdf" else p.stem for p in root.glob(pattern))


def with_shipped(schema: dict[str, Any]) -> dict[str, Any]:
    """The params schema with `examples` (the shipped names) on every `x-shipped` field."""
    for props in [schema.get("properties") or {}] + [
        d.get("properties") or {} for d in (schema.get("$defs") or {}).values()
    ]:
        for prop in props.values():
            kind = prop.get("x-shipped")
            if kind in SHIPPED_KINDS and "examples" not in prop:
                prop["examples"] = shipped_names(kind)
    return schema


class NodeParams(BaseModel):
    """Base of every node's params model: unknown keys are an error (typos must not pass silently)."""

    model_config = ConfigDict(extra="forbid")


class Node:
    """Base class of node declarations. Subclasses set the ClassVars and implement `run`."""

    type: ClassVar[str]
    title: ClassVar[str] = ""
    category: ClassVar[str] = "general"
    inputs: ClassVar[tuple[Port, ...]] = ()
    outputs: ClassVar[tuple[Port, ...]] = ()
    Params: ClassVar[builtins.type[NodeParams]] = NodeParams  # builtins: `type` is the ClassVar above
    version: ClassVar[str] = "1"
    # True when `run` reads `ctx.node_id` (e.g. a program named after its artifact): the node id
    # then enters the cache key, so a renamed node never gets another node's cached output.
    uses_node_id: ClassVar[bool] = False

    # ---- execution ---------------------------------------------------------------------------
    def run(self, ctx: "Context", params: Any, inputs: dict[str, Any]) -> dict[str, Any]:
        """Compute all outputs from validated params and input values (keyed by port name)."""
        raise NotImplementedError

    def artifacts(self, ctx: "Context", params: Any, outputs: dict[str, Any]) -> dict[str, str | bytes]:
        """Files this node writes, keyed by suffix: {"layers.json": text} → `<node id>.layers.json`."""
        return {}

    # A layered input whose runs of consecutive layers `run_ahead` works on in the worker task that
    # has just made them (engine/parallel.py, chain tails); None: this node has no such work.
    ahead_input: ClassVar[str | None] = None

    def run_ahead(self, params: Any, items: list[Any]) -> Any:
        """Work on a run of consecutive layers of `ahead_input` (None where a layer is None), done
        ahead in a worker where a chain of layer nodes has just made them, before this node runs;
        `run` gets the results as `ctx.ahead()`. Speculative: `run` must verify what it takes
        (the layers a result was made from may not be the ones it is given), and its outputs must
        not depend on whether or where this ran. A pure function of params and items."""
        raise NotImplementedError

    def shared_work_s(self, params: Any, points: int) -> float:
        """Expected CPU seconds of this node's work that it hands to the run's workers when they
        are up (`Context.submit`), for a run of `points` path points: the cost model that starts
        the workers (`parallel.wants_workers`) counts it for the nodes still to run."""
        return 0.0

    def read_files(self, params: Any, read_bytes: Callable[[str], bytes | None]) -> list[str]:
        """Files `run` reads besides its `FileRef` params (a user's cell file and the meshes it
        names): their content signatures join the node's cache key, so editing one recomputes
        the node. `read_bytes(path)` → the file's bytes, or None when it cannot be read."""
        return []

    # ---- catalog -----------------------------------------------------------------------------
    @classmethod
    def describe(cls) -> dict[str, Any]:
        doc = (cls.__doc__ or "").strip()
        return {
            "type": cls.type,
            "title": cls.title or cls.type,
            "category": cls.category,
            "description": doc,
            "version": cls.version,
            "per_layer": issubclass(cls, LayerNode),
            "inputs": [p.to_dict() for p in cls.inputs],
            "outputs": [p.to_dict() for p in cls.outputs],
            "params_schema": with_shipped(cls.Params.model_json_schema()),
        }

    @classmethod
    def input_port(cls, name: str) -> Port | None:
        return next((p for p in cls.inputs if p.name == name), None)

    @classmethod
    def output_port(cls, name: str) -> Port | None:
        return next((p for p in cls.outputs if p.name == name), None)


class LayerNode(Node):
    """A node that maps over layers.

    `over` names the input whose value is a `Layered` collection that drives the mapping; every
    other `Layered` input is indexed alongside it, non-layered inputs are passed whole. The
    engine calls `run_layer` once per layer that is not cached, then `combine` once.

    The per-layer cache key is: type + version + `layer_params(params, index, items)` + the
    signatures of that layer's input items + the signatures of whole (non-layered) inputs.
    Override `layer_params` to return only what of the params affects layer `index` (e.g. the
    mask governing it), so editing something else does not recompute it.
    """

    over: ClassVar[str] = "layers"
    # True when `combine` hands each output's per-layer items on unchanged (it may only warn or
    # report): a layer node fed by this one may then compute its layer i right after this one's,
    # in the same worker task (engine/parallel.py, chains), instead of waiting for every layer.
    combine_keeps_items: ClassVar[bool] = False

    def layer_params(self, params: Any, index: int, items: dict[str, Any]) -> Any:
        return params.model_dump(mode="json")

    def keeps_items(self, params: Any) -> bool:
        """Whether `combine`, with these params, hands each output's per-layer items on unchanged
        (`combine_keeps_items`, or the default `combine`); a node whose combine rewrites items
        only with some params (the zone's parameter file) says so here."""
        return self.combine_keeps_items or type(self).combine is LayerNode.combine

    def run_layer(self, ctx: "Context", params: Any, index: int, items: dict[str, Any]) -> dict[str, Any]:
        """Compute this layer's output items (keyed by output port) from its input items."""
        raise NotImplementedError

    def combine(
        self, ctx: "Context", params: Any, outputs: dict[str, list[Any]], inputs: dict[str, Any]
    ) -> dict[str, Any]:
        """Assemble per-layer outputs into port values. Runs on every execution (cached layers
        included), so keep it cheap. Default: each output becomes `Layered(tuple(items))`.
        Whatever it reads from params beyond `layer_params` must be file content (hashed into
        the signature) or must be included in `layer_params`."""
        from ..core.model import Layered

        return {name: Layered(tuple(items)) for name, items in outputs.items()}


class Context:
    """What a node may ask of the engine while it runs (files, warnings, progress, cancel)."""

    node_id: str

    def read_bytes(self, path: str, *, max_bytes: int | None = None) -> bytes:  # pragma: no cover
        raise NotImplementedError

    def read_text(self, path: str, *, max_bytes: int | None = None) -> str:
        return self.read_bytes(path, max_bytes=max_bytes).decode("utf-8")

    def exists(self, path: str) -> bool:  # pragma: no cover
        raise NotImplementedError

    layer: int | None = None  # the layer being mapped, if any
    warnings: list[dict[str, Any]]

    def warn(self, message: str, *, layer: int | None = None, section: str | None = None) -> None:
        """Record a warning of this node, located at `layer` (default: the layer being mapped)."""
        w: dict[str, Any] = {"node": self.node_id, "message": message}
        layer = self.layer if layer is None else layer
        if layer is not None:
            w["layer"] = int(layer)
        if section is not None:
            w["section"] = section
        self.warnings.append(w)

    def progress(self, fraction: float, message: str = "") -> None:  # pragma: no cover
        raise NotImplementedError

    def report(self, data: dict[str, Any]) -> None:
        """Record a small structured result of this node (totals, per-layer figures: JSON-able,
        at most `MAX_REPORT_BYTES` as JSON). Keys merge over repeated calls. The engine stores the
        report with the node's cache entry (a cached re-run states it again) and writes it into
        `summary.json` under `nodes.<node id>.report`. A `LayerNode` reports from `combine` (it
        runs on every execution); reports made in `run_layer` are not collected."""
        import json

        merged = {**getattr(self, "_report", {}), **dict(data)}
        try:
            size = len(json.dumps(merged, allow_nan=False))
        except (TypeError, ValueError) as e:
            raise TypeError(f"node {self.node_id!r}: report must be finite JSON ({e})") from None
        if size > MAX_REPORT_BYTES:
            raise ValueError(
                f"node {self.node_id!r}: report is {size} bytes as JSON, over {MAX_REPORT_BYTES}; "
                "put large results in an artifact"
            )
        self._report = merged

    def take_report(self) -> dict[str, Any]:
        """The report recorded so far, and reset (engine side)."""
        out = getattr(self, "_report", {})
        self._report = {}
        return out

    def trace(self) -> dict[str, Any]:
        """Traceability of the run (date UTC, waamflow version, recipe name and sha256, sha256 of
        each input file read) for program headers; {} outside a run. Never part of a cache key."""
        return {}

    def check_cancelled(self) -> None:  # pragma: no cover
        raise NotImplementedError

    def map(self, fn: Callable[[Any], Any], items: Sequence[Any], *, layers: int = 0, points: int = 0) -> list[Any]:
        """fn over the items, results in item order: here, or in the run's layer workers when they
        are up and the engine's cost model says work of this size (layers, path points) pays for
        the round trips. fn must be a module-level function and the items picklable; the results
        are the same either way."""
        return [fn(x) for x in items]

    def map_in_workers(
        self,
        fn: Callable[[Any], Any],
        items: Sequence[Any],
        *,
        layers: int = 0,
        points: int = 0,
        seconds: float | None = None,
    ) -> list[Any] | None:
        """`map` when it would run in the run's layer workers; None when it would run here. For
        speculative work, which pays only beside the node's own (the sequence node's runs of
        layers). `seconds`: the work's expected serial CPU seconds, from a kernel that knows its
        own cost better than the engine's cost model of `layers` and `points` (which it replaces)."""
        return None

    def ahead(self) -> list[Any]:
        """What `Node.run_ahead` gave for runs of this node's `ahead_input` layers in the run's
        workers, in no particular order ([] when nothing ran ahead); taken once."""
        return []

    def can_submit(self) -> bool:
        """Whether `submit` would start work in a worker now: a node builds a large job only then."""
        return False

    def start_workers(self, work_s: float) -> None:
        """Start the run's layer workers in the background, if they are not up and `work_s` (the
        expected CPU seconds of what this node will `submit`) pays for their start (the engine's
        cost model); the node goes on meanwhile, its `submit` returning None until they are up."""

    def submit(self, fn: Callable[[Any], Any], item: Any) -> Future[Any] | None:
        """fn(item) started in one of the run's layer workers, as a Future, when they are up
        (never waiting for them to start); None otherwise: the caller computes it itself. For
        work that overlaps the node's own (fn a module-level function, item picklable); the
        node's outputs must not depend on where it ran."""
        return None


# ---- registry ----------------------------------------------------------------------------------
REGISTRY: dict[str, type[Node]] = {}


def register(cls: type[Node]) -> type[Node]:
    """Class decorator: add a node declaration to the registry under its stable type id."""
    if not getattr(cls, "type", None):
        raise TypeError(f"{cls.__name__} has no type id")
    if cls.type in REGISTRY and REGISTRY[cls.type] is not cls:
        raise TypeError(f"node type {cls.type!r} declared twice ({REGISTRY[cls.type].__name__}, {cls.__name__})")
    if not cls.__doc__:
        raise TypeError(f"node {cls.type!r} needs a docstring (it is the catalog description)")
    REGISTRY[cls.type] = cls
    return cls


def load_nodes() -> dict[str, type[Node]]:
    """Import every module in waamflow.nodes (each registers its declarations) and return the registry."""
    import importlib
    import pkgutil

    from .. import nodes

    for mod in pkgutil.iter_modules(nodes.__path__):
        importlib.import_module(f"{nodes.__name__}.{mod.name}")
    return REGISTRY


_DECLARED: dict[str, str] = {}  # node type id → the waamflow.nodes module whose source declares it


def _declaring_modules() -> dict[str, str]:
    """Node type id → module, read off the sources of waamflow.nodes: a declaration's class body
    says `type = "<id>"` (read once per process; a few milliseconds against the ~0.1 s of CPU
    the node modules a recipe does not use take to import)."""
    if not _DECLARED:
        import pkgutil
        import re
        from pathlib import Path

        from .. import nodes

        for mod in pkgutil.iter_modules(nodes.__path__):
            try:
                text = (Path(nodes.__path__[0]) / f"{mod.name}.py").read_text(encoding="utf-8")
            except OSError:  # not a plain source file: `node_class` falls back to `load_nodes`
                continue
            for type_id in re.findall(r'^    type = "([^"]+)"', text, flags=re.MULTILINE):
                _DECLARED.setdefault(type_id, f"{nodes.__name__}.{mod.name}")
    return _DECLARED


def node_class(type_id: str) -> type[Node] | None:
    """The declaration of node type `type_id`, importing only the node module that declares it
    (a CLI run of a recipe without robot nodes does not import the trajectory kernels); every
    node module when the sources do not place it. None for an unknown type."""
    if type_id not in REGISTRY:
        import importlib

        module = _declaring_modules().get(type_id)
        if module is not None:
            importlib.import_module(module)
        if type_id not in REGISTRY:
            load_nodes()
    return REGISTRY.get(type_id)


def catalog() -> list[dict[str, Any]]:
    return [REGISTRY[t].describe() for t in sorted(load_nodes())]
