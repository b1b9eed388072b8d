"""Deposition process parameters: the names, units and bounds of what a zone carries.

One table shared by the XML parameter file, the toolpath, simulation, post-processors and the GUI.
Names carry their unit. Bounds are sanity limits for GMAW/CMT/plasma WAAM, not process windows.
The MPP study's example values: TS 6 mm/s, WFS 10 m/min, 200 A.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ProcessParameter:
    name: str          # element name in the XML, key in SectionPath.zone_params
    unit: str          # unit as written in the XML `unit` attribute
    label: str
    minimum: float
    maximum: float
    description: str


ZONE_PARAMETERS: tuple[ProcessParameter, ...] = (
    ProcessParameter("current", "A", "Current", 0.0, 1000.0, "Welding current."),
    ProcessParameter("voltage", "V", "Voltage", 0.0, 100.0, "Arc voltage."),
    ProcessParameter("wire_feed_speed", "m/min", "Wire feed speed", 0.0, 40.0,
                     "Wire feed speed (WFS), metres per minute as on the power source."),
    ProcessParameter("travel_speed", "mm/s", "Travel speed", 0.1, 500.0,
                     "Torch travel speed along the path; becomes the toolpath's programmed speed."),
    ProcessParameter("dwell", "s", "Dwell", 0.0, 600.0,
                     "Dwell at the start of the zone (e.g. after ignition) before moving."),
    ProcessParameter("job", "", "Job number", 0.0, 9999.0,
                     "Power-source job/program number (synergic line), optional."),
)

PARAMETERS_BY_NAME = {p.name: p for p in ZONE_PARAMETERS}
