"""The server's long-lived objects, created in the FastAPI lifespan and reached through deps.py."""

from __future__ import annotations

import json
import logging
import os
import re
import stat
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from ..core.errors import InputFileError, RecipeError, WaamflowError
from ..core.files import not_regular, read_regular
from ..engine.cache import MemoryCache, SqliteCache, TieredCache
from ..engine.executor import FileResolver, RunResult
from ..engine.graph import Graph
from ..engine.recipe import Recipe, parse_recipe
from ..settings import Settings
from .store import Store, valid_graph_name
from .worker import RunManager

log = logging.getLogger("waamflow.server")


def params_file_names(recipe: Recipe) -> list[str]:
    """The `parameters` file names of the recipe's zone nodes (their XML is the graph's params)."""
    out = []
    for n in recipe.nodes:
        params = n.params if isinstance(n.params, dict) else {}
        if n.type == "zone" and isinstance(params.get("parameters"), str) and params["parameters"]:
            out.append(params["parameters"])
    return out


URL = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")


class SandboxError(RecipeError):
    """A recipe sent over REST names a file outside the server's data and graphs folders."""

    kind = "outside_sandbox"


def _is_file_field(field, value: Any = None) -> bool:
    """A file parameter: `x-file` (engine.node.FileRef), or `x-file-suffix` when the value ends with
    it (simulate-robot's `cell`: a shipped name, or a user's cell .json file)."""
    extras = [field.json_schema_extra] + [getattr(m, "json_schema_extra", None) for m in field.metadata]
    for e in extras:
        if not isinstance(e, dict):
            continue
        if e.get("x-file") or e.get("format") == "path":
            return True
        if e.get("x-file-suffix") and isinstance(value, str) and value.endswith(e["x-file-suffix"]):
            return True
    return False


def file_params(model: BaseModel, prefix: str = "") -> list[tuple[str, str]]:
    """(dotted parameter name, value) of every file parameter in a node's validated params, at any
    depth (nested models, lists and dicts of models): fields marked `x-file` (engine.node.FileRef)."""
    out: list[tuple[str, str]] = []
    for name, f in type(model).model_fields.items():
        value = getattr(model, name, None)
        key = f"{prefix}{name}"
        if _is_file_field(f, value):
            for i, v in enumerate(value if isinstance(value, (list, tuple)) else [value]):
                if isinstance(v, str) and v:
                    out.append((key if not isinstance(value, (list, tuple)) else f"{key}.{i}", v))
            continue
        items = (
            value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, (list, tuple)) else None
        )
        if isinstance(value, BaseModel):
            out += file_params(value, key + ".")
        elif items is not None:
            for k, v in items:
                if isinstance(v, BaseModel):
                    out += file_params(v, f"{key}.{k}.")
    return out


def sandbox_problem(path: str, resolver: FileResolver) -> str | None:
    """Why a file parameter sent over REST may not be read, or None when it may."""
    if path in resolver.attachments:
        return None
    if path.startswith(("/", "\\")) or (len(path) > 1 and path[1] == ":"):
        return "absolute paths are not allowed over the API: upload the file and name it"
    if URL.match(path):
        return "URLs are not read by the server: upload the file to the graph instead"
    if ".." in re.split(r"[\\/]", path):
        return "'..' is not allowed in a file name over the API"
    try:
        p = resolver.resolve(path)  # follows symlinks; must end inside the data or graphs folder
    except RecipeError:
        return "the file (or the link it goes through) lies outside the server's data and graphs folders"
    return not_regular(p)  # a FIFO, device or socket inside: refused unopened (stat only)


def _check_files(node_id: str, params: BaseModel, resolver: FileResolver) -> None:
    for pname, value in file_params(params):
        why = sandbox_problem(value, resolver)
        if why:
            raise SandboxError(f"file {value!r} refused: {why}", node=node_id, field=pname)


def parse_api_recipe(data: Any) -> Recipe:
    """`parse_recipe` for a request body: whatever JSON arrives, a bad recipe is a RecipeError (422)."""
    try:
        return parse_recipe(data)
    except RecipeError:
        raise
    except (TypeError, ValueError, AttributeError, KeyError, IndexError) as e:
        raise RecipeError(f"invalid recipe: {e}") from None


class RunsUnavailable(WaamflowError):
    """A run route on a server started without run workers: 503 naming why."""

    kind = "unavailable"
    http_status = 503


