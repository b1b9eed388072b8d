"""The pattern registry and the one entry point, `plan_section`.

Adding a strategy = one kernel module with `plan(region, guide, spec) -> Draft` + one line in
`PATTERNS`.
"""

from __future__ import annotations

from typing import Callable

from shapely.geometry import LineString, Polygon

from . import contour, oscillate, parallel, raster, rectangular, semicircular, spiral, swiping, triangular
from .flags import Draft, finish
from .frame import guide_or_default
from .spec import Path2D, StrategySpec

Kernel = Callable[[Polygon, LineString | None, StrategySpec], Draft]

PATTERNS: dict[str, Kernel] = {
    "oscillate": oscillate.plan,
    "parallel": parallel.plan,
    "raster": raster.plan,
    "semicircular": semicircular.plan,
    "triangular": triangular.plan,
    "rectangular": rectangular.plan,
    "spiral": spiral.plan,
    "swiping": swiping.plan,
    "contour": contour.plan,
}


def plan_section(region: Polygon, guide: LineString | None, spec: StrategySpec) -> Path2D:
    """Fill one section polygon (layer-local, mm) with `spec.pattern` along `guide` (default: long axis
    of the region's minimum rotated rectangle). Segments are split at the section boundary and
    flagged inside/outside and arc ON/OFF (`spec.arc_outside`)."""
    if region.is_empty or region.area <= 0.0:
        raise ValueError("empty section region")
    draft = PATTERNS[spec.pattern](region, guide_or_default(region, guide), spec)
    return finish(draft.points, draft.arc_ok, region, spec.arc_outside)
