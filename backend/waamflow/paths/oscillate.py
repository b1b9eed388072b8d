"""Oscillate (MPP, Michel et al. 2019, §strategies): weave across the section, perpendicular to the
guide, advancing a constant step along it; follows curved guides.

Stations sit every `step` mm of guide arc length (shortened evenly so the first is where the guide
enters the section and the last where it leaves). At each station the section's chord along the
local normal is measured; the weave vertex goes to alternate ends of that chord, half a bead
width inside the boundary, so the amplitude is the local width minus a bead width (both vertices
at the chord middle where the section is narrower than a bead). Run-ups continue the guide's
direction before the first vertex and after the last.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString, Polygon

from .flags import Draft
from .frame import cross_chord, nudged, guide_or_default, guide_span, unit_tangent
from .spec import StrategySpec


def stations(region: Polygon, guide: LineString, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points (k, 2) on the guide every ≤ step mm inside the section, and their unit left normals (k, 2)."""
    s0, s1 = guide_span(region, guide)
    count = max(1, math.ceil((s1 - s0) / step - 1e-9))
    s = np.linspace(s0, s1, count + 1)
    h = min(step / 4.0, max((s1 - s0) / 4.0, 1e-6))
    pts = np.array([guide.interpolate(x).coords[0] for x in s])
    tan = np.array([unit_tangent(guide, x, h) for x in s])
    return pts, np.column_stack([-tan[:, 1], tan[:, 0]])


def weave_limits(region: Polygon, p: np.ndarray, n: np.ndarray, bead_width: float, reach: float) -> tuple[float, float]:
    """Offsets (mm along n from p) of the two weave vertices at one station."""
    lo, hi = cross_chord(region, p, n, reach)
    a, b = lo + bead_width / 2.0, hi - bead_width / 2.0
    if a > b:
        a = b = 0.5 * (lo + hi)
    return a, b


def plan(region: Polygon, guide: LineString | None, spec: StrategySpec) -> Draft:
    g = guide_or_default(region, guide)
    x0, y0, x1, y1 = region.bounds
    reach = 2.0 * math.hypot(x1 - x0, y1 - y0)
    pts, normals = stations(region, g, spec.step)
    # chords are measured on the region grown by NUDGE so a station on a straight end of the section
    # (normal along the boundary edge) still sees that edge despite round-off
    probe = nudged(region)
    strokes = []
    for k, (p, n) in enumerate(zip(pts, normals)):
        a, b = weave_limits(probe, p, n, spec.bead_width, reach)
        strokes.append(p + (a if k % 2 == 0 else b) * n)
    out = np.array(strokes)
    # run-ups continue the guide's direction (not the first weave stroke's)
    t0 = np.array([normals[0][1], -normals[0][0]])
    t1 = np.array([normals[-1][1], -normals[-1][0]])
    head = [out[0] - spec.extension_before * t0] if spec.extension_before > 0 else []
    tail = [out[-1] + spec.extension_after * t1] if spec.extension_after > 0 else []
    path = np.vstack(head + [out] + tail)
    return Draft(path, np.ones(len(path) - 1, dtype=bool))
