"""Deposition process parameters: the names, units and bounds of what a zone carries.

One table shared by the XML parameter file, the toolpath, simulation, post-processors and the GUI.
Names carry their unit. Bounds are sanity limits for GMAW/CMT/plasma WAAM, not process windows.
The MPP study's example values: TS 6 mm/s, WFS 10 m/min, 200 A.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ProcessParameter:
    name: str  # element name in the XML, key in SectionPath.zone_params
    unit: str  # unit as written in the XML `unit` attribute
    label: str
    minimum: float
    maximum: float
    description: str


ZONE_PARAMETERS: tuple[ProcessParameter, ...] = (
    ProcessParameter("current", "A", "Current", 0.0, 1000.0, "Welding current."),
    ProcessParameter("voltage", "V", "Voltage", 0.0, 100.0, "Arc voltage."),
    ProcessParameter(
        "wire_feed_speed",
        "m/min",
        "Wire feed speed",
        0.0,
        40.0,
        "Wire feed speed (WFS), metres per minute as on the power source.",
    ),
    ProcessParameter(
        "travel_speed",
        "mm/s",
        "Travel speed",
        0.1,
        500.0,
        "Torch travel speed along the path; becomes the toolpath's programmed speed.",
    ),
    ProcessParameter(
        "dwell", "s", "Dwell", 0.0, 600.0, "Dwell at the start of the zone (e.g. after ignition) before moving."
    ),
    ProcessParameter(
        "job", "", "Job number", 0.0, 9999.0, "Power-source job/program number (synergic line), optional."
    ),
)

PARAMETERS_BY_NAME = {p.name: p for p in ZONE_PARAMETERS}


# ---- mass balance: wire fed vs metal in the part --------------------------------------------------
# Wire volume fed per second = WFS · π d²/4; of it, the deposition efficiency η ends in the part
# (GMAW/CMT with solid wire: spatter and fume losses of 2–8 %, η ≈ 0.95; Ding et al. 2015, Rodrigues
# et al. 2019). A single bead's cross-section is A = k · w · h (w width, h height): k = 2/3 for a
# parabolic cap, π/4 ≈ 0.785 for an elliptic one; WAAM beads on a previous layer measure 0.70–0.80
# (Xiong et al. 2013, Suryakumar 2011). With overlapping beads at step s, a layer of height h takes
# s · h per mm of path.
WIRE_DIAMETER_MM = 1.2  # the most common WAAM steel/aluminium wire
DEPOSITION_EFFICIENCY = 0.95  # stated, not fitted
BEAD_SHAPE_FACTOR = 0.75  # k in A = k·w·h, stated (between parabolic 0.667 and elliptic 0.785)


def wire_area_mm2(diameter_mm: float = WIRE_DIAMETER_MM) -> float:
    """Cross-section of the wire, mm²."""
    import math

    return math.pi * diameter_mm * diameter_mm / 4.0


def deposit_rate_mm3_s(
    wfs_m_min: float, diameter_mm: float = WIRE_DIAMETER_MM, efficiency: float = DEPOSITION_EFFICIENCY
) -> float:
    """Metal that ends in the part per second of arc time, mm³/s, for a wire feed in m/min."""
    return wfs_m_min * 1000.0 / 60.0 * wire_area_mm2(diameter_mm) * efficiency
