"""Value types that flow between nodes. Plain, immutable data: numpy arrays + shapely geometry.

Units: millimetres, seconds, degrees everywhere; mm/s for speeds. Coordinates of layers,
sections and 2D paths are *layer-local* (x, y) in mm; for planar horizontal layers (the common
case, `Layer.frame is None`) layer-local x, y are world x, y and the layer sits at world height
`Layer.z`. Toolpath points are world (x, y, z).

Kernels return new values instead of mutating (mutation defeats caching): use
`dataclasses.replace`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Generic, Iterator, Sequence, TypeVar

import numpy as np
import shapely
from shapely.geometry import LineString, MultiPolygon, Polygon

T = TypeVar("T")


# --------------------------------------------------------------------------------------------
# Inputs
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class MeshData:
    """A solid part as a triangle mesh, in mm.

    vertices: (n, 3) float64, mm. faces: (m, 3) int64 indices into vertices.
    """

    vertices: np.ndarray
    faces: np.ndarray
    name: str = "mesh"
    surface: bool = False  # an open single-wall surface: sliced into per-layer curves, not regions
    bodies: int = 0  # closed bodies (faces joined across edges) when the mesh read counted them; 0: not counted

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float: min and max corner, mm."""
        return np.array([self.vertices.min(axis=0), self.vertices.max(axis=0)])


@dataclass(frozen=True, eq=False)
class Midsurface:
    """Thin-wall part given by its midsurface: 2D curves extruded along +Z (thin-walls study).

    curves: each (k, 2) float64 polyline in mm; a closed curve repeats its first point at the end.
    z0/height: the extrusion runs from z0 to z0 + height (mm).
    """

    curves: tuple[np.ndarray, ...]
    height: float
    z0: float = 0.0
    name: str = "sketch"
    joints: tuple[tuple[float, float], ...] = ()  # (x, y) mm where the sketch joined two curves end to end

    @property
    def bounds(self) -> np.ndarray:
        pts = np.vstack(self.curves)
        lo = [pts[:, 0].min(), pts[:, 1].min(), self.z0]
        hi = [pts[:, 0].max(), pts[:, 1].max(), self.z0 + self.height]
        return np.array([lo, hi], dtype=float)


