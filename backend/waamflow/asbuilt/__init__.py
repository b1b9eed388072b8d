"""As built vs as planned: layer scans in, deviation per path point, the next layer adapted, and a
process simulator to run the loop without a cell (issue #29).

    toolpath ─layer_track→ Track ─┬─ scan.read_points / read_heights → Scan ─register→ ─measure→ Measured
                                  └─ adapt.plan_speeds(beneath, gain) → speeds ─adapted_layer→ LayerPaths → post
    sim.simulate_build(toolpath, "open" | "closed") runs the whole loop on simulated beads and scans.
"""

from .adapt import Adaptation, Window, adapted_layer, beneath, carry, plan_speeds, planned_heights
from .scan import Measured, Registration, Scan, ScanError, measure, read_heights, read_points, register
from .session import BuildSession
from .sim import BuildLog, Disturbance, simulate_build, synth_scan
from .track import Track, layer_track

__all__ = [
    "Adaptation",
    "BuildLog",
    "BuildSession",
    "Disturbance",
    "Measured",
    "Registration",
    "Scan",
    "ScanError",
    "Track",
    "Window",
    "adapted_layer",
    "beneath",
    "carry",
    "layer_track",
    "measure",
    "plan_speeds",
    "planned_heights",
    "read_heights",
    "read_points",
    "register",
    "simulate_build",
    "synth_scan",
]
