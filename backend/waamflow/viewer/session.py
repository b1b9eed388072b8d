"""One view of the 3D preview: the scene, GUI panel, camera, view settings and playback of one
browser tab (or of the server-wide scene). `ViewerService` keeps one `ViewSession` per view id.

A session draws on a *target*: a browser client's own scene and GUI (`client.scene`,
`client.gui`, viser's per-client state), the server-wide scene (every client without a view of
its own), or nothing (`NullScene`: no browser attached yet, or it went away). The session's
content — which recipe it shows, its parts, view settings — lives on regardless of the target,
so `state()` answers before the browser connects, and a reconnect (the GUI's 3D tab remounts its
iframe on every visit) gets the same recipe, layer range and colours redrawn.

The session is split by concern: this module holds its content (which parts it draws, view
settings, state, picking, bounds); `target` where it draws (`Target`, `NullScene`, importable
from here too), `camera` how the camera frames it, `panel` its GUI panel and playback
(`SessionPanel`, mixed into `ViewSession`).
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from . import colors as C
from . import geometry as G
from .camera import Camera, framing, set_camera, view_direction
from .panel import SessionPanel
from .scene import (
    PATH_COLOR_MODES,
    SIM_COLOR_MODES,
    FeaturesPart,
    LayersPart,
    MeshPart,
    Part,
    Pick,
    SectionsPart,
    ToolpathPart,
    ViewState,
    kind_of,
    slug,
)
from .simulation import SimulationPart
from .target import NullHandle, NullScene, Target

if TYPE_CHECKING:
    from .service import ViewerService

__all__ = ["NullHandle", "NullScene", "PART_TYPES", "Target", "ViewSession"]

log = logging.getLogger("waamflow.viewer")

PART_TYPES: dict[str, type[Part]] = {
    "mesh": MeshPart,
    "layers": LayersPart,
    "sections": SectionsPart,
    "toolpath": ToolpathPart,
    "simulation": SimulationPart,
    "features": FeaturesPart,
}

PICK_TOLERANCE = 0.01  # picking radius as a fraction of the scene's bounding-box diagonal
VIEW_FIELDS = (
    "layer_lo",
    "layer_hi",
    "path_color",
    "sim_color",
    "time_s",
    "show_robot",
    "sim_offset_mm",
    "show_programmed",
    "show_simulated",
)


class ViewSession(SessionPanel):
    """The scene adapters + GUI panel (layer range, colour-by, per-node visibility, playback,
    picked-point readout) of one view. All methods run under the service's lock."""

    def __init__(self, svc: "ViewerService", view_id: str, target: Target) -> None:
        self.svc = svc
        self.id = view_id
        self.parts: dict[tuple[str, str], Part] = {}
        self.view = ViewState()
        self.key: str | None = None
        self.wanted: str | None = None  # the key the GUI shows (None: whatever was published last)
        self.node_types: dict[str, str] = {}
        self.selected: tuple[str | None, int | None] = (None, None)
        self.last_pick: dict[str, Any] | None = None
        self.last_used = time.monotonic()  # of the last request or connect
        self._gui: dict[str, Any] = {}
        self._syncing = False
        self._node_boxes: dict[str, Any] = {}
        self._node_frames: dict[str, Any] = {}  # /graph/<node>: toggles the node's visibility
        self._play_stop = threading.Event()
        self._play_thread: threading.Thread | None = None
        self._bounds: np.ndarray | None = None
        self._extent: tuple[int, int] = (self.view.layer_lo, self.view.layer_hi)  # layers published
        self.camera: Camera | None = None  # (eye, look_at, near, far)
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
        self._graph_frame = target.scene.add_frame("/graph", show_axes=False)  # moved by a cell's positioner
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
            set_camera(self.target, *self.camera)

    def atomic(self):
        return self.target.atomic()

    # ---- content -----------------------------------------------------------------------------
    def draw(
        self, key: str, recipe: dict | None, outputs: dict[str, dict[str, object]], *, refit: bool = True
    ) -> dict[str, int]:
        stats = {"redrawn": 0, "kept": 0, "removed": 0, "skipped": 0}
        nodes = (recipe or {}).get("nodes", [])
        with self.atomic():
            if key != self.key:
                self.view.time_s = 0.0  # a time in another recipe's program means nothing here
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
                    sim.node_params = dict(
                        next(
                            (
                                nd.get("params") or {}
                                for nd in nodes
                                if isinstance(nd, dict) and str(nd.get("id")) == node
                            ),
                            {},
                        )
                    )
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
        self.view.hidden.clear()  # node ids of another recipe say nothing about this one
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
            e = nodes.setdefault(
                node,
                {
                    "id": node,
                    "type": self.node_types.get(node, ""),
                    "kinds": [],
                    "visible": node not in self.view.hidden,
                },
            )
            e["kinds"].append(part.kind)
        order = {n: i for i, n in enumerate(self.node_types)}
        legend: list[dict[str, Any]] = []
        duration = 0.0
        has_cell = False
        for part in self.parts.values():
            if isinstance(part, ToolpathPart):
                legend.append(
                    {
                        "node": part.node,
                        "kind": "toolpath",
                        "mode": self.view.path_color,
                        "zones": [{"zone": z, "color": h} for z, h in part.zone_legend()],
                        "ranges": {"speed": _range(part.speed_range, "mm/s", getattr(part, "speed_full", None))},
                        "arc": {"on": C.rgb_to_hex(C.ARC_ON_RGB), "off": C.rgb_to_hex(C.ARC_OFF_RGB)},
                        "travel": C.rgb_to_hex(C.TRAVEL_RGB),
                    }
                )
            elif isinstance(part, SimulationPart):
                units = {"deviation": "mm", "speed": "mm/s", "deposit": "mm³/mm"}
                full = getattr(part, "full_ranges", {})
                legend.append(
                    {
                        "node": part.node,
                        "kind": "simulation",
                        "mode": self.view.sim_color,
                        "ranges": {k: _range(r, units[k], full.get(k)) for k, r in part.ranges.items()},
                        "programmed": C.rgb_to_hex(C.PROGRAMMED_RGB),
                        "travel": C.rgb_to_hex(C.TRAVEL_RGB),
                        "robot": part.robot.name if part.robot is not None else None,
                        "robot_note": part.robot_note,
                    }
                )
                duration = max(duration, part.duration())
                has_cell = has_cell or bool(part.cell_handles) or part.robot is not None
        v = self.view
        shown = self.wanted if self.wanted is not None else self.key
        return {
            "view_id": self.id,
            "attached": self.client is not None,
            "key": self.key,
            "wanted": self.wanted,
            "published": list(svc.scenes),
            "run": svc.scene_runs.get(self.key) if self.parts and self.key is not None else None,
            # the shown key's latest finished run being rebuilt (after a restart): {key, run, since}
            "loading": dict(svc._rebuilding[shown]) if shown in svc._rebuilding else None,
            "rebuild_error": dict(svc._rebuild_failed[shown]) if shown in svc._rebuild_failed else None,
            "nodes": sorted(nodes.values(), key=lambda n: order.get(n["id"], len(order))),
            "layers": {"lo": lo, "hi": hi} if self.parts else None,
            "duration_s": duration,
            "view": {
                "layer_lo": v.layer_lo,
                "layer_hi": v.layer_hi,
                "path_color": v.path_color,
                "sim_color": v.sim_color,
                "time_s": v.time_s,
                "show_robot": v.show_robot,
                "sim_offset_mm": v.sim_offset_mm,
                "show_programmed": v.show_programmed,
                "show_simulated": v.show_simulated,
                "hidden": sorted(v.hidden),
            },
            "path_color_modes": list(PATH_COLOR_MODES),
            "sim_color_modes": list(SIM_COLOR_MODES),
            "colormap": [C.rgb_to_hex(c) for c in C.VIRIDIS_STOPS],
            "legend": legend,
            "bounds": None if self._bounds is None else [[round(float(x), 3) for x in r] for r in self._bounds],
            "has_cell": has_cell,
            "camera": None
            if self.camera is None
            else {
                "position": [round(float(x), 3) for x in self.camera[0]],
                "look_at": [round(float(x), 3) for x in self.camera[1]],
            },
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
        own = [
            b
            for b in (p.bounds() for p in self.parts.values() if p.kind in ("mesh", "layers", "sections"))
            if b is not None
        ]
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
        self.camera = framing(center, radius, view_direction(self.parts.values(), self.view.time_s, center))
        set_camera(self.target, *self.camera)
        if what == "cell":
            part_b = self.world_bounds("part")
            assert part_b is not None  # both are None without part bounds, and b is not
            floor = float(part_b[0][2])
        else:
            floor = float(b[0][2])
        grid_size = float(np.ceil(radius * 2.4 / 10.0) * 10.0)
        self.scene.add_grid(
            "/grid",
            width=grid_size,
            height=grid_size,
            cell_size=grid_size / 20,
            section_size=grid_size / 4,
            position=(float(center[0]), float(center[1]), floor),
        )


def _range(r: tuple[float, float], unit: str, full: tuple[float, float] | None) -> dict[str, Any]:
    """A legend range: the colour map's limits and, when they are robust limits that clamp
    outliers, the data's full extent (`min`, `max`) and that values beyond are clamped."""
    out: dict[str, Any] = {"lo": r[0], "hi": r[1], "unit": unit}
    if full is not None:
        out["min"], out["max"] = full
        tol = 0.01 * max(r[1] - r[0], 1e-12)  # beyond the ends by more than 1 % of the span
        out["clamped"] = bool(full[0] < r[0] - tol or full[1] > r[1] + tol)
    return out
