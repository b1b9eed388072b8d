"""MPP segmentation: Building-Strategy masks cut layers into sections; guides give each its direction.

Pure kernels on shapely geometry (no engine imports). Source: Michel et al., "A modular path
planning solution for Wire + Arc Additive Manufacturing", RCIM 60 (2019), steps 2 and 3.
"""

from .guide import apply_guide, guide_crossings
from .mask import Mask, MaskSection, connected_sections, governing_mask, segment_layer

__all__ = [
    "Mask",
    "MaskSection",
    "apply_guide",
    "connected_sections",
    "governing_mask",
    "guide_crossings",
    "segment_layer",
]
