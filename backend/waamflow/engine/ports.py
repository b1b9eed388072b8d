"""Port types: what may flow along an edge. One table for the catalog, validation and the GUI."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class PortType:
    name: str
    color: str  # GUI handle colour
    description: str


PORT_TYPES: dict[str, PortType] = {
    t.name: t
    for t in (
        PortType("mesh", "#8d99ae", "A part: solid triangle mesh (MeshData) or extruded midsurface (Midsurface), mm."),
        PortType("layers", "#4cc9f0", "Sliced layers: Layered[Layer] (regions and midsurface curves per layer)."),
        PortType("sections", "#f72585", "Layer sections: Layered[LayerSections] (MPP segmentation, guides)."),
        PortType("toolpath", "#f8961e", "Section paths per layer: Layered[LayerPaths] (points, arc, speed, zones)."),
        PortType("features", "#90be6d", "Recognised thin-wall features (FeatureSet)."),
        PortType("simulation", "#577590", "Simulated robot motion (SimulationResult)."),
        PortType("program", "#43aa8b", "Robot/machine program text (Program)."),
        PortType(
            "coverage", "#e63946", "Bead coverage per layer and section: void, overlap, over-deposit (Layered[dict])."
        ),
        PortType("report", "#6c757d", "A JSON-able report another node or the GUI reads (dict)."),
        PortType(
            "bead-model", "#9d4edd", "Bead width and height as functions of wire feed and travel speed (BeadFit)."
        ),
    )
}


@dataclass(frozen=True)
class Port:
    """A named, typed input or output of a node. `optional` inputs may stay unconnected."""

    name: str
    type: str
    description: str = ""
    optional: bool = False

    def __post_init__(self) -> None:
        if self.type not in PORT_TYPES:
            raise ValueError(f"unknown port type {self.type!r}")

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "type": self.type,
            "description": self.description,
            "optional": self.optional,
            "color": PORT_TYPES[self.type].color,
        }
