"""The `Program` value: what a post-processor produces and the `program` port carries."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True, eq=False)
class Program:
    """A machine/robot program as text files.

    format: "gcode" | "krl" | "rapid" | "csv" | "printpoints".
    files: artifact suffix → file text, e.g. {"gcode": ...}, {"src": ..., "dat": ...,
    "L003.src": ..., "L003.dat": ...}; the engine writes each as `<node id>.<suffix>`.
    stats: summary numbers (layers, points, motions, arc_on_count, deposition_length_mm,
    travel_length_mm, dwell_total_s, estimated_time_s, ...).
    weld_issues: zones whose weld data the program writes empty, zero or incomplete.
    """

    format: str
    files: dict[str, str]
    stats: dict[str, Any] = field(default_factory=dict)
    weld_issues: tuple = ()   # common.WeldDataIssue: zones whose weld data is empty or zero (krl arctech, rapid)

    @property
    def main_suffix(self) -> str:
        """Suffix of the file a user opens first (the main program)."""
        return {"gcode": "gcode", "krl": "src", "rapid": "mod", "csv": "csv", "printpoints": "printpoints.json"}[self.format]