# --------------------------------------------------------------------------------------------
# Layers
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Layer:
    """One layer of the build.

    index: 0-based, bottom to top. z: height of the *top* of the layer (where the bead top sits and
    the torch deposits), mm. thickness: layer height, mm; the layer occupies [z - thickness, z]
    and its geometry is cut at mid-layer, z - thickness/2. region: the solid's cross-section
    (layer-local, may be empty). curves: midsurface curves cut by the plane (open or closed; a
    closed curve repeats its first point). frame: (4, 4) float, layer-local (x, y, 0) → world,
    for non-horizontal layers (fan slicing); None = horizontal plane at height z.
    """

    index: int
    z: float
    thickness: float
    region: MultiPolygon = field(default_factory=MultiPolygon)
    curves: tuple[LineString, ...] = ()
    frame: np.ndarray | None = None
    joints: tuple[tuple[float, float], ...] = ()  # (x, y) mm: wall junctions inside joined curves

    @property
    def area(self) -> float:
        return float(self.region.area)

    def to_world(self, xy: np.ndarray) -> np.ndarray:
        """(n, 2) layer-local points → (n, 3) world points at the layer's deposition height."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        if self.frame is None:
            return np.column_stack([xy, np.full(len(xy), self.z)])
        homo = np.column_stack([xy, np.zeros(len(xy)), np.ones(len(xy))])
        return np.asarray((homo @ self.frame.T)[:, :3])

    @property
    def normal(self) -> np.ndarray:
        """World build direction of this layer (unit)."""
        if self.frame is None:
            return np.array([0.0, 0.0, 1.0])
        return np.asarray(self.frame[:3, 2] / np.linalg.norm(self.frame[:3, 2]))


@dataclass(frozen=True, eq=False)
class Layered(Generic[T]):
    """One item per layer, in layer order. The engine caches and recomputes per item.

    items[i] belongs to layer i (items carry their own `index`). sigs[i] is the content
    signature of items[i], set by the engine (empty tuple when built by hand in tests).
    An item may be None in a partial (single-layer preview) run.
    """

    items: tuple[T, ...]
    sigs: tuple[str, ...] = ()

    def __len__(self) -> int:
        return len(self.items)

    def __iter__(self) -> Iterator[T]:
        return iter(self.items)

    def __getitem__(self, i: int) -> T:
        return self.items[i]


LayerStack = Layered[Layer]


# --------------------------------------------------------------------------------------------
# Sections (MPP segmentation)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Section:
    """A simple region of one layer with its own path and process parameters (MPP).

    key: "<mask id>/<section id>", or "region<k>" (k-th connected region, largest first) when no
    mask is given. region: layer-local polygon, mm. order: default deposition order in the layer.
    guide: open polyline giving the deposition direction, clipped so it starts at `start` and
    stops at `stop` — its two crossings with the region boundary (None before the guide node).
    """

    key: str
    region: Polygon
    order: int = 0
    guide: LineString | None = None
    start: tuple[float, float] | None = None
    stop: tuple[float, float] | None = None


@dataclass(frozen=True, eq=False)
class LayerSections:
    """The sections of one layer, in default deposition order.

    uncovered_area: area of the layer (mm²) that no section covers (mask leaves it unbuilt).
    """

    layer: Layer
    sections: tuple[Section, ...]
    uncovered_area: float = 0.0

    @property
    def index(self) -> int:
        return self.layer.index

    def by_key(self) -> dict[str, Section]:
        return {s.key: s for s in self.sections}


# --------------------------------------------------------------------------------------------
# Paths and toolpaths
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class SectionPath:
    """The deposition path of one section.

    points: (n, 3) float, world mm. Per segment (length n - 1): arc (bool: arc ON), inside (bool:
    segment lies in the section region; False for links a strategy takes outside it), speed
    (float mm/s, programmed travel speed), zone (zone id: "start", "z1", ..., "end"; "" before
    zoning). zone_colors: zone id → "#rrggbb". zone_params: zone id → {parameter name: value},
    names from `waamflow.core.process.ZONE_PARAMETERS` (units in the names).
    tool_axis: (n, 3) unit vectors from the torch towards the part, or None (= (0, 0, -1)).
    approach: (k, 3) arc-OFF travel points flown before points[0] (set by sequencing), or None.
    tool: "" for the deposition torch; else a post-deposition tool ("rolling", "peening") whose
    contact is every arc-OFF segment with a programmed speed (the post-processor engages the tool
    before such a run and lifts it after), with `tool_params` (force_n, tool_width_mm,
    speed_mm_s, ...) stated in the program's tool commands.
    """

    key: str
    strategy: str
    points: np.ndarray
    arc: np.ndarray
    inside: np.ndarray
    speed: np.ndarray
    zone: tuple[str, ...] = ()
    zone_colors: dict[str, str] = field(default_factory=dict)
    zone_params: dict[str, dict[str, float]] = field(default_factory=dict)
    tool_axis: np.ndarray | None = None
    approach: np.ndarray | None = None
    tool: str = ""
    tool_params: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = len(self.points)
        for name in ("arc", "inside", "speed"):
            arr = getattr(self, name)
            if len(arr) != max(n - 1, 0):
                raise ValueError(f"SectionPath {self.key}: {name} has {len(arr)} entries for {n} points")
        if self.zone and len(self.zone) != max(n - 1, 0):
            raise ValueError(f"SectionPath {self.key}: zone has {len(self.zone)} entries for {n} points")

    @property
    def segment_lengths(self) -> np.ndarray:
        """(n - 1,) float, mm."""
        return np.asarray(np.linalg.norm(np.diff(self.points, axis=0), axis=1))

    @property
    def length(self) -> float:
        return float(self.segment_lengths.sum())


@dataclass(frozen=True, eq=False)
class LayerPaths:
    """The program of one layer: section paths in deposition order.

    dwell_after_s: interlayer dwell after this layer (s). dwell_note: why (e.g. the interpass
    rule that set it), written beside the dwell in the program.
    """

    layer: Layer
    sections: tuple[SectionPath, ...]
    dwell_after_s: float = 0.0
    dwell_note: str = ""

    @property
    def index(self) -> int:
        return self.layer.index


Toolpath = Layered[LayerPaths]


def region_polygons(geom: Any) -> list[Polygon]:
    """The polygons of any shapely areal geometry (Polygon, MultiPolygon, collection), largest first."""
    if geom is None or geom.is_empty:
        return []
    parts = [g for g in shapely.get_parts(geom) if isinstance(g, Polygon) and not g.is_empty]
    out: list[Polygon] = []
    for g in parts:
        out.append(g)
    return sorted(out, key=lambda p: -p.area)


def as_multipolygon(polys: Sequence[Polygon] | Polygon | MultiPolygon) -> MultiPolygon:
    if isinstance(polys, MultiPolygon):
        return polys
    if isinstance(polys, Polygon):
        return MultiPolygon([polys]) if not polys.is_empty else MultiPolygon()
    polys = [p for p in polys if not p.is_empty]
    return MultiPolygon(polys) if polys else MultiPolygon()
