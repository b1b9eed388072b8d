"""waamflow — node-graph CAM for Wire + Arc Additive Manufacturing.

Pipeline (folders follow the data):
mesh/sketch (geometry) → layers (slicing) → sections (sections) → paths (paths)
→ zoned toolpath (zoning, sequencing) → trajectory (trajectory) → program (program).
Nodes (nodes/) are thin adapters over those pure kernels; engine/ runs graphs of them.
"""

__version__ = "0.1.0"
