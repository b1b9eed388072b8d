"""The 3D preview service: a viser server the API starts in its lifespan and feeds after each run.

    viewer = ViewerService(host="127.0.0.1", port=8080)
    viewer.start()                       # non-blocking: viser serves from its own thread
    viewer.publish("mpp-cross", recipe, outputs)   # outputs: node id → port → value
    viewer.show("mpp-cross", view="tab-1")         # that browser view's open recipe
    viewer.set_view(view="tab-1", hidden={"slice"}, layer_lo=2, layer_hi=5, sim_color="deposit", time_s=3.0)
    viewer.state(view="tab-1")           # nodes, layer extent, view and legend data for the GUI
    viewer.select("toolpath", 3)         # the default view follows the selected node / layer
    viewer.loader = source               # optional: key → (run id, rebuild) for runs not in memory
    viewer.url                           # → /api/health `viewer_url`
    viewer.stop()

**One scene per view.** Each browser tab's 3D view has a view id (the GUI makes one per page
load and opens viser's page as `/?embedded&view=<id>`); the viser client connecting with it gets
its own scene, GUI panel, camera, layer range, colours and playback (`ViewSession`, drawn with
viser's per-client `client.scene` / `client.gui`). The REST calls of that tab name the same id,
so two tabs — or two users — on one server each see their own recipe, and a run of another
recipe never replaces what a user looks at. A view exists before its browser connects (headless,
so its state is known at once) and outlives a reconnect (the GUI's 3D tab remounts its iframe);
views idle for `VIEW_TTL_S` are dropped, at most `MAX_VIEWS` are kept. A client without a view id
gets a view of its own that follows every published run, dropped when it disconnects.

The default view (`view=None`): headless by default — scripts read its state through
/api/viewer without a view id; with `shared=True` (one-off previews, tests) it draws on the
server-wide scene and GUI that every client without a view id sees.

Scenes are keyed (graph name, or run id for an unsaved recipe): the last few published runs are
kept, and `show(key)` switches a view to one of them. Scenes live in memory: when `show(key)`
finds none (the server restarted, or the scene was evicted) and a `loader` is set, the latest
finished run of `key` is rebuilt beside the server (`state()["loading"]` says which run
meanwhile) and shown when ready. Re-publishing redraws only outputs (and, for per-layer outputs,
only layers) whose content signature changed. Large parts are decimated for display
(`max_segments` line segments per output in total); the data is never modified.
"""

from __future__ import annotations

import hmac
import logging
import threading
import time
from collections import OrderedDict
from typing import TYPE_CHECKING, Any, Callable
from urllib.parse import parse_qs, urlsplit

import numpy as np

from .session import ViewSession
from .target import NullScene, Target

if TYPE_CHECKING:  # viser is imported when the service starts
    from viser import ViserServer

log = logging.getLogger("waamflow.viewer")

MAX_SCENES = 4  # published runs kept for `show(key)` (outputs are held by reference)
MAX_VIEWS = 32  # browser views kept (the least recently used detached one goes first)
VIEW_TTL_S = 1800.0  # a view without a browser and without requests for this long is dropped
PROXY_HEADER = "X-Waamflow-Viewer-Proxy"  # carries `proxy_secret` from the API's /viewer proxy to viser
VIEW_ID_CHARS = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_.")


def valid_view_id(view: str) -> bool:
    return 0 < len(view) <= 64 and set(view) <= VIEW_ID_CHARS


