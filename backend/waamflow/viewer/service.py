"""The 3D preview service: a viser server the API starts in its lifespan and feeds after each run.

    viewer = ViewerService(host="127.0.0.1", port=8080)
    viewer.start()                       # non-blocking: viser serves from its own thread
    viewer.publish("mpp-cross", recipe, outputs)   # outputs: node id → port → value
    viewer.select("toolpath", 3)         # the GUI follows the selected node / layer
    viewer.show("mpp-cross")             # the GUI's open recipe: its latest published run
    viewer.loader = source               # optional: key → (run id, rebuild) for runs not in memory
    viewer.set_view(hidden={"slice"}, layer_lo=2, layer_hi=5, sim_color="deposit", time_s=3.0)
    viewer.state()                       # nodes, layer extent, view and legend data for the GUI
    viewer.url                           # → /api/health `viewer_url`
    viewer.stop()

Scenes are keyed (graph name, or run id for an unsaved recipe): the last few published runs are
kept, and `show(key)` switches the scene to one of them — the GUI asks for the open recipe's, so
a run of another recipe on the same server does not replace what the user looks at. Scenes live in
memory: when `show(key)` finds none (the server restarted, or the scene was evicted) and a `loader`
is set, the latest finished run of `key` is rebuilt beside the server (`state()["loading"]` says
which run meanwhile) and shown when ready.
The scene is shared: every connected browser sees the same content and GUI. Re-publishing
redraws only outputs (and, for per-layer outputs, only layers) whose content signature changed.
Large parts are decimated for display (`max_segments` line segments per output in total); the
data is never modified.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict
from typing import Any, Callable

import numpy as np

from . import colors as C
from . import geometry as G
from .scene import (PATH_COLOR_MODES, SIM_COLOR_MODES, FeaturesPart, LayersPart, MeshPart, Part, Pick,
                    SectionsPart, ToolpathPart, ViewState, kind_of, slug)
from .simulation import SimulationPart

log = logging.getLogger("waamflow.viewer")

PART_TYPES: dict[str, type[Part]] = {
    "mesh": MeshPart, "layers": LayersPart, "sections": SectionsPart, "toolpath": ToolpathPart,
    "simulation": SimulationPart, "features": FeaturesPart,
}

PICK_TOLERANCE = 0.01  # picking radius as a fraction of the scene's bounding-box diagonal
MAX_SCENES = 4         # published runs kept for `show(key)` (outputs are held by reference)
VIEW_FIELDS = ("layer_lo", "layer_hi", "path_color", "sim_color", "time_s", "show_robot",
               "sim_offset_mm", "show_programmed", "show_simulated")


class ViewerService:
    """viser server + scene adapters + GUI panel (layer range, colour-by, per-node visibility,
    playback, picked-point readout). Thread-safe: publish/select may come from any thread."""

    def __init__(self, host: str = "127.0.0.1", port: int = 8080, *, max_segments: int = 300_000,
                 label: str = "waamflow") -> None:
        self.host = host
        self.port = port
        self.max_segments = int(max_segments)
        self.label = label
        self.server = None
        self.parts: dict[tuple[str, str], Part] = {}
        self.view = ViewState()
        self.key: str | None = None
        self.node_types: dict[str, str] = {}
        self.selected: tuple[str | None, int | None] = (None, None)
        self.last_pick: dict[str, Any] | None = None
        self._lock = threading.RLock()
        self._gui: dict[str, Any] = {}
        self._syncing = False
        self._node_boxes: dict[str, Any] = {}
        self._node_frames: dict[str, Any] = {}     # /graph/<node>: toggles the node's visibility
        self._play_stop = threading.Event()
        self._play_thread: threading.Thread | None = None
        self._bounds: np.ndarray | None = None
        self._extent: tuple[int, int] = (self.view.layer_lo, self.view.layer_hi)   # layers published
        self.scenes: OrderedDict[str, tuple[dict | None, dict]] = OrderedDict()   # key → (recipe, outputs)
        self.wanted: str | None = None   # the key the GUI shows (None: whatever was published last)
        self.scene_runs: dict[str, str] = {}   # key → id of the run its scene shows (when known)
        # key → (run id, rebuild(cancel) → (recipe, outputs)) | None: finds a finished run that is
        # not in memory (after a restart); set by the API to read its store
        self.loader: Callable[[str], tuple[str, Callable[[threading.Event], tuple[dict | None, dict]]] | None] | None = None
        self._rebuilding: dict[str, dict[str, Any]] = {}   # key → {"run", "since"} while rebuilt
        self._rebuild_failed: dict[str, dict[str, Any]] = {}   # key → {"run", "message"}
        self._rebuild_stop = threading.Event()

    # ------------------------------------------------------------------------------------------
    # lifecycle
    # ------------------------------------------------------------------------------------------
    def start(self) -> "ViewerService":
        """Start the viser server (returns at once; viser runs its own thread). Idempotent."""
        import viser

        with self._lock:
            if self.server is not None:
                return self
            self._rebuild_stop.clear()   # stop() cancelled the rebuilds of the previous start
            from .embed import embedded_client

            with embedded_client():
                self.server = viser.ViserServer(host=self.host, port=self.port, label=self.label, verbose=False)
            self.server.scene.set_up_direction("+z")
            self._graph_frame = self.server.scene.add_frame("/graph", show_axes=False)   # moved by a cell's positioner
            self._build_gui()
            self.server.scene.on_click()(self._on_click)
        return self

    def stop(self) -> None:
        """Stop playback and the server; the service can be started again afterwards."""
        self._play_stop.set()
        self._rebuild_stop.set()
        if self._play_thread is not None:
            self._play_thread.join(timeout=2.0)
            self._play_thread = None
        with self._lock:
            if self.server is not None:
                self.server.stop()
            self.server = None
            self.parts.clear()
            self.scenes.clear()
            self._gui.clear()
            self._node_boxes.clear()
            self._node_frames.clear()

    @property
    def url(self) -> str | None:
        """http URL of the viewer page (None until started). Port 0 resolves to the bound port."""
        if self.server is None:
            return None
        host = self.server.get_host()
        host = "127.0.0.1" if host in ("0.0.0.0", "") else host
        return f"http://{host}:{self.server.get_port()}"

    @property
    def bound_port(self) -> int | None:
        """The port viser actually listens on (it moves to the next free one if `port` is busy)."""
        return None if self.server is None else int(self.server.get_port())

    # ------------------------------------------------------------------------------------------
    # publishing
    # ------------------------------------------------------------------------------------------
    def publish(self, key: str, recipe: dict | None, outputs: dict[str, dict[str, object]], *,
                run: str | None = None) -> dict[str, int]:
        """Show a run's outputs (`run`: its id, reported by `state()`). Only outputs whose content
        changed are redrawn; outputs of nodes that are gone are removed. Returns counts:
        {"redrawn", "kept", "removed", "skipped"} (redrawn = scene nodes added or replaced;
        skipped = outputs with nothing to draw)."""
        if self.server is None:
            raise RuntimeError("ViewerService.publish before start()")
        with self._lock:
            self.scenes[key] = (recipe, outputs)
            self.scenes.move_to_end(key)
            if run is None:
                self.scene_runs.pop(key, None)
            else:
                self.scene_runs[key] = run
            self._rebuild_failed.pop(key, None)
            while len(self.scenes) > MAX_SCENES:
                self.scene_runs.pop(self.scenes.popitem(last=False)[0], None)
            if self.wanted is not None and key != self.wanted:
                # another recipe's run: kept for when the GUI asks for it, the shown scene stays
                return {"redrawn": 0, "kept": 0, "removed": 0, "skipped": 0, "deferred": 1}
            return self._draw(key, recipe, outputs)

    def _draw(self, key: str, recipe: dict | None, outputs: dict[str, dict[str, object]]) -> dict[str, int]:
        stats = {"redrawn": 0, "kept": 0, "removed": 0, "skipped": 0}
        nodes = (recipe or {}).get("nodes", [])
        with self._lock, self.server.atomic():
            self.key = key
            self.node_types = {str(n.get("id")): str(n.get("type", "")) for n in nodes if isinstance(n, dict)}
            wanted: dict[tuple[str, str], tuple[str, Any]] = {}
            for node, ports in outputs.items():
                for port, value in (ports or {}).items():
                    kind = kind_of(value)
                    if kind is None:
                        stats["skipped"] += 1
                        continue
                    wanted[(str(node), str(port))] = (kind, value)
            for k in [k for k, p in self.parts.items() if k not in wanted or p.kind != wanted[k][0]]:
                self.parts.pop(k).remove()
                stats["removed"] += 1
            for node in [n for n in self._node_frames if all(k[0] != n for k in wanted)]:
                self._node_frames.pop(node).remove()
            for (node, port), (kind, value) in wanted.items():
                part = self.parts.get((node, port))
                if part is None:
                    if node not in self._node_frames:
                        self._node_frames[node] = self.server.scene.add_frame(f"/graph/{slug(node)}", show_axes=False)
                    part = self.parts[(node, port)] = PART_TYPES[kind](self.server.scene, node, port, self.max_segments)
                if kind == "simulation":
                    part.graph_frame = getattr(self, "_graph_frame", None)
                    part.node_params = dict(next((nd.get("params") or {} for nd in nodes
                                                  if isinstance(nd, dict) and str(nd.get("id")) == node), {}))
                n = part.sync(value, self.view)
                if n:
                    stats["redrawn"] += n
                else:
                    stats["kept"] += 1
            self._after_publish()
        return stats

    def show(self, key: str | None) -> bool:
        """Show the latest published run under `key` (the GUI's open recipe); an unknown key
        empties the scene until a run of it is published, or until the `loader` has rebuilt the
        latest finished run of it. None: follow every publish again.
        Returns whether a run of `key` is shown."""
        if self.server is None:
            return False
        with self._lock:
            self.wanted = key
            if key is None or key == self.key:
                return key is not None
            self.view.hidden.clear()   # node ids of another recipe say nothing about this one
            if key in self.scenes:
                recipe, outputs = self.scenes[key]
                self._draw(key, recipe, outputs)
                return True
            with self.server.atomic():
                for k in list(self.parts):
                    self.parts.pop(k).remove()
                for node in list(self._node_frames):
                    self._node_frames.pop(node).remove()
                self.key, self.node_types = key, {}
                self._bounds = None
                self._after_publish()
            self._start_rebuild(key)
            return False

    def _start_rebuild(self, key: str) -> None:
        """Rebuild the latest finished run of `key` in a thread (no-op without a loader, when one
        is under way, or when `key` has no finished run)."""
        if self.loader is None or key in self._rebuilding:
            return
        try:
            found = self.loader(key)
        except Exception as e:   # a broken store must not break the select request
            log.exception("looking up a run of %s to rebuild failed", key)
            self._rebuild_failed[key] = {"run": None, "message": str(e)}
            return
        if found is None:
            return
        run_id, rebuild = found
        self._rebuild_failed.pop(key, None)
        self._rebuilding[key] = {"key": key, "run": run_id, "since": time.time()}
        threading.Thread(target=self._rebuild, args=(key, run_id, rebuild), name=f"viewer-rebuild-{run_id}",
                         daemon=True).start()

    def _rebuild(self, key: str, run_id: str, rebuild: Callable) -> None:
        try:
            recipe, outputs = rebuild(self._rebuild_stop)
            with self._lock:   # state() sees the scene and the end of loading together
                self._rebuilding.pop(key, None)
                # a run that ended meanwhile was published under `key`: it is newer, keep it
                if self.server is not None and key not in self.scenes:
                    self.publish(key, recipe, outputs, run=run_id)
        except Exception as e:
            log.warning("rebuilding the 3D scene of run %s (%s) failed: %s", run_id, key, e)
            with self._lock:
                self._rebuild_failed[key] = {"run": run_id, "message": str(e)}
        finally:
            with self._lock:
                self._rebuilding.pop(key, None)
                if self._gui and self.key == key:
                    self._sync_gui()

    def set_view(self, *, hidden: set[str] | None = None, fit: bool = False, **fields: Any) -> None:
        """Apply the GUI's view settings (any subset of VIEW_FIELDS, plus hidden node ids);
        `fit` frames the camera on what is published."""
        unknown = set(fields) - set(VIEW_FIELDS)
        if unknown:
            raise ValueError(f"unknown view setting(s): {', '.join(sorted(unknown))}")
        with self._lock:
            if fields.get("path_color", PATH_COLOR_MODES[0]) not in PATH_COLOR_MODES:
                raise ValueError(f"path_color must be one of {', '.join(PATH_COLOR_MODES)}")
            if fields.get("sim_color", SIM_COLOR_MODES[0]) not in SIM_COLOR_MODES:
                raise ValueError(f"sim_color must be one of {', '.join(SIM_COLOR_MODES)}")
            for k, v in fields.items():
                if v is not None:
                    setattr(self.view, k, type(getattr(self.view, k))(v))
            if hidden is not None:
                self.view.hidden = set(hidden)
            lo, hi = self._layer_extent()
            if "layer_lo" in fields or "layer_hi" in fields:
                self.view.layer_lo = int(np.clip(self.view.layer_lo, lo, hi))
                self.view.layer_hi = int(np.clip(self.view.layer_hi, self.view.layer_lo, hi))
            if self.server is None:
                return
            with self.server.atomic():
                self._sync_gui()
                self._apply()
                if "time_s" in fields:
                    for p in self.parts.values():
                        if p.kind == "simulation":
                            p.set_time(self.view.time_s)
            b = self.part_bounds()
            if fit and b is not None:
                self._frame_camera(b)

    def state(self) -> dict[str, Any]:
        """What the GUI's 3D tab shows beside the scene: the shown run, its nodes (with what each
        draws and whether it is visible), layer extent, playback duration, view settings and the
        legend data (zone colours, scalar ranges with units, the colour map's stops)."""
        with self._lock:
            lo, hi = self._layer_extent()
            nodes: dict[str, dict[str, Any]] = {}
            for (node, port), part in self.parts.items():
                e = nodes.setdefault(node, {"id": node, "type": self.node_types.get(node, ""), "kinds": [],
                                            "visible": node not in self.view.hidden})
                e["kinds"].append(part.kind)
            order = {n: i for i, n in enumerate(self.node_types)}
            legend: list[dict[str, Any]] = []
            duration = 0.0
            for part in self.parts.values():
                if part.kind == "toolpath":
                    legend.append({"node": part.node, "kind": "toolpath", "mode": self.view.path_color,
                                   "zones": [{"zone": z, "color": h} for z, h in part.zone_legend()],
                                   "ranges": {"speed": {"lo": part.speed_range[0], "hi": part.speed_range[1], "unit": "mm/s"}},
                                   "arc": {"on": C.rgb_to_hex(C.ARC_ON_RGB), "off": C.rgb_to_hex(C.ARC_OFF_RGB)},
                                   "travel": C.rgb_to_hex(C.TRAVEL_RGB)})
                elif part.kind == "simulation":
                    units = {"deviation": "mm", "speed": "mm/s", "deposit": "mm³/mm"}
                    legend.append({"node": part.node, "kind": "simulation", "mode": self.view.sim_color,
                                   "ranges": {k: {"lo": a, "hi": b, "unit": units[k]} for k, (a, b) in part.ranges.items()},
                                   "programmed": C.rgb_to_hex(C.PROGRAMMED_RGB), "travel": C.rgb_to_hex(C.TRAVEL_RGB),
                                   "robot": part.robot.name if part.robot is not None else None,
                                   "robot_note": part.robot_note})
                    duration = max(duration, part.duration())
            v = self.view
            shown = self.wanted if self.wanted is not None else self.key
            return {
                "key": self.key, "wanted": self.wanted, "published": list(self.scenes),
                "run": self.scene_runs.get(self.key) if self.parts else None,
                # the shown key's latest finished run being rebuilt (after a restart): {key, run, since}
                "loading": dict(self._rebuilding[shown]) if shown in self._rebuilding else None,
                "rebuild_error": dict(self._rebuild_failed[shown]) if shown in self._rebuild_failed else None,
                "nodes": sorted(nodes.values(), key=lambda n: order.get(n["id"], len(order))),
                "layers": {"lo": lo, "hi": hi} if self.parts else None,
                "duration_s": duration,
                "view": {"layer_lo": v.layer_lo, "layer_hi": v.layer_hi, "path_color": v.path_color,
                         "sim_color": v.sim_color, "time_s": v.time_s, "show_robot": v.show_robot,
                         "sim_offset_mm": v.sim_offset_mm, "show_programmed": v.show_programmed,
                         "show_simulated": v.show_simulated, "hidden": sorted(v.hidden)},
                "path_color_modes": list(PATH_COLOR_MODES), "sim_color_modes": list(SIM_COLOR_MODES),
                "colormap": [C.rgb_to_hex(c) for c in C.VIRIDIS_STOPS],
                "legend": legend,
                "bounds": None if self._bounds is None else [[round(float(x), 3) for x in r] for r in self._bounds],
            }

    def select(self, node_id: str | None, layer: int | None) -> None:
        """Follow the GUI: show `node_id`'s output (meshes stay as context; None shows every node)
        and only `layer` (None shows all layers)."""
        with self._lock:
            self.selected = (node_id, layer)
            if node_id is None:
                self.view.hidden.clear()
            else:
                self.view.hidden = {n for (n, _), p in self.parts.items() if n != node_id and p.kind != "mesh"}
            lo, hi = self._layer_extent()
            if layer is None:
                self.view.layer_lo, self.view.layer_hi = lo, hi
            else:
                self.view.layer_lo = self.view.layer_hi = int(np.clip(layer, lo, hi))
            self._sync_gui()
            self._apply()

    # ------------------------------------------------------------------------------------------
    # queries (also used by tests)
    # ------------------------------------------------------------------------------------------
    def scene_names(self, prefix: str = "/graph") -> list[str]:
        """Names of the scene nodes under `prefix`, from viser's server-side scene registry."""
        if self.server is None:
            return []
        names = self.server.scene._handle_from_node_name  # viser's own registry of live nodes
        return sorted(n for n in names if n == prefix or n.startswith(prefix + "/"))

    def bounds(self) -> np.ndarray | None:
        """(2, 3) min/max corner (mm) of everything published, or None."""
        return G.layers_bounds([b for b in (p.bounds() for p in self.parts.values()) if b is not None])

    def part_bounds(self) -> np.ndarray | None:
        """(2, 3) bounds of the part itself (mesh, layers, sections), else of everything: what
        the camera frames, so travel moves to a home position do not shrink the part on screen."""
        own = [b for b in (p.bounds() for p in self.parts.values() if p.kind in ("mesh", "layers", "sections")) if b is not None]
        return G.layers_bounds(own) if own else self.bounds()

    def pick(self, origin, direction) -> dict[str, Any] | None:
        """Readout of the point nearest a view ray (what a click in the browser does): layer,
        section, zone, programmed and actual speed. None if nothing visible is near the ray."""
        with self._lock:
            b = self._bounds if self._bounds is not None else self.bounds()
            if b is None:
                return None
            tol = max(PICK_TOLERANCE * float(np.linalg.norm(b[1] - b[0])), 0.1)
            picks: list[tuple[Part, Pick]] = []
            for (node, _), part in self.parts.items():
                if node in self.view.hidden:
                    continue
                p = part.pick(origin, direction, tol, self.view)
                if p is not None:
                    picks.append((part, p))
            if not picks:
                return None
            # Points (paths, traces, features) win over areas (section fills) they lie on.
            pointlike = [x for x in picks if x[0].kind != "sections"] or picks
            part, best = min(pointlike, key=lambda x: x[1].along)
            info = {"node": part.node, "port": part.port, "point": [round(float(v), 3) for v in best.point]}
            info.update(best.info)
            info.update(self._complement(part, best))
            self.last_pick = info
            return info

    # ------------------------------------------------------------------------------------------
    # internals
    # ------------------------------------------------------------------------------------------
    def _complement(self, part: Part, best: Pick) -> dict[str, Any]:
        """Programmed speed for a picked trace sample, actual speed for a picked path point."""
        out: dict[str, Any] = {}
        layer = best.info.get("layer")
        if part.kind == "toolpath":
            for p in self.parts.values():
                if p.kind == "simulation":
                    s = p.nearest_sample(best.point, layer)
                    if s:
                        out["actual_speed_mm_s"] = s.get("actual_speed_mm_s")
                        out["deviation_mm"] = s.get("deviation_mm")
                    break
        elif part.kind == "simulation":
            for p in self.parts.values():
                if p.kind == "toolpath":
                    q = p.nearest_point(best.point, layer)
                    if q is not None:
                        out["section"] = q.get("section", best.info.get("section"))
                        out["zone"] = q.get("zone")
                        out["programmed_speed_mm_s"] = q.get("programmed_speed_mm_s")
                    break
        return out

    def _layer_extent(self) -> tuple[int, int]:
        idx = [i for p in self.parts.values() for i in p.layer_indices()]
        return (min(idx), max(idx)) if idx else (0, 0)

    def _after_publish(self) -> None:
        # A range showing every layer keeps doing so; a narrowed one is kept, clipped to the part.
        lo, hi = self._layer_extent()
        full = (self.view.layer_lo, self.view.layer_hi) == self._extent
        self._extent = (lo, hi)
        if full:
            self.view.layer_lo, self.view.layer_hi = lo, hi
        else:
            self.view.layer_lo = int(np.clip(self.view.layer_lo, lo, hi))
            self.view.layer_hi = int(np.clip(self.view.layer_hi, self.view.layer_lo, hi))
        self.view.hidden &= {n for n, _ in self.parts}
        b = self.bounds()
        if b is None:
            self._bounds = None
        elif self._bounds is None or not np.allclose(b, self._bounds):
            self._bounds = b
            self._frame_camera(self.part_bounds())
        self._sync_gui()
        self._apply()

    def _apply(self) -> None:
        for node, frame in self._node_frames.items():
            frame.visible = node not in self.view.hidden
        for part in self.parts.values():
            part.apply(self.view)

    def _frame_camera(self, b: np.ndarray) -> None:
        center = (b[0] + b[1]) / 2
        diag = max(float(np.linalg.norm(b[1] - b[0])), 1.0)
        eye = center + diag * np.array([0.42, -0.58, 0.46])   # ~0.85 diagonals away: the part fills the view
        cam = self.server.initial_camera
        cam.near, cam.far = diag * 1e-3, diag * 20
        cam.position, cam.look_at = tuple(eye), tuple(center)
        for client in self.server.get_clients().values():
            client.camera.position, client.camera.look_at = tuple(eye), tuple(center)
        grid_size = float(np.ceil(diag * 1.2 / 10.0) * 10.0)
        self.server.scene.add_grid("/grid", width=grid_size, height=grid_size, cell_size=grid_size / 20,
                                   section_size=grid_size / 4, position=(center[0], center[1], b[0][2]))

    # ---- GUI -----------------------------------------------------------------------------
    def _build_gui(self) -> None:
        gui = self.server.gui
        # A sidebar beside the canvas (not floating over it), no share button: the preview is local.
        gui.configure_theme(show_logo=False, show_share_button=False, brand_color=(248, 150, 30))
        gui.main_panel.dock_right()
        gui.main_panel.set_width(260)
        # Embedded in the GUI the view is small: start with the panel folded to its rail so the
        # scene is visible; one click unfolds it.
        gui.main_panel.minimize()
        g = self._gui
        g["run"] = gui.add_markdown("**No run published yet.**")
        g["layers"] = gui.add_multi_slider("Layers", min=0, max=1, step=1, initial_value=(0, 1))
        g["path_color"] = gui.add_dropdown("Toolpath colour", PATH_COLOR_MODES, initial_value=self.view.path_color)
        g["sim_color"] = gui.add_dropdown("Simulation colour", SIM_COLOR_MODES, initial_value=self.view.sim_color)
        g["offset"] = gui.add_number("Sim. offset z (mm)", initial_value=0.0, min=0.0, max=1000.0, step=0.5,
                                     hint="Draw the simulated path this far above the programmed one")
        g["time"] = gui.add_slider("Time (s)", min=0.0, max=1.0, step=0.01, initial_value=0.0)
        g["play"] = gui.add_button("Play / pause")
        g["robot"] = gui.add_checkbox("Show robot", initial_value=self.view.show_robot)
        g["legend"] = gui.add_html("")
        g["nodes"] = gui.add_folder("Nodes")
        g["pick"] = gui.add_markdown("*Click a path point for its layer, section, zone and speeds.*")

        g["layers"].on_update(lambda _: self._on_layers())
        g["path_color"].on_update(lambda _: self._on_color())
        g["sim_color"].on_update(lambda _: self._on_color())
        g["time"].on_update(lambda _: self._on_time())
        g["play"].on_click(lambda _: self._toggle_play())
        g["robot"].on_update(lambda _: self._on_robot())
        g["offset"].on_update(lambda _: self._on_offset())

    def _sync_gui(self) -> None:
        g = self._gui
        if not g:
            return
        self._syncing = True   # setting a widget calls its handler: they must not write back
        try:
            self._sync_widgets(g)
        finally:
            self._syncing = False

    def _sync_widgets(self, g: dict[str, Any]) -> None:
        v = self.view
        g["path_color"].value = v.path_color
        g["sim_color"].value = v.sim_color
        g["offset"].value = v.sim_offset_mm
        g["robot"].value = v.show_robot
        lo, hi = self._layer_extent()
        g["layers"].min, g["layers"].max = lo, max(hi, lo + 1)
        g["layers"].value = (self.view.layer_lo, self.view.layer_hi)
        names = [n for n in self.node_types if any(k[0] == n for k in self.parts)]
        names += sorted({n for n, _ in self.parts} - set(names))
        for n in [n for n in self._node_boxes if n not in names]:
            self._node_boxes.pop(n).remove()
        with g["nodes"]:
            for n in names:
                if n not in self._node_boxes:
                    box = self.server.gui.add_checkbox(f"{n} ({self.node_types.get(n, '?')})", initial_value=True)
                    box.on_update(lambda ev, node=n: self._on_node_box(node, ev.target.value))
                    self._node_boxes[n] = box
        for n, box in self._node_boxes.items():
            box.value = n not in self.view.hidden
        sims = [p for p in self.parts.values() if p.kind == "simulation"]
        duration = max([p.duration() for p in sims], default=0.0)
        g["time"].max = max(duration, 0.01)
        g["time"].step = max(duration / 1000.0, 0.001)
        g["time"].disabled = not sims
        g["time"].value = min(max(v.time_s, 0.0), g["time"].max)
        run = self.scene_runs.get(self.key or "")
        loading = self._rebuilding.get(self.key or "")
        g["run"].content = (f"**Run:** `{self.key}`{f' ({run})' if run else ''} — {len(self.parts)} outputs" if self.parts else
                            f"**Rebuilding the scene of run `{loading['run']}`…**" if loading else
                            f"**No run of `{self.key}` yet.**" if self.key else "**No run published yet.**")
        g["legend"].content = self._legend()

    def _legend(self) -> str:
        """HTML legend: zone colour swatches, scalar ranges, robot state, feature kinds."""
        from html import escape

        from . import colors as C

        def swatch(hexcol: str, label: str) -> str:
            return (f'<span style="display:inline-block;width:0.8em;height:0.8em;background:{hexcol};'
                    f'margin:0 0.25em 0 0.6em;vertical-align:middle"></span>{escape(label)}')

        rows = []
        for p in self.parts.values():
            head = f"<b>{escape(p.node)}</b> "
            if p.kind == "toolpath":
                lo, hi = p.speed_range
                zones = "".join(swatch(h, z) for z, h in p.zone_legend()) or " not zoned (coloured by section)"
                rows.append(head + f"zones{zones}<br>speed {lo:.3g}–{hi:.3g} mm/s (dark→yellow), travel pale")
            elif p.kind == "simulation":
                ranges = ", ".join(f"{k} {lo:.3g}–{hi:.3g} {u}" for k, u in (("deviation", "mm"), ("speed", "mm/s"))
                                   if k in p.ranges for lo, hi in [p.ranges[k]])
                robot = (f"robot {escape(p.robot.name)} (IK residual ≤ {p.robot.reach_err.max():.2g} mm)"
                         if p.robot is not None else escape(p.robot_note))
                rows.append(head + ranges + (f"<br>{robot}" if robot else ""))
            elif p.kind == "features":
                kinds = sorted(set(p.kinds))
                rows.append(head + "".join(swatch(C.rgb_to_hex(C.FEATURE_RGB.get(k, C.categorical(k))), k) for k in kinds))
        return f'<div style="font-size:0.8em;line-height:1.5">{"<br>".join(rows)}</div>'

    def _on_layers(self) -> None:
        if self._syncing:
            return
        with self._lock:
            lo, hi = (int(v) for v in self._gui["layers"].value)
            self.view.layer_lo, self.view.layer_hi = min(lo, hi), max(lo, hi)
            self._apply()

    def _on_color(self) -> None:
        if self._syncing:
            return
        with self._lock:
            self.view.path_color = self._gui["path_color"].value
            self.view.sim_color = self._gui["sim_color"].value
            with self.server.atomic():
                self._apply()

    def _on_offset(self) -> None:
        if self._syncing:
            return
        with self._lock:
            self.view.sim_offset_mm = float(self._gui["offset"].value)
            self._apply()

    def _on_robot(self) -> None:
        if self._syncing:
            return
        with self._lock:
            self.view.show_robot = bool(self._gui["robot"].value)
            self._apply()

    def _on_node_box(self, node: str, shown: bool) -> None:
        if self._syncing:
            return
        with self._lock:
            (self.view.hidden.discard if shown else self.view.hidden.add)(node)
            self._apply()

    def _on_time(self) -> None:
        if self._syncing:
            return
        with self._lock:
            self.view.time_s = float(self._gui["time"].value)
            for p in self.parts.values():
                if p.kind == "simulation":
                    info = p.set_time(self.view.time_s)
                    if info:
                        self._gui["pick"].content = "**Torch at t**  \n" + _table(info)

    def _toggle_play(self) -> None:
        if self._play_thread is not None and self._play_thread.is_alive():
            self._play_stop.set()
            self._play_thread.join(timeout=2.0)
            self._play_thread = None
            return
        self._play_stop.clear()
        self._play_thread = threading.Thread(target=self._play, name="viewer-playback", daemon=True)
        self._play_thread.start()

    def _play(self) -> None:
        """Advance the time slider in real time (30 frames/s) until the end or pause."""
        frame = 1 / 30
        while not self._play_stop.wait(frame):
            slider = self._gui.get("time")
            if slider is None:
                return
            t = float(slider.value) + frame
            if t >= slider.max:
                slider.value = slider.max
                return
            slider.value = t

    def _on_click(self, event) -> None:
        info = self.pick(np.asarray(event.ray_origin, float), np.asarray(event.ray_direction, float))
        with self._lock:
            if "pick" not in self._gui:
                return
            if info is None:
                self._gui["pick"].content = "*Nothing picked.*"
                return
            self._gui["pick"].content = "**Picked point**  \n" + _table(info)
            self.server.scene.add_icosphere("/pick", radius=max(self._pick_radius(), 0.2), color=(255, 0, 110),
                                            position=tuple(info["point"]), cast_shadow=False)

    def _pick_radius(self) -> float:
        b = self._bounds
        return 0.005 * float(np.linalg.norm(b[1] - b[0])) if b is not None else 0.5


def _table(info: dict[str, Any]) -> str:
    return "  \n".join(f"{k}: `{v}`" for k, v in info.items() if v is not None)

