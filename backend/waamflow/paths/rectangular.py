"""Rectangular (robot study; reconstructed): boustrophedon that stays inside the section.

The study only says the links are rectangular and inside the OR and gives the programmed length
(small OR: 217.600 mm). Reconstruction: the study's boundary margin W_bound is applied on every
side, not only across the passes — passes are the chords of the region shrunk by W_bound (mitred),
joined at alternating ends by straight links (a W_WB step on a rectangle, hence "rectangular").
The arc is struck on the section boundary: the first pass starts with a lead-in along the pass from
the boundary, and the last pass ends with a lead-out to the boundary.
Small OR: 5 × (43 − 2·1.89) + 4 × 4.43 + 2 × 1.89 = 217.600 mm (exact). Run-ups (extension_before
/after) are added to the lead-in and lead-out only, so the fill itself stays inside the section.
"""

from __future__ import annotations

import numpy as np
from shapely.geometry import LineString, Polygon

from .flags import Draft, extend_ends
from .frame import chord, plan_passes
from .links import boustrophedon
from .spec import StrategySpec


def plan(region: Polygon, guide: LineString | None, spec: StrategySpec) -> Draft:
    probe = plan_passes(region, guide, spec.spacing)
    pp = plan_passes(region, guide, spec.spacing, inset=probe.margin)
    d = boustrophedon(pp, lambda a, b, side: [])
    pts = d.points
    first, last = pp.passes[0], pp.passes[-1]
    c0 = chord(pp.local_region, first.t)
    c1 = chord(pp.local_region, last.t)
    lead_in = pp.frame.to_world(np.array([[c0[0], first.t]]))
    end_fwd = (len(pp.passes) - 1) % 2 == 0
    lead_out = pp.frame.to_world(np.array([[c1[1] if end_fwd else c1[0], last.t]]))
    pts = np.vstack([lead_in, pts, lead_out])
    pts = extend_ends(_dedupe_ends(pts), spec.extension_before, spec.extension_after)
    return Draft(pts, np.ones(len(pts) - 1, dtype=bool))


def _dedupe_ends(pts: np.ndarray) -> np.ndarray:
    """Drop a lead-in/out of zero length (pass already on the boundary) so run-ups have a direction."""
    keep = np.ones(len(pts), dtype=bool)
    if np.allclose(pts[0], pts[1], atol=1e-9):
        keep[0] = False
    if np.allclose(pts[-1], pts[-2], atol=1e-9):
        keep[-1] = False
    return pts[keep]