@dataclass
class Services:
    settings: Settings
    store: Store
    cache: TieredCache
    runs: RunManager | None = None
    viewer: Any = None
    extra: dict = field(default_factory=dict)
    auth_required: bool = False
    # recipes of the graphs folder that could not be offered: name → {file, size, reason}; listed by
    # GET /api/graphs with this marker, their GET is a 422 with the reason (never skipped silently)
    unloaded: dict[str, dict] = field(default_factory=dict)

    def run_manager(self) -> RunManager:
        """`runs`, which the app's lifespan makes at startup unless `start_workers` is false: every
        route that queues, reads or cancels a run goes through here (503 without one)."""
        if self.runs is None:
            raise RunsUnavailable(
                "this server was started without run workers (start_workers false): "
                "it keeps graphs but cannot run them; start it with workers to run"
            )
        return self.runs

    def release_reserve(self) -> int:
        """Delete the disk reserve (bytes freed): after a disk-full error, so that deletes, whose
        database journal needs a little room, go through. Made again at the next start."""
        p = Path(self.settings.data_dir) / RESERVE_NAME
        try:
            n = p.stat().st_size
            p.unlink()
            return n
        except OSError:
            return 0

    def prepare(self, graph_name: str | None, recipe: Recipe, params_xml: str | None = None) -> Recipe:
        """A saved graph's zone nodes that name no parameter file use the XML stored with the graph
        (`<graph>.params.xml`), or the draft XML sent with the run, so values filled in the GUI reach
        the run without setting a path. An unsaved recipe's draft XML is the file `draft.params.xml`."""
        if params_xml is None and (not graph_name or self.store.get_params_xml(graph_name) is None):
            return recipe
        r = recipe.model_copy(deep=True)
        for n in r.nodes:
            if n.type == "zone" and not n.params.get("parameters"):
                n.params["parameters"] = f"{graph_name or 'draft'}.params.xml"
        return r

    # files a graph's nodes may read: its stored files + its parameter XML, then the graphs folder
    # (a draft XML sent with the run stands in for the saved one and is never stored)
    def resolver_for(self, graph_name: str | None, recipe: Recipe, params_xml: str | None = None) -> FileResolver:
        attachments: dict[str, bytes] = {}
        if graph_name:
            attachments.update(self.store.get_files(graph_name))
        attachments.update(self.pinned_files(graph_name, recipe))
        xml = params_xml if params_xml is not None or not graph_name else self.store.get_params_xml(graph_name)
        if xml:
            for fname in params_file_names(recipe):
                attachments[fname] = xml.encode("utf-8")
        base = self.settings.graphs_dir or self.settings.data_dir
        roots = [p for p in (self.settings.graphs_dir, self.settings.data_dir) if p is not None]
        return FileResolver(base, attachments, roots=roots)

    def pinned_files(self, graph_name: str | None, recipe: Recipe) -> dict[str, bytes]:
        """The recipe's `files` pins (name → sha256): exactly that content of the graph's uploads,
        whatever the name points at now (#25: a same-name upload never changes a pinned recipe's run)."""
        out: dict[str, bytes] = {}
        for name, digest in (recipe.files or {}).items():
            data = self.store.get_file_content(graph_name, digest) if graph_name else None
            if data is None:
                where = f"graph {graph_name!r}" if graph_name else "an unsaved recipe (save it first)"
                raise RecipeError(
                    f"file {name!r} is pinned to content sha256 {digest[:12]}… that {where} does not have",
                    field=f"files.{name}",
                )
            out[name] = data
        return out

    def check_sandbox(self, graph: Graph, resolver: FileResolver) -> None:
        """Before anything runs: every file parameter of every node of a recipe that came over REST
        names an uploaded file or a regular file inside the data/graphs folders (422 naming node and
        param)."""
        for nid, gnode in graph.nodes.items():
            _check_files(nid, gnode.params, resolver)

    def check_recipe_files(self, recipe: Recipe, resolver: FileResolver) -> None:
        """check_sandbox on each node's validated params alone, before the graph's edges are checked:
        a file reference is judged first, whatever else the recipe lacks (422 naming node and
        param; a shipped name that is not one fails its pattern here too)."""
        from ..engine.graph import _validate_params
        from ..engine.node import REGISTRY, load_nodes
        from ..engine.recipe import substitute_inputs

        load_nodes()
        for entry in recipe.nodes:
            cls = REGISTRY.get(entry.type)
            if cls is None:
                continue  # build_graph names it
            raw = substitute_inputs(entry.params, recipe.inputs, entry.id)
            _check_files(entry.id, _validate_params(entry.id, cls, raw), resolver)

    def after_run(self, run_id: str, graph_name: str | None, recipe: Recipe, result: RunResult) -> None:
        # A run never writes what the user saved: the merged parameter XML (values kept, orphans
        # reported) is a run artifact; the GUI offers it as a draft that changes the graph on save.
        if self.viewer is not None:
            # publishing a large part takes seconds: do it beside the run, not inside it
            threading.Thread(
                target=self._publish,
                args=(graph_name or run_id, recipe.to_json(), result.outputs, run_id),
                name="waamflow-viewer-publish",
                daemon=True,
            ).start()

    def _publish(self, key: str, recipe: dict, outputs: dict, run_id: str) -> None:
        try:
            self.viewer.publish(key, recipe, outputs, run=run_id)
        except Exception:
            log.exception("3D preview update failed for %s", key)

    def scene_source(self, key: str):
        """For the 3D preview after a restart (its scenes live in memory): the latest finished run
        of graph `key` (or the finished run with id `key`) as (run id, rebuild), where
        rebuild(cancel) re-executes the run's stored recipe, with the draft XML it used, through the
        engine and the server's cache and returns (recipe JSON, outputs). None: no such run."""
        run = self.store.latest_finished_run(key)
        if run is None:
            return None
        run_id, graph_name = run["id"], run["graph"]

        def rebuild(cancel: threading.Event) -> tuple[dict, dict]:
            from ..engine.executor import execute
            from ..engine.graph import build_graph

            recipe = parse_recipe(run["recipe"])
            xml = self.store.get_run_params_xml(run_id)
            result = execute(
                build_graph(recipe),
                resolver=self.resolver_for(graph_name, recipe, xml),
                cache=self.cache,
                cancel=cancel,
                artifacts=False,
                workers=self.settings.layer_workers,
                scheduler=self.settings.scheduler,
            )
            return recipe.to_json(), result.outputs

        return run_id, rebuild


