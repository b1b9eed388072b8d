"""Swiping (robot study; reconstructed): a dense zig-zag inside the section with many bead overlaps.

The study describes a zig-zag whose direction reverses at a very sharp interior angle (about
2.95°), that overlaps beads and stays inside the OR, and gives its programmed length (small OR:
464.246 mm). Reconstruction: legs run along the passes from one end of the section to the other,
stopping W_WB / 2 short of the section boundary (the bead of width ≈ W_WB stays inside at the
hairpins); each leg advances across by `swipe_advance`·W_WB (default 1/3: every bead overlaps two
thirds of the previous one), over the band from the first to the last pass centre line
((n_WB − 1)·W_WB wide), in N = ceil(band / advance) legs.
Small OR: band 17.72 mm, N = 12 legs of √(38.57² + 1.4767²) = 463.18 mm (−0.23 % vs 464.246).
Reversal interior angle there: 2·atan(1.4767 / 38.57) = 4.4°. (A path with a constant 2.95° reversal
and 464 mm length can only advance 464·sin(1.475°) = 11.95 mm across, less than the 17.72 mm band,
so the published angle and length cannot both hold for a zig-zag that covers the passes.)
Run-ups (extension_before/after) extend the first and last leg.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString, Polygon

from .flags import Draft, extend_ends
from .frame import chord, plan_passes
from .spec import StrategySpec


def plan(region: Polygon, guide: LineString | None, spec: StrategySpec) -> Draft:
    pp = plan_passes(region, guide, spec.spacing)
    t0, t1 = pp.passes[0].t, pp.passes[-1].t
    band = t1 - t0
    target = spec.swipe_advance * spec.spacing
    legs = max(1, math.ceil(band / target - 1e-6))
    keep = spec.spacing / 2.0
    st = []
    for k in range(legs + 1):
        t = t0 + band * k / legs
        c = chord(pp.local_region, t) or (pp.passes[0].s_lo, pp.passes[0].s_hi)
        lo, hi = c[0] + keep, c[1] - keep
        if lo > hi:
            lo = hi = 0.5 * (c[0] + c[1])
        st.append([lo if k % 2 == 0 else hi, t])
    pts = extend_ends(pp.frame.to_world(np.array(st)), spec.extension_before, spec.extension_after)
    return Draft(pts, np.ones(len(pts) - 1, dtype=bool))
