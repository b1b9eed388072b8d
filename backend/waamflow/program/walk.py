"""The statement walk the INFORM and TP writers share.

Both write a plan as numbered controller programs (`plan.chunk_steps`) of line motions with the
same rules: a comment at every layer and section start, the ignition dwell folded into the arc
start (the dialect writes it there, the plan's own ignition Dwell is then skipped), other dwells
as a comment and a wait, a post-deposition tool switched by its templates after the (exact-stop)
motion to its point, the travel speed for travel and unprogrammed motions, no circular motions.
What differs — comments, the weld at a zone change, the arc start and end, the wait, the motion
line and how a program numbers its positions — is the dialect's (`Dialect`).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from .common import num, short, tool_lines
from .plan import (
    ArcOff,
    ArcOn,
    Dwell,
    LayerStart,
    Motion,
    Plan,
    ProcessChange,
    SectionStart,
    StepChunk,
    ToolOff,
    ToolOn,
    ignition_dwell_after,
)


class Dialect(Protocol):
    """One controller language's lines for the steps of a plan."""

    name: str  # for messages ("INFORM", "TP")
    travel_speed: float  # mm/s: travel and motions without a programmed speed
    tool_on: str  # post-deposition tool templates (common.tool_lines)
    tool_off: str

    def comment(self, text: str) -> str: ...

    def process_change(self, st: ProcessChange, arc: bool) -> list[str]:
        """The lines of a zone change; `arc`: the arc is on (a change while welding)."""
        ...

    def arc_on(self, ignition_s: float) -> list[str]:
        """The arc start, holding the ignition dwell (s, 0: none) when the dialect writes it there."""
        ...

    def arc_off(self) -> list[str]: ...

    def wait(self, seconds: float) -> str: ...

    def start_program(self) -> None:
        """A new controller program begins: its position table is empty."""
        ...

    def motion(self, st: Motion, speed: float) -> str:
        """The motion line to st.end at `speed` mm/s (the point enters the program's positions)."""
        ...

    def positions(self) -> list[int]:
        """The current program's positions (indices into the plan's points), in table order."""
        ...


def walk_programs(
    plan: Plan, chunks: list[StepChunk], dialect: Dialect
) -> list[tuple[StepChunk, list[str], list[int]]]:
    """(chunk, lines, positions) of every controller program that has a line or a position, in
    order (see module doc)."""
    steps = plan.steps
    keys = plan.moves.section_keys
    c = dialect.comment
    out: list[tuple[StepChunk, list[str], list[int]]] = []
    arc = False
    skip_dwell = False
    for chunk in chunks:
        dialect.start_program()
        cur: list[str] = []
        for k in chunk.steps:
            st = steps[k]
            if isinstance(st, LayerStart):
                cur.append(c(f"layer {st.layer} z={num(st.z, 3)}"))
            elif isinstance(st, SectionStart):
                cur.append(c(f"section {keys[st.section]}"))
            elif isinstance(st, ProcessChange):
                cur += dialect.process_change(st, arc)
            elif isinstance(st, ArcOn):
                ign = ignition_dwell_after(steps, k)
                cur += dialect.arc_on(ign)
                skip_dwell = ign > 0
                arc = True
            elif isinstance(st, ArcOff):
                cur += dialect.arc_off()
                arc = False
            elif isinstance(st, Dwell):
                if st.reason == "ignition" and skip_dwell:
                    skip_dwell = False
                    continue
                cur.append(c(f"{st.reason} dwell {short(round(st.seconds, 3))} s"))
                cur.append(dialect.wait(st.seconds))
            elif isinstance(st, (ToolOn, ToolOff)):  # after the (exact-stop) motion to the point
                on = isinstance(st, ToolOn)
                cur.append(c(f"{st.tool} {'on' if on else 'off'}"))
                cur += tool_lines(
                    dialect.tool_on if on else dialect.tool_off, st.tool, st.params if isinstance(st, ToolOn) else {}
                )
            elif isinstance(st, Motion):
                if st.circular:
                    raise ValueError(f"{dialect.name}: circular motions are not written (plan with arc_tolerance 0)")
                v = dialect.travel_speed if st.mode == "travel" or not np.isfinite(st.speed) else st.speed
                cur.append(dialect.motion(st, v))
        pts = dialect.positions()
        if cur or pts:
            out.append((chunk, cur, pts))
    return out
