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
Along a curved guide the legs blend between neighbouring offsets of the guide, so they follow the
curve. Run-ups (extension_before/after) extend the first and last leg.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString, Polygon
from shapely.ops import substring

from .flags import Draft, extend_ends
from .passes import offset_piece, plan_passes
from .spec import StrategySpec


def _shortened(points: np.ndarray, keep: float) -> LineString:
    """The pass without `keep` mm at each end (a quarter of it each end when shorter than 2·keep)."""
    line = LineString(points)
    keep = min(keep, 0.25 * line.length)
    return substring(line, keep, line.length - keep)


def _leg(c0: LineString, c1: LineString, forward: bool, samples: int) -> np.ndarray:
    """Points of one leg from one end of c0 to the other end of c1, blending the two curves."""
    lam = np.linspace(0.0, 1.0, samples + 1)
    q = lam if forward else 1.0 - lam
    p0 = np.array([c0.interpolate(x, normalized=True).coords[0] for x in q])
    p1 = np.array([c1.interpolate(x, normalized=True).coords[0] for x in q])
    return (1.0 - lam)[:, None] * p0 + lam[:, None] * p1


def plan(region: Polygon, guide: LineString, spec: StrategySpec) -> Draft:
    pp = plan_passes(region, guide, spec.spacing)
    t0, t1 = pp.passes[0].t, pp.passes[-1].t
    band = t1 - t0
    legs = max(1, math.ceil(band / (spec.swipe_advance * spec.spacing) - 1e-6))
    curves = []
    for k in range(legs + 1):
        t = t0 + band * k / legs
        pts = offset_piece(pp.guide, t, pp.region)
        curves.append(_shortened(pts if pts is not None else pp.passes[0].points, spec.spacing / 2.0))
    out = [np.asarray(curves[0].coords[0])[None]]
    for k in range(legs):
        samples = 1 if pp.straight else max(2, math.ceil(curves[k].length / (spec.spacing / 2.0)))
        out.append(_leg(curves[k], curves[k + 1], k % 2 == 0, samples)[1:])
    pts = extend_ends(np.vstack(out), spec.extension_before, spec.extension_after)
    return Draft(pts, np.ones(len(pts) - 1, dtype=bool))
