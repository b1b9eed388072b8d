"""The GUI panel of a view of the 3D preview: layer range, colour-by, simulation offset, robot,
per-node visibility, playback of the simulated time, the legend and the picked-point readout,
in the sidebar of a browser client's own view (`Target.gui`). `SessionPanel` is mixed into
`ViewSession`: the widgets follow the session's view settings (`_sync_gui`), a widget the user
moves writes them back (`_on_*`, under the service's lock, never while the panel is syncing)."""

from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from . import colors as C
from .scene import PATH_COLOR_MODES, SIM_COLOR_MODES, FeaturesPart, Part, ToolpathPart, ViewState
from .simulation import SimulationPart
from .target import Target

if TYPE_CHECKING:
    from .service import ViewerService


class SessionPanel(ABC):
    """The panel's part of a `ViewSession` (see module doc)."""

    # what the panel reads and writes of its session (ViewSession sets them in __init__)
    id: str
    svc: ViewerService
    view: ViewState
    parts: dict[tuple[str, str], Part]
    node_types: dict[str, str]
    key: str | None
    target: Target
    _gui: dict[str, Any]  # widget name → viser GUI handle ({} without a panel)
    _syncing: bool  # the panel is being set from the view: handlers must not write back
    _node_boxes: dict[str, Any]  # node id → its visibility checkbox
    _play_stop: threading.Event
    _play_thread: threading.Thread | None
    _bounds: np.ndarray | None

    # ... and what it calls
    @property
    @abstractmethod
    def lock(self) -> Any: ...

    @property
    @abstractmethod
    def scene(self) -> Any: ...

    @abstractmethod
    def atomic(self) -> Any: ...

    @abstractmethod
    def _apply(self) -> None: ...

    @abstractmethod
    def _layer_extent(self) -> tuple[int, int]: ...

    @abstractmethod
    def pick(self, origin: np.ndarray, direction: np.ndarray) -> dict[str, Any] | None: ...

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
        g["offset"] = gui.add_number(
            "Sim. offset z (mm)",
            initial_value=0.0,
            min=0.0,
            max=1000.0,
            step=0.5,
            hint="Draw the simulated path this far above the programmed one",
        )
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
        if self._syncing:  # setting a widget calls its handler: it must not write back
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
        g["run"].content = (
            f"**Run:** `{self.key}`{f' ({run})' if run else ''} — {len(self.parts)} outputs"
            if self.parts
            else f"**Rebuilding the scene of run `{loading['run']}`…**"
            if loading
            else f"**No run of `{self.key}` yet.**"
            if self.key
            else "**No run published yet.**"
        )
        g["legend"].content = self._legend()

    def _legend(self) -> str:
        """HTML legend: zone colour swatches, scalar ranges, robot state, feature kinds."""
        from html import escape

        def swatch(hexcol: str, label: str) -> str:
            return (
                f'<span style="display:inline-block;width:0.8em;height:0.8em;background:{hexcol};'
                f'margin:0 0.25em 0 0.6em;vertical-align:middle"></span>{escape(label)}'
            )

        rows = []
        for p in self.parts.values():
            head = f"<b>{escape(p.node)}</b> "
            if isinstance(p, ToolpathPart):
                lo, hi = p.speed_range
                zones = "".join(swatch(h, z) for z, h in p.zone_legend()) or " not zoned (coloured by section)"
                rows.append(head + f"zones{zones}<br>speed {lo:.3g}–{hi:.3g} mm/s (dark→yellow), travel pale")
            elif isinstance(p, SimulationPart):
                ranges = ", ".join(
                    f"{k} {lo:.3g}–{hi:.3g} {u}"
                    for k, u in (("deviation", "mm"), ("speed", "mm/s"))
                    if k in p.ranges
                    for lo, hi in [p.ranges[k]]
                )
                robot = (
                    f"robot {escape(p.robot.name)} (IK residual ≤ {p.robot.reach_err.max():.2g} mm)"
                    if p.robot is not None
                    else escape(p.robot_note)
                )
                rows.append(head + ranges + (f"<br>{robot}" if robot else ""))
            elif isinstance(p, FeaturesPart):
                kinds = sorted(set(p.kinds))
                rows.append(
                    head + "".join(swatch(C.rgb_to_hex(C.FEATURE_RGB.get(k, C.categorical(k))), k) for k in kinds)
                )
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
            self.scene.add_icosphere(
                "/pick",
                radius=max(self._pick_radius(), 0.2),
                color=(255, 0, 110),
                position=tuple(info["point"]),
                cast_shadow=False,
            )

    def _pick_radius(self) -> float:
        b = self._bounds
        return 0.005 * float(np.linalg.norm(b[1] - b[0])) if b is not None else 0.5


def _table(info: dict[str, Any]) -> str:
    return "  \n".join(f"{k}: `{v}`" for k, v in info.items() if v is not None)
