"""Triangular links (robot study): boustrophedon passes joined outside the section by the two
equal sides of an isosceles triangle on base W_WB with apex angle θ = angle_deg.

Side = (W_WB / 2) / sin(θ / 2), apex height h = (W_WB / 2) / tan(θ / 2). Small OR:
θ = 45° → 5 × 43 + 8 × 5.788 = 261.301 mm; θ = 60° → 250.440 mm; θ = 90° → 240.06 mm.
Along a curved guide the passes are its offsets and the apex points along the pass's end tangent.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString, Polygon

from .flags import Draft
from .links import boustrophedon, flush
from .passes import plan_passes
from .spec import StrategySpec


def plan(region: Polygon, guide: LineString, spec: StrategySpec) -> Draft:
    pp = plan_passes(region, guide, spec.spacing)
    half = math.radians(spec.angle_deg) / 2.0

    def link(a, b, tau):
        a2, b2, stub_a, stub_b = flush(a, b, tau)
        h = float(np.hypot(*(b2 - a2))) / 2.0 / math.tan(half)
        return stub_a + [0.5 * (a2 + b2) + h * tau] + stub_b

    return boustrophedon(pp, link, spec.extension_before, spec.extension_after)
