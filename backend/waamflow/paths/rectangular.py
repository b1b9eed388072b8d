"""Rectangular (robot study; reconstructed): boustrophedon that stays inside the section.

The study only says the links are rectangular and inside the OR and gives the programmed length
(small OR: 217.600 mm). Reconstruction: the study's boundary margin W_bound is applied on every
side, not only across the passes — passes are clipped to the region shrunk by W_bound (mitred),
joined at alternating ends by straight links (a W_WB step on a rectangle, hence "rectangular").
The arc is struck on the section boundary: the first pass starts with a lead-in along the pass from
the boundary, and the last pass ends with a lead-out to the boundary.
Small OR: 5 × (43 − 2·1.89) + 4 × 4.43 + 2 × 1.89 = 217.600 mm (exact). Run-ups (extension_before
/after) are added to the lead-in and lead-out only, so the fill itself stays inside the section.
Passes follow a curved guide (its offsets).
"""

from __future__ import annotations

import numpy as np
from shapely.geometry import LineString, Polygon

from .flags import Draft, extend_ends
from .links import boustrophedon
from .passes import end_direction, plan_passes, to_boundary
from .spec import StrategySpec


def plan(region: Polygon, guide: LineString, spec: StrategySpec) -> Draft:
    margin = plan_passes(region, guide, spec.spacing).margin
    pp = plan_passes(region, guide, spec.spacing, inset=margin)
    pts = boustrophedon(pp, lambda a, b, tau: []).points
    lead_in = to_boundary(region, pts[0], end_direction(pts))
    lead_out = to_boundary(region, pts[-1], end_direction(pts, at_start=False))
    pts = np.vstack([lead_in[None], pts, lead_out[None]])
    keep = np.r_[True, np.hypot(*np.diff(pts, axis=0).T) > 1e-9]  # no zero-length lead-in/out
    pts = extend_ends(pts[keep], spec.extension_before, spec.extension_after)
    return Draft(pts, np.ones(len(pts) - 1, dtype=bool))