RESERVE_NAME = ".disk-reserve"


def make_reserve(data: Path, nbytes: int) -> bool:
    """A file of `nbytes` really allocated on the data folder's disk, given back when the disk is full."""
    p = data / RESERVE_NAME
    try:
        if p.is_file() and p.stat().st_size >= nbytes:
            return True
        with open(p, "wb") as f:
            os.posix_fallocate(f.fileno(), 0, nbytes)
        return True
    except (OSError, AttributeError):
        try:
            p.unlink()
        except OSError:
            pass
        return False


def build_services(settings: Settings) -> Services:
    data = Path(settings.data_dir)
    data.mkdir(parents=True, exist_ok=True)
    if settings.disk_reserve_mb and not make_reserve(data, int(settings.disk_reserve_mb * 2**20)):
        log.warning("no room for the %g MB disk reserve in %s: free some space", settings.disk_reserve_mb, data)
    store = Store(data / "waamflow.sqlite")
    disk = SqliteCache(data / "cache.sqlite", max_bytes=int(settings.disk_cache_gb * 1024**3))
    cache = TieredCache(MemoryCache(settings.memory_cache_entries), disk)
    svc = Services(settings, store, cache)
    n = store.mark_interrupted()
    if n:
        log.warning("%d runs were interrupted by the last shutdown and are marked interrupted", n)
    seed_examples(svc)
    return svc


class ExampleNotLoaded(Exception):
    """Why a recipe of the graphs folder is not offered (its text never echoes the file's content)."""


def _mtime(path: Path) -> float:
    try:
        return path.lstat().st_mtime
    except OSError:
        return 0.0


def seed_examples(svc: Services) -> None:
    """Offer the recipes in the graphs folder; never overwrite a graph the user has saved."""
    gdir = svc.settings.graphs_dir
    if gdir is None or not Path(gdir).is_dir():
        return
    for path in sorted(Path(gdir).glob("*.json")):
        name = path.stem
        if not valid_graph_name(name) or svc.store.get_graph(name) is not None:
            continue
        size = 0
        try:
            st = path.stat()
            size = st.st_size if stat.S_ISREG(st.st_mode) else 0
            limit = svc.settings.max_body_mb * 2**20  # checked before reading: the limit of PUT /api/graphs
            if size > limit:
                raise ExampleNotLoaded(
                    f"{size / 2**20:.2f} MB, over the {svc.settings.max_body_mb:g} MB recipe "
                    "limit (max_body_mb): raise WAAMFLOW_MAX_BODY_MB or make the file smaller"
                )
            # through the file gate: a FIFO named *.json in the graphs folder must not hang the start
            raw = read_regular(path, int(limit), label=path.name)
            try:
                data = json.loads(raw.decode("utf-8"))
            except (UnicodeDecodeError, json.JSONDecodeError) as e:
                raise ExampleNotLoaded(
                    f"not valid JSON ({type(e).__name__} at character {getattr(e, 'pos', getattr(e, 'start', '?'))})"
                ) from None
            recipe = parse_recipe(data)
        except Exception as e:  # a broken example must not stop the server; it is listed with the reason
            reason = (
                str(e)
                if isinstance(e, (ExampleNotLoaded, InputFileError, RecipeError))
                else f"cannot be read ({type(e).__name__})"
            )
            log.warning("example %s not loaded: %s", path.name, reason)
            svc.unloaded[name] = {"file": path.name, "size": size, "reason": reason, "updated": _mtime(path)}
            continue
        svc.store.put_graph(name, recipe.to_json(), example=True)
        for fname in params_file_names(recipe):
            p = Path(gdir) / fname
            if p.is_file():
                try:
                    svc.store.put_params_xml(name, read_regular(p, 32 * 2**20).decode("utf-8"))
                except (InputFileError, UnicodeDecodeError) as e:
                    log.warning("parameter file %s of example %s not loaded: %s", fname, name, e)
                break
