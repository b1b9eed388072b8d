"""Segmentation of a layer into MPP sections by a Building-Strategy mask (Michel et al. 2019, step 2).

A mask is a list of closed planar curves drawn over the layer; section k is `layer ∩ polygon(curve_k)`.
One mask governs the layers from its `from_layer` up to the layer before the next mask's.

Overlapping curves: MPP replaces sharp turns and crossings by *corner/intersection sections*, i.e.
the user draws the intersection as its own section or lets one arm run through it. We therefore let
the **earlier** section in the mask own any overlap: section k's region is
`layer ∩ curve_k − (region_0 ∪ … ∪ region_{k-1})`. No area is deposited twice, and a user may draw
the side arms of a cross loosely over the centre without double deposition there. A later section
that is cut in two by an earlier one fails like any other curve yielding several regions.

Layers below the first mask's `from_layer` are not governed by a mask: like a recipe with no mask,
each connected region becomes one section (`region<k>`, largest first).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, Sequence, TypeVar

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.validation import explain_validity

from ..core.errors import PlanningError, RecipeError
from ..core.model import Layer, LayerSections, Section, region_polygons
from ..core.tolerances import TOL


@dataclass(frozen=True, eq=False)
class MaskSection:
    """One segmentation curve. id: section id within the mask; polygon: the closed curve, mm."""

    id: str
    polygon: Polygon


@dataclass(frozen=True, eq=False)
class Mask:
    """A Building-Strategy mask: sections in default deposition order, governing layers ≥ from_layer."""

    id: str
    from_layer: int
    sections: tuple[MaskSection, ...]

    def key(self, section_id: str) -> str:
        return f"{self.id}/{section_id}"

    @classmethod
    def from_json(cls, data: dict) -> "Mask":
        """Build from the contract form `{"id", "from_layer", "sections": [{"id", "curve": [[x,y],...]}]}`.

        Raises RecipeError for a curve that is not a valid simple closed polygon.
        """
        mid = str(data["id"])
        sections = []
        seen: set[str] = set()
        for s in data.get("sections", []):
            sid = str(s["id"])
            key = f"{mid}/{sid}"
            if sid in seen:
                raise RecipeError(f"section id {sid!r} used twice in mask {mid!r}", section=key)
            seen.add(sid)
            sections.append(MaskSection(sid, curve_polygon(s["curve"], key)))
        return cls(mid, int(data.get("from_layer", 0)), tuple(sections))


def curve_polygon(curve: Sequence[Sequence[float]], key: str = "") -> Polygon:
    """A closed planar curve (k, 2) in mm (closing point optional) → valid Polygon, else RecipeError."""
    pts = np.asarray(curve, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3 or not np.isfinite(pts).all():
        raise RecipeError("a mask curve needs at least 3 finite [x, y] points", section=key or None)
    poly = Polygon(pts)
    if not poly.is_valid:
        raise RecipeError(f"mask curve is not a simple closed curve ({explain_validity(poly)})", section=key or None)
    if poly.area <= TOL.min_area:
        raise RecipeError("mask curve encloses no area", section=key or None)
    return poly


class _Starts(Protocol):
    @property
    def from_layer(self) -> int: ...


_M = TypeVar("_M", bound=_Starts)


def governing_mask(masks: Sequence[_M], index: int) -> _M | None:
    """The mask governing layer `index`: the one with the largest from_layer ≤ index (None below all).
    The one rule: masks (`Mask`) and the mask node's params (`MaskParams`) alike."""
    best: _M | None = None
    for m in masks:
        if m.from_layer <= index and (best is None or m.from_layer >= best.from_layer):
            best = m
    return best


def _parts(geom) -> list[Polygon]:
    """Polygons of a boolean result, dropping slivers below TOL.min_area (mm²) left by clipping."""
    return [p for p in region_polygons(geom) if p.area > TOL.min_area]


def connected_sections(layer: Layer) -> LayerSections:
    """No mask: each connected region of the layer is one section `region<k>`, largest first."""
    polys = _parts(layer.region)
    sections = tuple(Section(f"region{k}", p, order=k) for k, p in enumerate(polys))
    return LayerSections(layer, sections, uncovered_area=0.0)


def segment_layer(layer: Layer, mask: Mask | None) -> LayerSections:
    """Cut one layer into the sections of `mask` (see module doc for the overlap rule).

    Raises PlanningError(layer=index, section=key) when a curve yields no region or more than one
    on this layer. `uncovered_area` (mm²) is the layer area no section covers.
    """
    if mask is None:
        return connected_sections(layer)
    region = layer.region
    taken = None
    sections: list[Section] = []
    for order, ms in enumerate(mask.sections):
        key = mask.key(ms.id)
        cut = shapely.intersection(region, ms.polygon)
        if taken is not None:
            cut = shapely.difference(cut, taken)
        parts = _parts(cut)
        if not parts:
            if region.is_empty and layer.curves:  # a surface part (open mesh, sketch): curves, no area
                raise PlanningError(
                    f"this layer has no area to segment: the part is a single-wall surface, its layer is "
                    f"{len(layer.curves)} curve(s) (an open mesh is read so: close its gaps, set the mesh's "
                    "'as': 'solid' to see why it is open, or plan its walls with wall-path)",
                    layer=layer.index,
                    section=key,
                )
            raise PlanningError(
                "mask curve yields no region on this layer; start a new mask here", layer=layer.index, section=key
            )
        if len(parts) > 1:
            areas = ", ".join(f"{p.area:.1f}" for p in parts)
            raise PlanningError(
                f"mask curve yields {len(parts)} separate regions (areas {areas} mm²) on this "
                "layer; start a new mask here",
                layer=layer.index,
                section=key,
            )
        sections.append(Section(key, parts[0], order=order))
        taken = parts[0] if taken is None else shapely.union(taken, parts[0])
    covered = 0.0 if taken is None else float(shapely.intersection(region, taken).area)
    uncovered = max(float(region.area) - covered, 0.0)
    if uncovered <= TOL.min_area:
        uncovered = 0.0
    return LayerSections(layer, tuple(sections), uncovered_area=uncovered)


def uncovered_percent(ls: LayerSections) -> float:
    """Share of the layer area left uncovered by the sections, in %."""
    area = ls.layer.area
    return 0.0 if area <= 0 else 100.0 * ls.uncovered_area / area
