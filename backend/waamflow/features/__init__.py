"""Thin-walled parts (Venturini et al. 2018): feature recognition by valence and feature strategies.

recognition: midsurface curves → features (free ends, junctions, crossings, tubulars).
junctions: the junction points of the curves, their branches and valence → kind.
walls: features → one bead pass per wall entity (crossing circles, free-end extensions).
fillets: corner paths turned on the fillet radius; fillet corners the beads leave empty.
tubular: helical / aligned / scattered laps of tubulars.
"""

from .recognition import (
    FEATURE_KINDS,
    FeatureSet,
    RecognitionSpec,
    features_for_layer,
    join_collinear,
    recognise,
    recognise_layers,
)
from .tubular import aligned_loop, helix, scattered_loop
from .walls import LayerWalls, WallPass, WallSpec, crossing_bounds, crossing_geometry, crossing_window, plan_layer_walls

__all__ = [
    "FEATURE_KINDS",
    "FeatureSet",
    "RecognitionSpec",
    "features_for_layer",
    "join_collinear",
    "recognise",
    "recognise_layers",
    "aligned_loop",
    "helix",
    "scattered_loop",
    "LayerWalls",
    "WallPass",
    "WallSpec",
    "crossing_bounds",
    "crossing_geometry",
    "crossing_window",
    "plan_layer_walls",
]
