"""One view of the 3D preview: the scene, GUI panel, camera, view settings and playback of one
browser tab (or of the server-wide scene). `ViewerService` keeps one `ViewSession` per view id.

A session draws on a *target*: a browser client's own scene and GUI (`client.scene`,
`client.gui`, viser's per-client state), the server-wide scene (every client without a view of
its own), or nothing (`NullScene`: no browser attached yet, or it went away). The session's
content — which recipe it shows, its parts, view settings — lives on regardless of the target,
so `state()` answers before the browser connects, and a reconnect (the GUI's 3D tab remounts its
iframe on every visit) gets the same recipe, layer range and colours redrawn.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from typing import TYPE_CHECKING, Any, Callable, cast

import numpy as np

from . import colors as C
from . import geometry as G
from .scene import (PATH_COLOR_MODES, SIM_COLOR_MODES, FeaturesPart, LayersPart, MeshPart, Part, Pick,
                    SectionsPart, ToolpathPart, ViewState, kind_of, slug)
from .simulation import SimulationPart

if TYPE_CHECKING:
    from .service import ViewerService

log = logging.getLogger("waamflow.viewer")

PART_TYPES: dict[str, type[Part]] = {
    "mesh": MeshPart, "layers": LayersPart, "sections": SectionsPart, "toolpath": ToolpathPart,
    "simulation": SimulationPart, "features": FeaturesPart,
}

PICK_TOLERANCE = 0.01  # picking radius as a fraction of the scene's bounding-box diagonal
VIEW_FIELDS = ("layer_lo", "layer_hi", "path_color", "sim_color", "time_s", "show_robot",
               "sim_offset_mm", "show_programmed", "show_simulated")
# Camera: looking down at ~35° (elevation), framing the bounding sphere with viser's default 75°
# vertical field of view plus a margin, so the framed box fills ~80 % of the view's height.
CAMERA_ELEVATION_DEG = 35.0
CAMERA_FOV_DEG = 75.0
CAMERA_MARGIN = 1.1


class NullHandle:
    """Stands in for a viser scene/GUI handle when nothing is attached: takes every attribute."""

    def __init__(self, name: str = "", **props: Any) -> None:
        self.__dict__.update(props)
        self.name = name

    def remove(self) -> None:
        self.removed = True

    def on_update(self, cb):
        return cb

    on_click = on_update


class NullScene:
    """A scene that draws nothing (a session without a browser): every `add_*` returns a handle
    that remembers what was set on it."""

    def __init__(self) -> None:
        self._handle_from_node_name: dict[str, NullHandle] = {}

    def __getattr__(self, attr: str):
        if not attr.startswith("add_"):
            raise AttributeError(attr)

        def add(name: str, *args: Any, **props: Any) -> NullHandle:
            h = NullHandle(name, **props)
            self._handle_from_node_name[name] = h
            return h
        return add

    def get_handle_by_name(self, name: str):
        return self._handle_from_node_name.get(name)


class Target:
    """Where a session draws: scene API, GUI API (None: no panel), atomic() and the cameras."""

    def __init__(self, scene, gui=None, atomic: Callable[[], Any] | None = None,
                 cameras: Callable[[], list] = lambda: [], initial_camera=None, client=None) -> None:
        self.scene = scene
        self.gui = gui
        self.atomic = atomic or contextlib.nullcontext
        self.cameras = cameras
        self.initial_camera = initial_camera
        self.client = client


class ViewSession:
    """The scene adapters + GUI panel (layer range, colour-by, per-node visibility, playback,
    picked-point readout) of one view. All methods run under the service's lock."""

    def __init__(self, svc: "ViewerService", view_id: str, target: Target) -> None:
        self.svc = svc
        self.id = view_id
        self.parts: dict[tuple[str, str], Part] = {}
        self.view = ViewState()
        self.key: str | None = None
        self.wanted: str | None = None   # the key the GUI shows (None: whatever was published last)
        self.node_types: dict[str, str] = {}
        self.selected: tuple[str | None, int | None] = (None, None)
        self.last_pick: dict[str, Any] | None = None
        self.last_used = time.monotonic()   # of the last request or connect
        self._gui: dict[str, Any] = {}
        self._syncing = False
        self._node_boxes: dict[str, Any] = {}
        self._node_frames: dict[str, Any] = {}     # /graph/<node>: toggles the node's visibility
        self._play_stop = threading.Event()
        self._play_thread: threading.Thread | None = None
        self._bounds: np.ndarray | None = None
        self._extent: tuple[int, int] = (self.view.layer_lo, self.view.layer_hi)   # layers published
        self.camera: tuple[tuple, tuple, float, float] | None = None   # (eye, look_at, near, far)
        self.target = target
        self._open(target)

    # ---- target ------------------------------------------------------------------------------
    @property
    def scene(self):
        return self.target.scene

    @property
    def client(self):
        return self.target.client

    @property
    def lock(self):
        return self.svc._lock

    def _open(self, target: Target) -> None:
        self.target = target
        self._graph_frame = target.scene.add_frame("/graph", show_axes=False)   # moved by a cell's positioner
        if target.gui is not None:
            self._build_gui()
            with contextlib.suppress(Exception):
                target.scene.on_click()(self._on_click)

    def retarget(self, target: Target, *, drop_old: bool = True) -> None:
        """Draw this session on another target (a new browser client, or none): the old
        target's handles are dropped, the shown run is drawn again on the new one with the same
        view settings; the camera goes back to the last framing."""
        self.stop_playback()
        if drop_old:
            with contextlib.suppress(Exception):
                for part in self.parts.values():
                    part.remove()
                for h in list(self._node_boxes.values()) + list(self._gui.values()):
                    h.remove()
        self.parts.clear()
        self._node_frames.clear()
        self._node_boxes.clear()
        self._gui.clear()
        self._bounds = None
        self._open(target)
        key = self.key
        if key is not None and key in self.svc.scenes:
            recipe, outputs = self.svc.scenes[key]
            self.draw(key, recipe, outputs, refit=self.camera is None)
        else:
            self._after_publish()
        if self.camera is not None:
            self._set_camera(*self.camera)

    def atomic(self):
        return self.target.atomic()

    # ---- content -----------------------------------------------------------------------------
    def draw(self, key: str, recipe: dict | None, outputs: dict[str, dict[str, object]], *,
             refit: bool = True) -> dict[str, int]:
        stats = {"redrawn": 0, "kept": 0, "removed": 0, "skipped": 0}
        nodes = (recipe or {}).get("nodes", [])
        with self.atomic():
            if key != self.key:
                self.view.time_s = 0.0   # a time in another recipe's program means nothing here
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
                        self._node_frames[node] = self.scene.add_frame(f"/graph/{slug(node)}", show_axes=False)
                    part = self.parts[(node, port)] = PART_TYPES[kind](self.scene, node, port, self.svc.max_segments)
                if kind == "simulation":
                    sim = cast(SimulationPart, part)
                    sim.graph_frame = self._graph_frame
                    sim.node_params = dict(next((nd.get("params") or {} for nd in nodes
                                                  if isinstance(nd, dict) and str(nd.get("id")) == node), {}))
                n = part.sync(value, self.view)
                if n:
                    stats["redrawn"] += n
                else:
                    stats["kept"] += 1
            self._after_publish(refit=refit)
        return stats

    def show(self, key: str | None) -> bool:
        """Show the latest published run under `key`; see `ViewerService.show`."""
        self.wanted = key
        if key is None or key == self.key:
            return key is not None
        self.view.hidden.clear()   # node ids of another recipe say nothing about this one
        if key in self.svc.scenes:
            recipe, outputs = self.svc.scenes[key]
            self.draw(key, recipe, outputs)
            return True
        self.clear(key)
        return False

    def clear(self, key: str | None) -> None:
        with self.atomic():
            for k in list(self.parts):
                self.parts.pop(k).remove()
            for node in list(self._node_frames):
                self._node_frames.pop(node).remove()
            self.key, self.node_types = key, {}
            self.view.time_s = 0.0
            self._bounds = None
            self._after_publish()

    def set_view(self, *, hidden: set[str] | None = None, fit: bool | str = False, **fields: Any) -> None:
        unknown = set(fields) - set(VIEW_FIELDS)
        if unknown:
            raise ValueError(f"unknown view setting(s): {', '.join(sorted(unknown))}")
        if fields.get("path_color", PATH_COLOR_MODES[0]) not in PATH_COLOR_MODES:
            raise ValueError(f"path_color must be one of {', '.join(PATH_COLOR_MODES)}")
        if fields.get("sim_color", SIM_COLOR_MODES[0]) not in SIM_COLOR_MODES:
            raise ValueError(f"sim_color must be one of {', '.join(SIM_COLOR_MODES)}")
        if fit not in (False, True, "part", "cell"):
            raise ValueError("fit must be false, true, 'part' or 'cell'")
        for k, v in fields.items():
            if v is not None:
                setattr(self.view, k, type(getattr(self.view, k))(v))
        if hidden is not None:
            self.view.hidden = set(hidden)
        lo, hi = self._layer_extent()
        if "layer_lo" in fields or "layer_hi" in fields:
            self.view.layer_lo = int(np.clip(self.view.layer_lo, lo, hi))
            self.view.layer_hi = int(np.clip(self.view.layer_hi, self.view.layer_lo, hi))
        with self.atomic():
            self._sync_gui()
            self._apply()
            if "time_s" in fields:
                for p in self.parts.values():
                    if isinstance(p, SimulationPart):
                        p.set_time(self.view.time_s)
        if fit:
            self.fit("cell" if fit == "cell" else "part")

    def select(self, node_id: str | None, layer: int | None) -> None:
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

    def state(self) -> dict[str, Any]:
        """See `ViewerService.state`."""
        svc = self.svc
        lo, hi = self._layer_extent()
        nodes: dict[str, dict[str, Any]] = {}
        for (node, port), part in self.parts.items():
            e = nodes.setdefault(node, {"id": node, "type": self.node_types.get(node, ""), "kinds": [],
                                        "visible": node not in self.view.hidden})
            e["kinds"].append(part.kind)
        order = {n: i for i, n in enumerate(self.node_types)}
        legend: list[dict[str, Any]] = []
        duration = 0.0
        has_cell = False
        for part in self.parts.values():
            if isinstance(part, ToolpathPart):
                legend.append({"node": part.node, "kind": "toolpath", "mode": self.view.path_color,
                               "zones": [{"zone": z, "color": h} for z, h in part.zone_legend()],
                               "ranges": {"speed": _range(part.speed_range, "mm/s", getattr(part, "speed_full", None))},
                               "arc": {"on": C.rgb_to_hex(C.ARC_ON_RGB), "off": C.rgb_to_hex(C.ARC_OFF_RGB)},
                               "travel": C.rgb_to_hex(C.TRAVEL_RGB)})
            elif isinstance(part, SimulationPart):
                units = {"deviation": "mm", "speed": "mm/s", "deposit": "mm³/mm"}
                full = getattr(part, "full_ranges", {})
                legend.append({"node": part.node, "kind": "simulation", "mode": self.view.sim_color,
                               "ranges": {k: _range(r, units[k], full.get(k)) for k, r in part.ranges.items()},
                               "programmed": C.rgb_to_hex(C.PROGRAMMED_RGB), "travel": C.rgb_to_hex(C.TRAVEL_RGB),
                               "robot": part.robot.name if part.robot is not None else None,
                               "robot_note": part.robot_note})
                duration = max(duration, part.duration())
                has_cell = has_cell or bool(part.cell_handles) or part.robot is not None
        v = self.view
        shown = self.wanted if self.wanted is not None else self.key
        return {
            "view_id": self.id, "attached": self.client is not None,
            "key": self.key, "wanted": self.wanted, "published": list(svc.scenes),
            "run": svc.scene_runs.get(self.key) if self.parts and self.key is not None else None,
            # the shown key's latest finished run being rebuilt (after a restart): {key, run, since}
            "loading": dict(svc._rebuilding[shown]) if shown in svc._rebuilding else None,
            "rebuild_error": dict(svc._rebuild_failed[shown]) if shown in svc._rebuild_failed else None,
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
            "has_cell": has_cell,
            "camera": None if self.camera is None else {"position": [round(float(x), 3) for x in self.camera[0]],
                                                        "look_at": [round(float(x), 3) for x in self.camera[1]]},
        }

    # ---- queries -----------------------------------------------------------------------------
    def scene_names(self, prefix: str = "/graph") -> list[str]:
        names = self.scene._handle_from_node_name  # viser's own registry of live nodes
        return sorted(n for n in names if n == prefix or n.startswith(prefix + "/"))

    def bounds(self) -> np.ndarray | None:
        """(2, 3) min/max corner (mm, part frame) of everything published, or None."""
        return G.layers_bounds([b for b in (p.bounds() for p in self.parts.values()) if b is not None])

    def part_bounds(self) -> np.ndarray | None:
        """(2, 3) bounds of the part itself (mesh, layers, sections), else of everything: what
        the camera frames, so travel moves to a home position do not shrink the part on screen."""
        own = [b for b in (p.bounds() for p in self.parts.values() if p.kind in ("mesh", "layers", "sections")) if b is not None]
        return G.layers_bounds(own) if own else self.bounds()

    def world_bounds(self, what: str = "part") -> np.ndarray | None:
        """(2, 3) world bounds (mm) at the current playback time: the part as the positioner
        holds it then ("part"), or the part with the arm, torch and positioner ("cell")."""
        b = self.part_bounds()
        if b is None:
            return None
        sims = [p for p in self.parts.values() if isinstance(p, SimulationPart)]
        corners = np.array([[x, y, z] for x in b[:, 0] for y in b[:, 1] for z in b[:, 2]])
        for p in sims:
            pose = p.work_pose(self.view.time_s)
            if pose is not None:
                R, t = pose
                corners = corners @ R.T + t
                break
        pts = [corners]
        if what == "cell":
            for p in sims:
                pts += p.cell_points(self.view.time_s)
        return G.layers_bounds(pts)

    def pick(self, origin, direction) -> dict[str, Any] | None:
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

    # ---- internals ---------------------------------------------------------------------------
    def _complement(self, part: Part, best: Pick) -> dict[str, Any]:
        """Programmed speed for a picked trace sample, actual speed for a picked path point."""
        out: dict[str, Any] = {}
        layer = best.info.get("layer")
        if isinstance(part, ToolpathPart):
            for p in self.parts.values():
                if isinstance(p, SimulationPart):
                    s = p.nearest_sample(best.point, layer)
                    if s:
                        out["actual_speed_mm_s"] = s.get("actual_speed_mm_s")
                        out["deviation_mm"] = s.get("deviation_mm")
                    break
        elif isinstance(part, SimulationPart):
            for p in self.parts.values():
                if isinstance(p, ToolpathPart):
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

    def _after_publish(self, refit: bool = True) -> None:
        # A range showing every layer keeps doing so; a narrowed one is kept, clipped to the part.
        lo, hi = self._layer_extent()
        full = (self.view.layer_lo, self.view.layer_hi) == self._extent
        if self.parts:
            self._extent = (lo, hi)
        if full:
            self.view.layer_lo, self.view.layer_hi = lo, hi
        elif self.parts:
            self.view.layer_lo = int(np.clip(self.view.layer_lo, lo, hi))
            self.view.layer_hi = int(np.clip(self.view.layer_hi, self.view.layer_lo, hi))
        self.view.hidden &= {n for n, _ in self.parts}
        b = self.bounds()
        if b is None:
            self._bounds = None
        elif self._bounds is None or not np.allclose(b, self._bounds):
            self._bounds = b
            if refit:
                self.fit("part")
        self._sync_gui()
        self._apply()

    def _apply(self) -> None:
        for node, frame in self._node_frames.items():
            frame.visible = node not in self.view.hidden
        for part in self.parts.values():
            part.apply(self.view)

    def fit(self, what: str = "part") -> None:
        """Frame the camera on the part ("part") or on part + cell ("cell") as they stand at
        the current playback time, looking from the side away from the robot (so the arm and
        torch stand behind the part, not between it and the camera)."""
        b = self.world_bounds(what)
        if b is None:
            return
        center = (b[0] + b[1]) / 2
        radius = max(float(np.linalg.norm(b[1] - b[0])) / 2, 1.0)
        dist = CAMERA_MARGIN * radius / np.sin(np.radians(CAMERA_FOV_DEG / 2))
        eye = center + dist * self._view_direction(center)
        self.camera = (tuple(float(x) for x in eye), tuple(float(x) for x in center), dist * 1e-3, dist * 20)
        self._set_camera(*self.camera)
        if what == "cell":
            part_b = self.world_bounds("part")
            assert part_b is not None   # both are None without part bounds, and b is not
            floor = float(part_b[0][2])
        else:
            floor = float(b[0][2])
        grid_size = float(np.ceil(radius * 2.4 / 10.0) * 10.0)
        self.scene.add_grid("/grid", width=grid_size, height=grid_size, cell_size=grid_size / 20,
                            section_size=grid_size / 4, position=(float(center[0]), float(center[1]), floor))

    def _view_direction(self, center: np.ndarray) -> np.ndarray:
        """Unit vector from the part to the camera: CAMERA_ELEVATION_DEG above the part's own
        table plane (the positioner may have tilted it: the camera stays on the part's side of
        the table, never looking at the part through it), at `_azimuth` about the world z."""
        az = self._azimuth(center)
        el = np.radians(CAMERA_ELEVATION_DEG)
        up = np.array([0.0, 0.0, 1.0])
        for p in self.parts.values():
            if isinstance(p, SimulationPart):
                pose = p.work_pose(self.view.time_s)
                if pose is not None:
                    up = pose[0][:, 2] / np.linalg.norm(pose[0][:, 2])
                    break
        h = np.array([np.cos(az), np.sin(az), 0.0])
        h = h - (h @ up) * up
        if np.linalg.norm(h) < 1e-6:
            h = np.cross(up, [1.0, 0.0, 0.0])
        h /= np.linalg.norm(h)
        return np.cos(el) * h + np.sin(el) * up

    def _azimuth(self, center: np.ndarray) -> float:
        """Camera azimuth (rad): 40° off the direction robot base → part, so the part is seen
        in front of the arm; without a cell the classic front-left-above view."""
        for p in self.parts.values():
            if isinstance(p, SimulationPart):
                base = p.robot_base()
                if base is not None:
                    d = center[:2] - base[:2]
                    if np.linalg.norm(d) > 1e-6:
                        return float(np.arctan2(d[1], d[0]) + np.radians(40.0))
        return float(np.arctan2(-0.58, 0.42))

    def _set_camera(self, eye, center, near, far) -> None:
        cam = self.target.initial_camera
        if cam is not None:
            cam.near, cam.far = near, far
            cam.position, cam.look_at = tuple(eye), tuple(center)
        for camera in self.target.cameras():
            with contextlib.suppress(Exception):
                camera.near, camera.far = near, far
                camera.position, camera.look_at = tuple(eye), tuple(center)

    # ---- GUI ---------------------------------------------------------------------------------
    def _build_gui(self) -> None:
        gui = self.target.gui
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

        g["layers"].on_update(lambda _: self._guarded(self._on_layers))
        g["path_color"].on_update(lambda _: self._guarded(self._on_color))
        g["sim_color"].on_update(lambda _: self._guarded(self._on_color))
        g["time"].on_update(lambda _: self._guarded(self._on_time))
        g["play"].on_click(lambda _: self._toggle_play())
        g["robot"].on_update(lambda _: self._guarded(self._on_robot))
        g["offset"].on_update(lambda _: self._guarded(self._on_offset))

    def _guarded(self, handler: Callable[[], None]) -> None:
        if self._syncing:   # setting a widget calls its handler: it must not write back
            return
        with self.lock:
            if self._gui:
                handler()

    def _sync_gui(self) -> None:
        g = self._gui
        if not g:
            return
        self._syncing = True
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
                    box = self.target.gui.add_checkbox(f"{n} ({self.node_types.get(n, '?')})", initial_value=True)
                    box.on_update(lambda ev, node=n: self._guarded(lambda: self._on_node_box(node, ev.target.value)))
                    self._node_boxes[n] = box
        for n, box in self._node_boxes.items():
            box.value = n not in self.view.hidden
        sims = [p for p in self.parts.values() if isinstance(p, SimulationPart)]
        duration = max([p.duration() for p in sims], default=0.0)
        g["time"].max = max(duration, 0.01)
        g["time"].step = max(duration / 1000.0, 0.001)
        g["time"].disabled = not sims
        g["time"].value = min(max(v.time_s, 0.0), g["time"].max)
        run = self.svc.scene_runs.get(self.key or "")
        loading = self.svc._rebuilding.get(self.key or "")
        g["run"].content = (f"**Run:** `{self.key}`{f' ({run})' if run else ''} — {len(self.parts)} outputs" if self.parts else
                            f"**Rebuilding the scene of run `{loading['run']}`…**" if loading else
                            f"**No run of `{self.key}` yet.**" if self.key else "**No run published yet.**")
        g["legend"].content = self._legend()

    def _legend(self) -> str:
        """HTML legend: zone colour swatches, scalar ranges, robot state, feature kinds."""
        from html import escape

        def swatch(hexcol: str, label: str) -> str:
            return (f'<span style="display:inline-block;width:0.8em;height:0.8em;background:{hexcol};'
                    f'margin:0 0.25em 0 0.6em;vertical-align:middle"></span>{escape(label)}')

        rows = []
        for p in self.parts.values():
            head = f"<b>{escape(p.node)}</b> "
            if isinstance(p, ToolpathPart):
                lo, hi = p.speed_range
                zones = "".join(swatch(h, z) for z, h in p.zone_legend()) or " not zoned (coloured by section)"
                rows.append(head + f"zones{zones}<br>speed {lo:.3g}–{hi:.3g} mm/s (dark→yellow), travel pale")
            elif isinstance(p, SimulationPart):
                ranges = ", ".join(f"{k} {lo:.3g}–{hi:.3g} {u}" for k, u in (("deviation", "mm"), ("speed", "mm/s"))
                                   if k in p.ranges for lo, hi in [p.ranges[k]])
                robot = (f"robot {escape(p.robot.name)} (IK residual ≤ {p.robot.reach_err.max():.2g} mm)"
                         if p.robot is not None else escape(p.robot_note))
                rows.append(head + ranges + (f"<br>{robot}" if robot else ""))
            elif isinstance(p, FeaturesPart):
                kinds = sorted(set(p.kinds))
                rows.append(head + "".join(swatch(C.rgb_to_hex(C.FEATURE_RGB.get(k, C.categorical(k))), k) for k in kinds))
        return f'<div style="font-size:0.8em;line-height:1.5">{"<br>".join(rows)}</div>'

    def _on_layers(self) -> None:
        lo, hi = (int(v) for v in self._gui["layers"].value)
        self.view.layer_lo, self.view.layer_hi = min(lo, hi), max(lo, hi)
        self._apply()

    def _on_color(self) -> None:
        self.view.path_color = self._gui["path_color"].value
        self.view.sim_color = self._gui["sim_color"].value
        with self.atomic():
            self._apply()

    def _on_offset(self) -> None:
        self.view.sim_offset_mm = float(self._gui["offset"].value)
        self._apply()

    def _on_robot(self) -> None:
        self.view.show_robot = bool(self._gui["robot"].value)
        self._apply()

    def _on_node_box(self, node: str, shown: bool) -> None:
        (self.view.hidden.discard if shown else self.view.hidden.add)(node)
        self._apply()

    def _on_time(self) -> None:
        self.view.time_s = float(self._gui["time"].value)
        for p in self.parts.values():
            if isinstance(p, SimulationPart):
                info = p.set_time(self.view.time_s)
                if info:
                    self._gui["pick"].content = "**Torch at t**  \n" + _table(info)

    def _toggle_play(self) -> None:
        if self._play_thread is not None and self._play_thread.is_alive():
            self.stop_playback()
            return
        self._play_stop.clear()
        self._play_thread = threading.Thread(target=self._play, name=f"viewer-playback-{self.id}", daemon=True)
        self._play_thread.start()

    def stop_playback(self) -> None:
        self._play_stop.set()
        t = self._play_thread
        if t is not None and t is not threading.current_thread():
            t.join(timeout=2.0)
        self._play_thread = None

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
        with self.lock:
            info = self.pick(np.asarray(event.ray_origin, float), np.asarray(event.ray_direction, float))
            if "pick" not in self._gui:
                return
            if info is None:
                self._gui["pick"].content = "*Nothing picked.*"
                return
            self._gui["pick"].content = "**Picked point**  \n" + _table(info)
            self.scene.add_icosphere("/pick", radius=max(self._pick_radius(), 0.2), color=(255, 0, 110),
                                     position=tuple(info["point"]), cast_shadow=False)

    def _pick_radius(self) -> float:
        b = self._bounds
        return 0.005 * float(np.linalg.norm(b[1] - b[0])) if b is not None else 0.5


def _range(r: tuple[float, float], unit: str, full: tuple[float, float] | None) -> dict[str, Any]:
    """A legend range: the colour map's limits and, when they are robust limits that clamp
    outliers, the data's full extent (`min`, `max`) and that values beyond are clamped."""
    out: dict[str, Any] = {"lo": r[0], "hi": r[1], "unit": unit}
    if full is not None:
        out["min"], out["max"] = full
        tol = 0.01 * max(r[1] - r[0], 1e-12)   # beyond the ends by more than 1 % of the span
        out["clamped"] = bool(full[0] < r[0] - tol or full[1] > r[1] + tol)
    return out


def _table(info: dict[str, Any]) -> str:
    return "  \n".join(f"{k}: `{v}`" for k, v in info.items() if v is not None)
