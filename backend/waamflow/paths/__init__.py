"""Strategy kernels: fill a section polygon with a deposition path (pure: numpy + shapely).

`plan_section(region, guide, spec) -> Path2D` (layer-local mm; guide None = long axis of the
region's minimum rotated rectangle). `PATTERNS` maps names to kernels; adding a pattern is one
module with `plan(region, guide, spec) -> Draft` plus one line in `registry.PATTERNS`.

Patterns (programmed lengths on the robot study's small objective rectangle 43 × 21.5 mm,
W_WB 4.43 mm: ours / published):

- oscillate (MPP, Michel et al. 2019): weave across the guide, constant step along it, amplitude =
  local width − bead width; follows curved guides.
- parallel (MPP): equidistant offsets of the guide, linked at alternating ends. 232.72 mm.
- raster (da Silva Viola et al. 2023): all passes one way, arc OFF on the diagonal returns.
  387.910 / 387.910.
- semicircular: boustrophedon with G1 half-circle links outside. 242.795 / 242.603 (+0.08 %).
- triangular θ: isosceles links outside with apex θ. 45°: 261.305 / 261.301; 60°: 250.440 / 250.437.
- rectangular (reconstructed): inset by W_bound on all sides, straight links, lead-in/out from the
  boundary. 217.600 / 217.600.
- spiral (reconstructed): inward offset rings W_WB apart from a corner, centre pass, lead-in.
  215.710 / 215.710.
- swiping (reconstructed): zig-zag legs W_WB/2 short of the ends advancing W_WB/3 per leg.
  463.179 / 464.246 (−0.23 %).

Pass count and boundary margin everywhere come from the study's rule (`pass_layout`). Passes are
offsets of the guide, so every pass pattern follows a curved guide. Paths are split where they cross
the section boundary; each segment carries `inside` and `arc` (arc_outside "off" switches the arc at
every crossing). See each kernel module for its construction.
"""

from .frame import pass_layout
from .registry import PATTERNS, plan_section
from .spec import Path2D, StrategySpec

__all__ = ["PATTERNS", "Path2D", "StrategySpec", "pass_layout", "plan_section"]
