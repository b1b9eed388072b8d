"""Semi-circular links (robot study): boustrophedon passes joined outside the section by half
circles of diameter W_WB, tangent to both passes (G1-smooth).

Each half circle is discretised into k equal chords with sagitta r·(1 − cos(π/2k)) ≤ chord_tol.
Small OR: 5 × 43 + 4 × π·4.43/2 = 242.834 mm exact; the study's programmed 242.603 mm is within
0.1 % (it used coarser chords). When neighbouring passes end at different s (non-rectangular
section) the shorter one is first extended straight to the longer one's end, which keeps G1.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString, Polygon

from .flags import Draft
from .frame import plan_passes
from .links import boustrophedon, closing_stub, flush
from .spec import StrategySpec


def chord_count(radius: float, tol: float) -> int:
    """Chords for a half circle of `radius` mm so that the sagitta stays within `tol` mm."""
    if tol >= radius:
        return 2
    return max(2, math.ceil(math.pi / (2.0 * math.acos(1.0 - tol / radius))))


def half_circle(a: np.ndarray, b: np.ndarray, side: int, tol: float) -> list:
    """Points strictly between a and b (same s) on the half circle bulging towards `side` (s)."""
    r = abs(b[1] - a[1]) / 2.0
    if r == 0.0:
        return []
    sgn = 1.0 if b[1] > a[1] else -1.0
    tc = 0.5 * (a[1] + b[1])
    k = chord_count(r, tol)
    phi = np.linspace(0.0, math.pi, k + 1)[1:-1]
    return [np.array([a[0] + side * r * math.sin(f), tc - sgn * r * math.cos(f)]) for f in phi]


def plan(region: Polygon, guide: LineString | None, spec: StrategySpec) -> Draft:
    pp = plan_passes(region, guide, spec.spacing)

    def link(a, b, side):
        s_star, stub = flush(a, b, side)
        a2 = np.array([s_star, a[1]])
        b2 = np.array([s_star, b[1]])
        return stub + half_circle(a2, b2, side, spec.chord_tol) + closing_stub(b, s_star)

    return boustrophedon(pp, link, spec.extension_before, spec.extension_after)
