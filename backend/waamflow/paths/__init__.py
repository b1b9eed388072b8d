"""Strategy kernels: fill a section polygon with a deposition path (pure: numpy + shapely).

`plan_section(region, guide, spec) -> Path2D`; `PATTERNS` names the fill patterns: the MPP
study's oscillate and parallel (Michel et al. 2019) and the robot study's raster, semicircular,
triangular, rectangular, spiral and swiping (da Silva Viola et al. 2023).
"""

from .frame import pass_layout
from .registry import PATTERNS, plan_section
from .spec import Path2D, StrategySpec

__all__ = ["PATTERNS", "Path2D", "StrategySpec", "pass_layout", "plan_section"]
