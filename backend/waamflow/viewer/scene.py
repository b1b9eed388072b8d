"""Scene adapters: one `Part` per published (node, port) output, drawn under `/graph/<node>/<port>`.

Each part owns its viser handles and redraws only what changed: per-layer parts keep one
signature per layer and replace just the layers whose signature changed; colour and visibility
changes mutate existing handles instead of re-adding them. Geometry comes from the pure
functions in `geometry`; this module only talks to viser.

Scene tree (names are stable, so a redraw replaces a node instead of adding a second one):

    /graph/<node>/mesh/mesh                      translucent part (MeshData / Midsurface)
    /graph/<node>/layers/L0007                   outlines of layer 7 (one line-segment batch)
    /graph/<node>/sections/L0007/<section>       filled section region, one mesh per section
    /graph/<node>/sections/L0007/guides          the layer's guides (one batch)
    /graph/<node>/toolpath/L0007                 layer 7's moves: ONE line-segment batch
    /graph/<node>/simulation/...                 see `simulation`
    /graph/<node>/features/points                recognised feature points (by kind)
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.model import Layer, LayerPaths, LayerSections, Layered, MeshData, Midsurface
from . import colors as C
from . import geometry as G
from .signature import digest, layer_signatures

LINE_PX = 2.0  # outline / guide thickness in screen pixels (independent of part size)
PATH_PX = 3.0  # programmed toolpath: the widest line, its zone/speed colours read at a glance
SIM_PX = 1.5  # simulated path: half the toolpath's width, drawn inside it (zone colours show beside it)
PROGRAMMED_PX = 1.0  # the simulation's programmed reference: a thin dark core line
FILL_OPACITY = 0.55
MESH_OPACITY = 0.25

PATH_COLOR_MODES = ("zone", "speed", "arc", "section")
SIM_COLOR_MODES = ("deviation", "speed", "deposit")


def slug(name: str) -> str:
    """A scene-tree-safe name: section keys like 'bs1/A' must not open a sub-tree ('bs1-A')."""
    return re.sub(r"[^A-Za-z0-9_.:-]", "-", str(name)) or "-"


def layer_name(index: int) -> str:
    return f"L{int(index):04d}"


@dataclass
class ViewState:
    """What the GUI asks to see. layer_lo/hi: inclusive layer index range; hidden: node ids;
    time_s: playback time; sim_offset_mm: simulated path drawn this far above (+z) the programmed
    one, to compare them side by side instead of on top of each other."""

    layer_lo: int = 0
    layer_hi: int = 1 << 30
    path_color: str = "zone"
    sim_color: str = "deviation"
    hidden: set[str] = field(default_factory=set)
    time_s: float = 0.0
    show_robot: bool = True
    sim_offset_mm: float = 0.0  # lift of the simulated path above the programmed one (+z), mm
    show_programmed: bool = True
    show_simulated: bool = True

    def shows_layer(self, index: int) -> bool:
        return self.layer_lo <= index <= self.layer_hi


@dataclass
class Pick:
    """A picked point: distance along the ray (mm), its world position and readout fields."""

    along: float
    point: np.ndarray
    info: dict[str, Any]


def kind_of(value: Any) -> str | None:
    """The scene kind of an output value, by type or (for other engineers' types) duck typing."""
    if isinstance(value, (MeshData, Midsurface)):
        return "mesh"
    if isinstance(value, Layered):
        first = next((x for x in value.items if x is not None), None)
        if isinstance(first, LayerPaths):
            return "toolpath"
        if isinstance(first, LayerSections):
            return "sections"
        if isinstance(first, Layer):
            return "layers"
        return None
    if hasattr(value, "trace") and isinstance(getattr(value, "trace"), dict):
        return "simulation"
    if hasattr(value, "features"):
        return "features"
    return None


class Part:
    """Base of scene adapters. `root` is '/graph/<node>/<port>'."""

    kind = ""

    def __init__(self, scene, node: str, port: str, max_segments: int) -> None:
        self.scene = scene
        self.node = node
        self.port = port
        self.root = f"/graph/{slug(node)}/{slug(port)}"
        self.max_segments = max_segments
        self.frame = scene.add_frame(self.root, show_axes=False)

    # -- lifecycle -----------------------------------------------------------------------------
    def sync(self, value: Any, view: ViewState) -> int:
        """Show `value`, redrawing only what changed. Returns the number of scene nodes (re)added."""
        raise NotImplementedError

    def apply(self, view: ViewState) -> None:
        """Apply layer range and colour modes to existing handles (no re-adding)."""

    def remove(self) -> None:
        self.frame.remove()

    # -- queries -------------------------------------------------------------------------------
    def layer_indices(self) -> list[int]:
        return []

    def bounds(self) -> np.ndarray | None:
        return None

    def pick(self, origin, direction, tol: float, view: ViewState) -> Pick | None:
        return None


# --------------------------------------------------------------------------------------------
class MeshPart(Part):
    kind = "mesh"

    def __init__(self, *a, **k) -> None:
        super().__init__(*a, **k)
        self.sig: str | None = None
        self.handle = None
        self._bounds: np.ndarray | None = None

    def sync(self, value, view) -> int:
        sig = digest(value)
        if sig == self.sig:
            return 0
        verts, faces = G.mesh_arrays(value) if isinstance(value, MeshData) else G.midsurface_arrays(value)
        self.handle = self.scene.add_mesh_simple(
            f"{self.root}/mesh",
            verts,
            faces,
            color=C.MESH_RGB,
            opacity=MESH_OPACITY,
            side="double",
            cast_shadow=False,
            receive_shadow=False,
        )
        self.sig = sig
        self._bounds = G.layers_bounds([verts])
        return 1

    def bounds(self):
        return self._bounds


# --------------------------------------------------------------------------------------------
class LayeredPart(Part):
    """A part drawn per layer: `_draw_layer` adds the layer's nodes under `<root>/L0007`."""

    def __init__(self, *a, **k) -> None:
        super().__init__(*a, **k)
        self.entries: dict[int, dict[str, Any]] = {}  # layer index → {sig, handle, item, ...}

    def budget(self, n_layers: int) -> int:
        return max(self.max_segments // max(n_layers, 1), 64)

    def sync(self, value: Layered, view) -> int:
        sigs = layer_signatures(value)
        present: dict[int, tuple[Any, str]] = {}
        for item, sig in zip(value.items, sigs):
            if item is not None and sig is not None:  # sig is None exactly where item is (layer_signatures)
                present[int(item.index)] = (item, sig)
        self._prepare(value, present)
        # items[i] belongs to layer i; None = not computed in this (partial) run: keep what is shown
        partial = {i for i, item in enumerate(value.items) if item is None}
        added = 0
        for index in [i for i in self.entries if i not in present and i not in partial]:
            self.entries.pop(index)["handle"].remove()
        for index, (item, sig) in sorted(present.items()):
            old = self.entries.get(index)
            if old is not None:
                if old["sig"] == sig:
                    continue
                old["handle"].remove()  # children (section fills) may differ: no stale leftovers
            entry = self._draw_layer(index, item, self.budget(len(present)), view)
            entry["sig"] = sig
            entry["handle"].visible = view.shows_layer(index)
            self.entries[index] = entry
            added += 1
        return added

    def _prepare(self, value: Layered, present: dict) -> None:
        """Hook before drawing (e.g. the part-wide speed range)."""

    def _draw_layer(self, index: int, item: Any, budget: int, view: ViewState) -> dict[str, Any]:
        raise NotImplementedError

    def apply(self, view) -> None:
        for index, e in self.entries.items():
            e["handle"].visible = view.shows_layer(index)

    def layer_indices(self):
        return sorted(self.entries)

    def bounds(self):
        return G.layers_bounds([e["bounds"] for e in self.entries.values() if e.get("bounds") is not None])


class LayersPart(LayeredPart):
    kind = "layers"

    def _draw_layer(self, index, layer: Layer, budget, view):
        region, curves = G.layer_outline_segments(layer)
        segs = np.concatenate([region, curves])
        rgb = np.concatenate(
            [np.broadcast_to(C.OUTLINE_RGB, (len(region), 2, 3)), np.broadcast_to(C.CURVE_RGB, (len(curves), 2, 3))]
        ).astype(np.uint8)
        handle = self.scene.add_line_segments(
            f"{self.root}/{layer_name(index)}", segs, rgb, thickness=LINE_PX, thickness_units="screen"
        )
        return {"handle": handle, "count": len(segs), "bounds": G.layers_bounds([segs])}


class SectionsPart(LayeredPart):
    kind = "sections"

    def _draw_layer(self, index, ls: LayerSections, budget, view):
        name = f"{self.root}/{layer_name(index)}"
        frame = self.scene.add_frame(name, show_axes=False)
        fills, guides, pts = {}, [], []
        for s in ls.sections:
            verts, faces = G.section_fill(ls.layer, s.region)
            if len(faces):
                fills[s.key] = self.scene.add_mesh_simple(
                    f"{name}/{slug(s.key)}",
                    verts,
                    faces,
                    color=tuple(int(v) for v in C.categorical(s.key)),
                    opacity=FILL_OPACITY,
                    side="double",
                    cast_shadow=False,
                    receive_shadow=False,
                )
                pts.append(verts)
            guides.append(G.guide_segments(ls.layer, s.guide))
        g = np.concatenate(guides) if guides else np.zeros((0, 2, 3), np.float32)
        if len(g):
            self.scene.add_line_segments(f"{name}/guides", g, (40, 40, 40), thickness=LINE_PX, thickness_units="screen")
        return {"handle": frame, "fills": fills, "count": len(fills), "item": ls, "bounds": G.layers_bounds(pts)}

    def pick(self, origin, direction, tol, view):
        # Sections are areas: intersect the ray with each visible layer's plane (mid-layer).
        import shapely

        o, d = np.asarray(origin, float), np.asarray(direction, float)
        best: Pick | None = None
        for index, e in self.entries.items():
            if not view.shows_layer(index):
                continue
            layer = e["item"].layer
            n = layer.normal
            p0 = layer.to_world(np.zeros((1, 2)))[0] - n * 0.5 * layer.thickness
            denom = d @ n
            if abs(denom) < 1e-12:
                continue
            s = ((p0 - o) @ n) / denom
            if s <= 0 or (best is not None and s >= best.along):
                continue
            hit = o + s * d
            local = hit if layer.frame is None else (np.linalg.inv(layer.frame) @ np.r_[hit, 1.0])[:3]
            for sec in e["item"].sections:
                if sec.region.covers(shapely.Point(local[0], local[1])):
                    best = Pick(
                        s, hit, {"layer": index, "section": sec.key, "area_mm2": round(float(sec.region.area), 3)}
                    )
                    break
        return best


class ToolpathPart(LayeredPart):
    """One line-segment batch per layer; colour by zone / speed / arc / section; travel faint."""

    kind = "toolpath"

    def __init__(self, *a, **k) -> None:
        super().__init__(*a, **k)
        self.speed_range = (0.0, 1.0)  # colour-map limits (robust), mm/s
        self.speed_full = (0.0, 1.0)  # the speeds' full extent, mm/s
        self.color_mode = "zone"

    def _prepare(self, value, present):
        speeds = [np.asarray(sp.speed, float) for item, _ in present.values() for sp in item.sections]
        new_range = C.robust_range(*speeds) if speeds else (0.0, 1.0)
        self.speed_full = C.finite_range(*speeds) if speeds else (0.0, 1.0)
        if new_range != self.speed_range:
            self.speed_range = new_range
            for e in self.entries.values():
                e["recolor"] = True

    def colors(self, disp: G.PathLayerDisplay, mode: str) -> np.ndarray:
        """(m, 2, 3) uint8 colours of a layer's display segments for a colour mode."""
        if mode == "speed":
            rgb = C.colormap(disp.speed, *self.speed_range)
        elif mode == "arc":
            rgb = np.where(disp.arc[:, None], C.ARC_ON_RGB, C.ARC_OFF_RGB).astype(np.uint8)
        elif mode == "section":
            pal = np.array([C.categorical(k) for k in disp.section_keys] or [C.NAN_RGB], np.uint8)
            rgb = pal[np.clip(disp.section, 0, len(pal) - 1)]
        else:
            rgb = disp.zone_rgb.copy()
        if mode != "arc":
            rgb[disp.travel] = C.TRAVEL_RGB
        return np.repeat(rgb[:, None, :], 2, axis=1)

    def zone_legend(self, limit: int = 12) -> list[tuple[str, str]]:
        """(zone id, '#rrggbb') pairs as drawn (the zone node's colours), in path order
        start, z1, z2, …, end. Empty when the paths are not zoned (drawn by section)."""
        seen: dict[str, str] = {}
        for e in self.entries.values():
            disp = e["disp"]
            arc = ~disp.travel
            for zi in np.unique(disp.zone[arc & (disp.zone >= 0)]):
                zone = disp.zone_ids[zi]
                if zone and zone not in seen:
                    seen[zone] = C.rgb_to_hex(disp.zone_rgb[arc & (disp.zone == zi)][0])
            if len(seen) >= limit:
                break
        return sorted(seen.items(), key=lambda kv: _zone_order(kv[0]))[:limit]

    def _draw_layer(self, index, lp: LayerPaths, budget, view):
        disp = G.path_display(G.layer_polyline(lp), budget)
        handle = self.scene.add_line_segments(
            f"{self.root}/{layer_name(index)}",
            disp.segments,
            self.colors(disp, view.path_color),
            thickness=PATH_PX,
            thickness_units="screen",
        )
        return {
            "handle": handle,
            "disp": disp,
            "item": lp,
            "mode": view.path_color,
            "count": len(disp),
            "bounds": G.layers_bounds([disp.segments]),
        }

    def apply(self, view):
        super().apply(view)
        for e in self.entries.values():
            if e["mode"] != view.path_color or e.pop("recolor", False):
                e["handle"].colors = self.colors(e["disp"], view.path_color)
                e["mode"] = view.path_color

    def _point_info(self, index: int, poly: G.PathLayerPolyline, i: int) -> dict[str, Any]:
        seg = min(i, len(poly.travel) - 1)
        speed = poly.speed[seg]
        return {
            "layer": index,
            "section": poly.section_keys[poly.section[seg]] if poly.section_keys else "",
            "zone": poly.zone_ids[poly.zone[seg]] if poly.zone[seg] >= 0 else "travel",
            "arc": bool(poly.arc[seg]),
            "programmed_speed_mm_s": None if np.isnan(speed) else round(float(speed), 3),
        }

    def pick(self, origin, direction, tol, view):
        best: Pick | None = None
        d = np.asarray(direction, float) / np.linalg.norm(direction)
        for index, e in self.entries.items():
            if not view.shows_layer(index):
                continue
            poly = G.layer_polyline(e["item"])
            if len(poly.points) < 2:
                continue
            i = G.ray_pick(poly.points, origin, d, tol)
            if i is None:
                continue
            along = float((poly.points[i] - np.asarray(origin, float)) @ d)
            if best is None or along < best.along:
                best = Pick(along, poly.points[i], self._point_info(index, poly, i))
        return best

    def nearest_point(self, point: np.ndarray, layer: int | None) -> dict[str, Any] | None:
        """Readout of the path point nearest to a world point, within `layer` when given."""
        found: tuple[float, dict[str, Any]] | None = None
        for index, e in self.entries.items():
            if layer is not None and index != layer:
                continue
            poly = G.layer_polyline(e["item"])
            if len(poly.points) < 2:
                continue
            dist = np.linalg.norm(poly.points - np.asarray(point, float), axis=1)
            i = int(np.argmin(dist))
            if found is None or dist[i] < found[0]:
                found = (float(dist[i]), self._point_info(index, poly, i))
        return None if found is None else found[1]


# --------------------------------------------------------------------------------------------
class FeaturesPart(Part):
    kind = "features"

    def __init__(self, *a, **k) -> None:
        super().__init__(*a, **k)
        self.sig: str | None = None
        self.points = np.zeros((0, 3))
        self.kinds: list[str] = []
        self.layers: list[int | None] = []
        self.handle = None

    def sync(self, value, view) -> int:
        feats = list(value.features)
        sig = digest([(str(_get(f, "kind")), np.asarray(_get(f, "point"), float).tolist()) for f in feats])
        if sig == self.sig:
            return 0
        pts, kinds, layers = [], [], []
        for f in feats:
            layers.append(_get(f, "layer"))
            p = np.asarray(_get(f, "point"), float).reshape(-1)
            z = p[2] if len(p) > 2 else float(_get(f, "z", 0.0) or 0.0)
            pts.append([p[0], p[1], z])
            kinds.append(str(_get(f, "kind")))
        self.points = np.asarray(pts, float).reshape(-1, 3)
        self.kinds = kinds
        self.layers = layers
        rgb = np.array([C.FEATURE_RGB.get(k, tuple(C.categorical(k))) for k in kinds], np.uint8).reshape(-1, 3)
        if self.handle is not None and not len(self.points):
            self.handle.remove()
            self.handle = None
        if len(self.points):
            self.handle = self.scene.add_point_cloud(
                f"{self.root}/points", self.points.astype(np.float32), rgb, point_size=1.5, point_shape="circle"
            )
        self.sig = sig
        return 1

    def bounds(self):
        return G.layers_bounds([self.points])

    def pick(self, origin, direction, tol, view):
        i = G.ray_pick(self.points, origin, direction, tol)
        if i is None:
            return None
        d = np.asarray(direction, float) / np.linalg.norm(direction)
        return Pick(
            float((self.points[i] - np.asarray(origin, float)) @ d),
            self.points[i],
            {"feature": self.kinds[i], **({"layer": self.layers[i]} if self.layers[i] is not None else {})},
        )


def _zone_order(zone: str) -> tuple[int, int, str]:
    """Sort key of zone ids along a path: start, z1, z2, …, end, then anything else."""
    if zone == "start":
        return (0, 0, zone)
    if zone == "end":
        return (2, 0, zone)
    if re.fullmatch(r"z\d+", zone):
        return (1, int(zone[1:]), zone)
    return (3, 0, zone)


def _get(obj, key, default=None):
    return obj.get(key, default) if isinstance(obj, dict) else getattr(obj, key, default)
