"""The `Program` value: what a post-processor produces and the `program` port carries."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True, eq=False)
class Program:
    """A machine/robot program as text files.

    format: "gcode" | "krl" | "rapid" | "inform" | "tp" | "csv" | "printpoints".
    files: artifact suffix → file text, e.g. {"gcode": ...}, {"src": ..., "dat": ...,
    "L003.src": ..., "L003.dat": ...}; written as `file_names(node id)` says.
    stats: summary numbers (layers, points, motions, arc_on_count, deposition_length_mm,
    travel_length_mm, dwell_total_s, estimated_time_s, ...).
    weld_issues: zones whose weld data the program writes empty, zero or incomplete.
    """

    format: str
    files: dict[str, str]
    stats: dict[str, Any] = field(default_factory=dict)
    weld_issues: tuple = ()  # common.WeldDataIssue: zones whose weld data is empty or zero (krl arctech, rapid)
    name: str = ""  # KRL / RAPID: the program identifier its files are named after ("" = node id)
    # the cell the program was written for, as JSON ("" = none named): the preflight turns the
    # positioner angles the program states into the part's orientation in the world (weld_position)
    cell: str = ""

    def file_names(self, node_id: str) -> dict[str, str]:
        """File key → the file's name. G-code, CSV, print points: `<node id>.<key>`. KRL and RAPID
        (KRL requires file name = DEF name; RAPID modules named like their files): the program
        name, `<name>.<key>` for the main program ("src", "dat", "mod") and `<name>_<part>.<ext>`
        for a part "<part>.<ext>" (a subprogram or module, e.g. "L003.src" → `post_L003.src`,
        holding `DEF post_L003`; INFORM `POST_L003.JBI`, TP `POST_L003.LS` and the schedule table
        `POST_SCHED.CSV`). A valid node id without a program_name keeps `post.src`."""
        if not self.name or self.format not in ("krl", "rapid", "inform", "tp"):
            return {k: f"{node_id}.{k}" for k in self.files}
        out = {}
        for k in self.files:
            part, _, ext = k.rpartition(".")
            out[k] = f"{self.name}_{part}.{ext}" if part else f"{self.name}.{ext}"
        return out

    @property
    def main_suffix(self) -> str:
        """Suffix of the file a user opens first (the main program)."""
        return {
            "gcode": "gcode",
            "krl": "src",
            "rapid": "mod",
            "inform": "JBI",
            "tp": "LS",
            "csv": "csv",
            "printpoints": "printpoints.json",
        }[self.format]
