"""Triangular links (robot study): boustrophedon passes joined outside the section by the two
equal sides of an isosceles triangle on base W_WB with apex angle θ = angle_deg.

Side = (W_WB / 2) / sin(θ / 2), apex height h = (W_WB / 2) / tan(θ / 2). Small OR:
θ = 45° → 5 × 43 + 8 × 5.788 = 261.301 mm; θ = 60° → 250.440 mm; θ = 90° → 240.06 mm.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString, Polygon

from .flags import Draft
from .frame import plan_passes
from .links import boustrophedon, closing_stub, flush
from .spec import StrategySpec


def plan(region: Polygon, guide: LineString | None, spec: StrategySpec) -> Draft:
    pp = plan_passes(region, guide, spec.spacing)
    half = math.radians(spec.angle_deg) / 2.0

    def link(a, b, side):
        s_star, stub = flush(a, b, side)
        h = abs(b[1] - a[1]) / 2.0 / math.tan(half)
        apex = np.array([s_star + side * h, 0.5 * (a[1] + b[1])])
        return stub + [apex] + closing_stub(b, s_star)

    return boustrophedon(pp, link, spec.extension_before, spec.extension_after)
