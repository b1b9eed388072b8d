"""Where a view of the 3D preview draws (`Target`): a browser client's own scene and GUI, the
server-wide scene, or nothing — `NullScene`, whose handles remember what was set on them, for a
session without a browser (see `session`)."""

from __future__ import annotations

import contextlib
from typing import Any, Callable


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

    def __init__(
        self,
        scene,
        gui=None,
        atomic: Callable[[], Any] | None = None,
        cameras: Callable[[], list] = lambda: [],
        initial_camera=None,
        client=None,
    ) -> None:
        self.scene = scene
        self.gui = gui
        self.atomic = atomic or contextlib.nullcontext
        self.cameras = cameras
        self.initial_camera = initial_camera
        self.client = client
