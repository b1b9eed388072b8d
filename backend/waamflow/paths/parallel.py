"""Parallel (MPP, Michel et al. 2019, §strategies): equidistant passes parallel to the guide,
linked at alternating ends; follows curved guides.

The section's extent across the guide (t_min..t_max, measured on normals every W_WB/2 mm along the
guide) gives the pass count and boundary margin by the study's rule (`pass_layout`); pass k is the
guide offset by t_min + W_bound + k·W_WB (the guide is first extended tangentially so every offset
reaches the boundary), clipped to the section from its first entry to its last exit. Passes
alternate in direction and are joined by straight links; each pass gets the run-ups.
"""

from __future__ import annotations

from shapely.geometry import LineString, Polygon

from .flags import Draft
from .links import boustrophedon
from .passes import plan_passes
from .spec import StrategySpec


def plan(region: Polygon, guide: LineString, spec: StrategySpec) -> Draft:
    return boustrophedon(
        plan_passes(region, guide, spec.spacing), lambda a, b, tau: [], spec.extension_before, spec.extension_after
    )
