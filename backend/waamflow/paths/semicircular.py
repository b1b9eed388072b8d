"""Semi-circular links (robot study): boustrophedon passes joined outside the section by half
circles of diameter W_WB, tangent to both passes (G1-smooth).

Each half circle is discretised into k equal chords with sagitta r·(1 − cos(π/2k)) ≤ chord_tol.
Small OR: 5 × 43 + 4 × π·4.43/2 = 242.834 mm exact; the study's programmed 242.603 mm is within
0.1 % (it used coarser chords). When neighbouring passes end at different s (non-rectangular
section) the shorter one is first extended straight to the longer one's end, which keeps G1.
Along a curved guide the passes are its offsets and each half circle bulges along the pass's end
tangent.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString, Polygon

from .flags import Draft
from .links import boustrophedon, flush
from .passes import plan_passes
from .spec import StrategySpec


def chord_count(radius: float, tol: float) -> int:
    """Chords for a half circle of `radius` mm so that the sagitta stays within `tol` mm."""
    if tol >= radius:
        return 2
    return max(2, math.ceil(math.pi / (2.0 * math.acos(1.0 - tol / radius))))


def half_circle(a: np.ndarray, b: np.ndarray, tau: np.ndarray, tol: float) -> list:
    """Points strictly between a and b on the half circle of diameter |b − a| bulging along tau
    (tau ⟂ b − a, unit)."""
    r = float(np.hypot(*(b - a))) / 2.0
    if r == 0.0:
        return []
    c = 0.5 * (a + b)
    w = (b - a) / (2.0 * r)
    k = chord_count(r, tol)
    phi = np.linspace(0.0, math.pi, k + 1)[1:-1]
    return list(c - r * np.cos(phi)[:, None] * w + r * np.sin(phi)[:, None] * tau)


def plan(region: Polygon, guide: LineString, spec: StrategySpec) -> Draft:
    pp = plan_passes(region, guide, spec.spacing)

    def link(a, b, tau):
        a2, b2, stub_a, stub_b = flush(a, b, tau)
        return stub_a + half_circle(a2, b2, tau, spec.chord_tol) + stub_b

    return boustrophedon(pp, link, spec.extension_before, spec.extension_after)
