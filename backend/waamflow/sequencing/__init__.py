"""Layer path (MPP step 6): section order, arc-OFF travel between sections, interlayer dwell."""

from .layer_path import last_point, nearest_order, sequence_layer, sequence_part, travel_length

__all__ = ["last_point", "nearest_order", "sequence_layer", "sequence_part", "travel_length"]
