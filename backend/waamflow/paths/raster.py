"""Raster pass (robot study, da Silva Viola et al. 2023): every pass in the same direction.

Arc ON along each pass, OFF on the straight diagonal return from a pass end to the next pass
start, so the arc switches at both ends of every pass. Small OR 21.5 × 43 mm, W_WB 4.43 mm:
5 × 43 + 4 × √(43² + 4.43²) = 387.910 mm.
"""

from __future__ import annotations

import numpy as np
from shapely.geometry import LineString, Polygon

from .flags import Draft
from .frame import plan_passes
from .spec import StrategySpec


def plan(region: Polygon, guide: LineString | None, spec: StrategySpec) -> Draft:
    pp = plan_passes(region, guide, spec.spacing)
    st, ok = [], []
    for p in pp.passes:
        if st:
            ok.append(False)  # return travel
        st += [[p.s_lo - spec.extension_before, p.t], [p.s_hi + spec.extension_after, p.t]]
        ok.append(True)
    return Draft(pp.frame.to_world(np.array(st)), ok)
