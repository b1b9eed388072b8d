"""Live builds on the server (#29): a build started from a finished run, scans posted layer by
layer, the next layer's program handed back (`waamflow.asbuilt.session`).

A build lives in `<data>/builds/<id>/`: `build.json` (which run, who, the window), the session's
`state.json`, its per-layer arrays and the scans as received. The plan is not stored: it is the
run's stored recipe and draft XML re-planned through the server's cache, so after a restart the
first request to a build re-plans it and the build goes on where it stood. One lock per build
serialises its scans.
"""

from __future__ import annotations

import json
import secrets
import threading
from pathlib import Path
from typing import Any

from ..asbuilt.adapt import Window
from ..asbuilt.run import dwell_rule_of, post_callable, program_toolpath
from ..asbuilt.session import BuildSession
from ..core.errors import RecipeError
from ..engine.recipe import parse_recipe


class BuildNotFound(KeyError):
    pass


class Builds:
    def __init__(self, svc) -> None:
        self.svc = svc
        self.root = Path(svc.settings.data_dir) / "builds"
        self._sessions: dict[str, BuildSession] = {}
        self._locks: dict[str, threading.Lock] = {}
        self._guard = threading.Lock()

    def lock(self, build_id: str) -> threading.Lock:
        with self._guard:
            return self._locks.setdefault(build_id, threading.Lock())

    def _plan(self, run: dict):
        from ..engine.executor import execute
        from ..engine.graph import build_graph

        recipe = parse_recipe(run["recipe"])
        xml = self.svc.store.get_run_params_xml(run["id"])
        graph = build_graph(recipe)
        result = execute(
            graph,
            resolver=self.svc.resolver_for(run["graph"], recipe, xml),
            cache=self.svc.cache,
            artifacts=False,
            preflight=False,
            workers=self.svc.settings.layer_workers,
            scheduler=self.svc.settings.scheduler,
        )
        toolpath, src = program_toolpath(graph, result.outputs)
        post_id = next((nid for nid in graph.order if graph.nodes[nid].type == "post-process"), None)
        return toolpath, (post_callable(graph, post_id) if post_id else None), src, graph

    def create(
        self,
        run_id: str,
        who: str | None,
        window: Window,
        interpass_c: float | None = None,
        max_dwell_s: float | None = None,
    ) -> BuildSession:
        run = self.svc.store.get_run(run_id)
        if run is None:
            raise BuildNotFound(f"no run {run_id!r}")
        if run["status"] != "done":
            raise RecipeError(f"run {run_id} is {run['status']}: a build starts from a finished run")
        toolpath, post, src, graph = self._plan(run)
        rule = dwell_rule_of(graph, interpass_c, max_dwell_s)
        build_id = secrets.token_hex(6)
        folder = self.root / build_id
        meta = {
            "id": build_id,
            "run": run_id,
            "graph": run["graph"],
            "toolpath_node": src,
            "layers": sum(1 for x in toolpath.items if x is not None),
            "window": window.__dict__,
            "by": who,
            "interpass": rule.to_dict(),
        }
        s = BuildSession.create(folder, toolpath, meta, who=who, post=post, window=window)
        self._sessions[build_id] = s
        return s

    def get(self, build_id: str) -> BuildSession:
        s = self._sessions.get(build_id)
        if s is not None:
            return s
        folder = self.root / build_id
        if not build_id.isalnum() or not (folder / "state.json").is_file():
            raise BuildNotFound(f"no build {build_id!r}")
        meta = json.loads((folder / "state.json").read_text(encoding="utf-8"))["meta"]
        run = self.svc.store.get_run(meta["run"])
        if run is None:
            raise RecipeError(f"build {build_id}: its run {meta['run']} is gone, so its plan cannot be rebuilt")
        toolpath, post, _, _ = self._plan(run)
        s = BuildSession.load(folder, toolpath, post=post, window=Window(**meta.get("window", {})))
        self._sessions[build_id] = s
        return s

    def list(self) -> list[dict[str, Any]]:
        out: list[dict[str, Any]] = []
        if not self.root.is_dir():
            return out
        for d in sorted(self.root.iterdir()):
            f = d / "state.json"
            if f.is_file():
                st = json.loads(f.read_text(encoding="utf-8"))
                out.append(
                    {
                        "id": d.name,
                        "run": st["meta"]["run"],
                        "graph": st["meta"].get("graph"),
                        "status": st["status"],
                        "created": st["created"],
                        "layers_planned": st["meta"]["layers"],
                        "layers_scanned": len(st.get("layers", [])),
                    }
                )
        return out
