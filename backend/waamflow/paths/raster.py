"""Raster pass (robot study, da Silva Viola et al. 2023): every pass in the same direction.

Passes follow the guide (offsets of it; straight lines for a straight guide). Arc ON along each
pass, OFF on the straight diagonal return from a pass end to the next pass
start, so the arc switches at both ends of every pass. Small OR 21.5 × 43 mm, W_WB 4.43 mm:
5 × 43 + 4 × √(43² + 4.43²) = 387.910 mm.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from shapely.geometry import LineString, Polygon

from .flags import Draft
from .passes import oriented, plan_passes
from .spec import StrategySpec


def plan(region: Polygon, guide: LineString, spec: StrategySpec) -> Draft:
    pp = plan_passes(region, guide, spec.spacing)
    pts: list[Any] = []
    ok: list[Any] = []
    for p in pp.passes:
        run = oriented(p, True, spec.extension_before, spec.extension_after)
        if pts:
            ok.append(False)  # return travel
        pts.extend(run)
        ok.extend([True] * (len(run) - 1))
    return Draft(np.asarray(pts), ok)