class ViewerService:
    """viser server + one `ViewSession` per browser view. Thread-safe: publish/show/set_view
    may come from any thread (one lock for all views)."""

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 8080,
        *,
        max_segments: int = 300_000,
        label: str = "waamflow",
        shared: bool = False,
        proxy_secret: str | None = None,
    ) -> None:
        self.host = host
        # set by the API server: viser has no authentication of its own, so a websocket that does not
        # carry this secret (sent only by the API's authenticated /viewer proxy, `PROXY_HEADER`) is
        # closed before it is given a view — another local user cannot watch or steer the 3D preview
        self.proxy_secret = proxy_secret
        self.port = port
        self.max_segments = int(max_segments)
        self.label = label
        self.shared = shared
        self.server: ViserServer | None = None  # None until started
        self._lock = threading.RLock()
        self.sessions: OrderedDict[str, ViewSession] = OrderedDict()  # "" = the default view
        self.scenes: OrderedDict[str, tuple[dict | None, dict]] = OrderedDict()  # key → (recipe, outputs)
        self.scene_runs: dict[str, str] = {}  # key → id of the run its scene shows (when known)
        # key → (run id, rebuild(cancel) → (recipe, outputs)) | None: finds a finished run that is
        # not in memory (after a restart); set by the API to read its store
        self.loader: (
            Callable[[str], tuple[str, Callable[[threading.Event], tuple[dict | None, dict]]] | None] | None
        ) = None
        self._rebuilding: dict[str, dict[str, Any]] = {}  # key → {"run", "since"} while rebuilt
        self._rebuild_failed: dict[str, dict[str, Any]] = {}  # key → {"run", "message"}
        self._rebuild_stop = threading.Event()
        self.asbuilt: dict[str, Any] = {}  # view → the as-built overlay of the build it shows (viewer.asbuilt)

    # ------------------------------------------------------------------------------------------
    # lifecycle
    # ------------------------------------------------------------------------------------------
    def start(self) -> "ViewerService":
        """Start the viser server (returns at once; viser runs its own thread). Idempotent."""
        import viser

        with self._lock:
            if self.server is not None:
                return self
            self._rebuild_stop.clear()  # stop() cancelled the rebuilds of the previous start
            from .embed import embedded_client

            with embedded_client():
                server = self.server = viser.ViserServer(
                    host=self.host, port=self.port, label=self.label, verbose=False
                )
            if self.proxy_secret is not None:
                self._admit_only_the_proxy(server)
            server.scene.set_up_direction("+z")
            self.sessions[""] = ViewSession(self, "", self._default_target())
            server.on_client_connect(self._on_connect)
            server.on_client_disconnect(self._on_disconnect)
        return self

    def stop(self) -> None:
        """Stop playback and the server; the service can be started again afterwards."""
        self._rebuild_stop.set()
        with self._lock:
            sessions = list(self.sessions.values())
        for s in sessions:
            s.stop_playback()
        with self._lock:
            if self.server is not None:
                self.server.stop()
            self.server = None
            self.sessions.clear()
            self.scenes.clear()

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
    # views
    # ------------------------------------------------------------------------------------------
    def _default_target(self) -> Target:
        if not self.shared:
            return Target(NullScene())
        srv = self.server
        if srv is None:
            raise RuntimeError("the 3D preview is not running")

        def viewless() -> list:
            return [
                c.camera
                for cid, c in srv.get_clients().items()
                if not any(s.client is c for s in self.sessions.values())
            ]

        return Target(srv.scene, srv.gui, srv.atomic, viewless, srv.initial_camera)

    @staticmethod
    def _client_target(client) -> Target:
        return Target(client.scene, client.gui, client.atomic, lambda: [client.camera], client=client)

    def session(self, view: str | None = None, *, create: bool = True) -> ViewSession:
        """The view `view` (None or "": the default view), made headless when new."""
        if self.server is None:
            raise RuntimeError("the 3D preview is not running")
        key = view or ""
        if key and not valid_view_id(key):
            raise ValueError("view must be 1–64 letters, digits, '-', '_' or '.'")
        with self._lock:
            s = self.sessions.get(key)
            if s is None:
                if not create:
                    raise KeyError(view)
                s = self.sessions[key] = ViewSession(self, key, Target(NullScene()))
                self._evict()
            self.sessions.move_to_end(key)
            s.last_used = time.monotonic()
            return s

    def _evict(self) -> None:
        now = time.monotonic()
        for k in [k for k, s in self.sessions.items() if k and s.client is None and now - s.last_used > VIEW_TTL_S]:
            self.sessions.pop(k).stop_playback()
        while len(self.sessions) - ("" in self.sessions) > MAX_VIEWS:
            idle = [k for k, s in self.sessions.items() if k and s.client is None]
            victim = idle[0] if idle else next(k for k in self.sessions if k)
            self.sessions.pop(victim).stop_playback()

    def _view_of_client(self, client) -> str | None:
        """The `view` query parameter of the client's websocket request (viser's page passes it
        on, see `embed`), or None."""
        if self.server is None:
            return None
        try:
            conn = self.server._websock_server._live_connections.get(client.client_id)
            query = urlsplit(conn.request.path).query if conn is not None and conn.request is not None else ""
        except AttributeError:
            return None
        views = parse_qs(query).get("view")
        view = views[0] if views else None
        return view if view and valid_view_id(view) else None

    def _admit_only_the_proxy(self, server: ViserServer) -> None:
        """Close, right after its handshake and before viser sends it anything, every websocket that
        does not carry `proxy_secret` (viser's connection hook, awaited before its message loops)."""
        infra = server._websock_server
        secret = str(self.proxy_secret).encode()

        async def admit(conn) -> None:
            ws = infra._live_connections.get(conn.client_id)
            request = getattr(ws, "request", None)
            given = request.headers.get(PROXY_HEADER, "") if request is not None else ""
            if ws is not None and not hmac.compare_digest(given.encode(), secret):
                log.warning("3D preview: a websocket not from the server's /viewer proxy was closed")
                await ws.close(1008, "use the waamflow server's /viewer/")

        infra.on_client_connect(admit)

    def _on_connect(self, client) -> None:
        view = self._view_of_client(client)
        if view is None and self.shared:
            return  # sees the server-wide scene
        with self._lock:
            if self.server is None:
                return
            s = self.session(view or f"client-{client.client_id}")
            old = s.client
            s.retarget(
                self._client_target(client), drop_old=old is not None and old.client_id in self.server.get_clients()
            )
            if s.id in self.asbuilt:  # a build's as-built surface follows its view to the browser
                self.asbuilt[s.id].draw(s.scene)
            if view is None and s.wanted is None and s.key is None and self.scenes:
                key = next(reversed(self.scenes))
                s.draw(key, *self.scenes[key])

    def _on_disconnect(self, client) -> None:
        with self._lock:
            for k, s in list(self.sessions.items()):
                if s.client is client:
                    if k.startswith("client-"):
                        self.sessions.pop(k).stop_playback()
                    else:
                        s.retarget(Target(NullScene()), drop_old=False)
                        s.last_used = time.monotonic()

    # ------------------------------------------------------------------------------------------
    # publishing
    # ------------------------------------------------------------------------------------------
    def publish(
        self, key: str, recipe: dict | None, outputs: dict[str, dict[str, object]], *, run: str | None = None
    ) -> dict[str, int]:
        """Keep a run's outputs under `key` (`run`: its id, reported by `state()`) and draw them in
        every view that shows `key` (or follows every run). Only outputs whose content changed
        are redrawn; outputs of nodes that are gone are removed. Returns counts of the default
        view's redraw (else of the first view that drew): {"redrawn", "kept", "removed",
        "skipped"} (redrawn = scene nodes added or replaced; skipped = outputs with nothing to
        draw), "sessions": how many browser views drew it (when any did), "deferred": 1 when
        no view did."""
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
            drawn: list[tuple[str, dict[str, int]]] = []
            for vid, s in list(self.sessions.items()):
                if s.wanted == key or (s.wanted is None and self._follows(s)):
                    drawn.append((vid, s.draw(key, recipe, outputs)))
            if not drawn:
                # another recipe's run: kept for when a view asks for it, the shown scenes stay
                return {"redrawn": 0, "kept": 0, "removed": 0, "skipped": 0, "deferred": 1}
            stats = dict(next((st for vid, st in drawn if vid == ""), drawn[0][1]))
            if any(vid for vid, _ in drawn):
                stats["sessions"] = len([vid for vid, _ in drawn if vid])
            return stats

    def _follows(self, s: ViewSession) -> bool:
        """A view without a chosen recipe follows every run — unless it is the headless default
        (nobody sees it: it catches up when asked for its state)."""
        return not (s.id == "" and not self.shared)

    def show(self, key: str | None, *, view: str | None = None) -> bool:
        """Show the latest published run under `key` (the open recipe) in `view`; an unknown key
        empties that view's scene until a run of it is published, or until the `loader` has
        rebuilt the latest finished run of it. None: follow every publish again.
        Returns whether a run of `key` is shown."""
        if self.server is None:
            return False
        with self._lock:
            s = self.session(view)
            shown = s.show(key)
            if key is not None and not shown and key not in self.scenes:
                self._start_rebuild(key)
            return shown

    def _start_rebuild(self, key: str) -> None:
        """Rebuild the latest finished run of `key` in a thread (no-op without a loader, when one
        is under way, or when `key` has no finished run)."""
        if self.loader is None or key in self._rebuilding:
            return
        try:
            found = self.loader(key)
        except Exception as e:  # a broken store must not break the select request
            log.exception("looking up a run of %s to rebuild failed", key)
            self._rebuild_failed[key] = {"run": None, "message": str(e)}
            return
        if found is None:
            return
        run_id, rebuild = found
        self._rebuild_failed.pop(key, None)
        self._rebuilding[key] = {"key": key, "run": run_id, "since": time.time()}
        threading.Thread(
            target=self._rebuild, args=(key, run_id, rebuild), name=f"viewer-rebuild-{run_id}", daemon=True
        ).start()

    def _rebuild(self, key: str, run_id: str, rebuild: Callable) -> None:
        try:
            recipe, outputs = rebuild(self._rebuild_stop)
            with self._lock:  # state() sees the scene and the end of loading together
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
                for s in self.sessions.values():
                    if s.key == key:
                        s._sync_gui()

    def show_asbuilt(
        self, build: str | None, layers: list[dict] | None = None, *, view: str | None = None
    ) -> dict[str, Any] | None:
        """Draw a build's scanned as-built tops in `view` beside the plan (`viewer.asbuilt`:
        `layers` = `BuildSession.surface()`), replacing the build shown there before; `build`
        None removes it. Returns the overlay's legend (deviation range, stops, counts)."""
        from .asbuilt import AsBuiltOverlay

        with self._lock:
            s = self.session(view)
            old = self.asbuilt.pop(s.id, None)
            if old is not None:
                old.remove()
            if build is None:
                return None
            overlay = self.asbuilt[s.id] = AsBuiltOverlay(build, layers or [])
            with s.atomic():
                overlay.draw(s.scene)
            return overlay.legend

    def set_view(
        self, *, view: str | None = None, hidden: set[str] | None = None, fit: bool | str = False, **fields: Any
    ) -> None:
        """Apply a view's settings (any subset of VIEW_FIELDS, plus hidden node ids); `fit`
        frames its camera: True or "part" on the part, "cell" on part + cell, as they stand at
        the playback time."""
        if self.server is None:
            raise RuntimeError("the 3D preview is not running")
        with self._lock:
            self.session(view).set_view(hidden=hidden, fit=fit, **fields)

    def state(self, *, view: str | None = None) -> dict[str, Any]:
        """What the GUI's 3D tab shows beside the scene of `view`: the shown run, its nodes (with
        what each draws and whether it is visible), layer extent, playback duration, view
        settings and the legend data (zone colours, scalar ranges with units, the colour map's
        stops)."""
        with self._lock:
            s = self.session(view)
            if s.wanted is None and not self._follows(s) and self.scenes:
                latest = next(reversed(self.scenes))
                if s.key != latest:
                    s.draw(latest, *self.scenes[latest])
            st = s.state()
            if s.id in self.asbuilt:  # the build's as-built surface: its deviation range and colours
                st["asbuilt"] = self.asbuilt[s.id].legend
            return st

    def select(self, node_id: str | None, layer: int | None, *, view: str | None = None) -> None:
        """Follow the GUI: show `node_id`'s output (meshes stay as context; None shows every node)
        and only `layer` (None shows all layers)."""
        with self._lock:
            self.session(view).select(node_id, layer)

    # ------------------------------------------------------------------------------------------
    # queries of the default view (also used by tests)
    # ------------------------------------------------------------------------------------------
    @property
    def default(self) -> ViewSession:
        return self.sessions[""]

    @property
    def parts(self):
        return self.default.parts

    @property
    def view(self):
        return self.default.view

    @property
    def key(self) -> str | None:
        return self.default.key

    @property
    def wanted(self) -> str | None:
        return self.default.wanted

    @property
    def _gui(self) -> dict[str, Any]:
        return self.default._gui

    @property
    def _node_boxes(self) -> dict[str, Any]:
        return self.default._node_boxes

    @property
    def _graph_frame(self):
        return self.default._graph_frame

    def scene_names(self, prefix: str = "/graph", *, view: str | None = None) -> list[str]:
        """Names of the scene nodes under `prefix`, from viser's scene registry of that view."""
        if self.server is None:
            return []
        with self._lock:
            return self.session(view).scene_names(prefix)

    def bounds(self) -> np.ndarray | None:
        return self.default.bounds()

    def part_bounds(self) -> np.ndarray | None:
        return self.default.part_bounds()

    def pick(self, origin, direction, *, view: str | None = None) -> dict[str, Any] | None:
        """Readout of the point nearest a view ray (what a click in the browser does): layer,
        section, zone, programmed and actual speed. None if nothing visible is near the ray."""
        with self._lock:
            return self.session(view).pick(origin, direction)
