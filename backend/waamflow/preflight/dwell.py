"""Metal laid while the torch stands with the arc on (`dwell_metal`; the wire balance's dwells).

The wire feeds while the arc burns, moving or not (V̇ = WFS · π d²/4 · η, robot-modelling notes):
an ignition dwell, a zone's dwell inside a run, a `WAIT`/`G4` with the arc on lay their metal in
one spot. Before, the wire balance counted the moves only: mpp-cross's 24 ignition dwells of
0.5 s were 1.9 % of its metal (601.7 mm³ of 32,309), curved-duct's 5.2 %, uncounted, and a dwell
typed 50 s for 0.5 s — the metal of 400 mm of bead on one spot — passed "ok". Each dwell's metal
counts in its layer's wire (and the part's ratio); one that lays as much metal as more than
`dwell_warn_widths` bead widths of the program's bead (its median wire feed / speed, as
`local_deposit` takes it) warns, more than `dwell_fail_widths` fails. A dwell with no wire feed
of its own (an ArcWare seam without one) feeds its run's first move's.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from ..core.process import deposit_rate_mm3_s
from .read import ProgramRead, Run


def dwell_metal(
    prog: ProgramRead, layers: Sequence[tuple[int, list[Run]]], s: Any
) -> list[tuple[float, int, Run, int]]:
    """(metal mm³, layer position, run, dwell number) of each arc-ON dwell whose wire feed is known
    (its own, else its run's first move's); a dwell of a run that never moved (dropped: no run)
    counts in the layer of the nearest run point."""
    if not prog.dwells or not prog.runs:
        return []
    layer_of = {id(r): li for li, (_idx, rs) in enumerate(layers) for r in rs}
    out = []
    for n, (p, secs, wfs, run) in enumerate(prog.dwells):
        run = run if run is not None else _nearest_run(prog, p)
        feed = wfs if math.isfinite(wfs) else (float(run.wfs[0]) if len(run.wfs) else math.nan)
        if math.isfinite(feed) and feed > 0 and id(run) in layer_of:
            out.append(
                (
                    secs * deposit_rate_mm3_s(feed, s.wire_diameter_mm, s.deposition_efficiency),
                    layer_of[id(run)],
                    run,
                    n,
                )
            )
    return out


def _nearest_run(prog: ProgramRead, p: np.ndarray) -> Run:
    return min(prog.runs, key=lambda r: float(np.min(np.linalg.norm(r.points - p, axis=1))))


def dwell_problems(
    prog: ProgramRead,
    layers: Sequence[tuple[int, list[Run]]],
    metal: list[tuple[float, int, Run, int]],
    feed_per_mm: float,
    width: float,
    out: dict,
    rep: Any,
    s: Any,
) -> None:
    """The `dwell_metal` problem: the dwell laying the most metal, as bead widths of the program's
    bead (its median wire feed / speed, `deposit.feed_per_mm`; out["dwell_max_widths"]), beyond
    `s.dwell_warn_widths` (warn) or `s.dwell_fail_widths`."""
    if s.dwell_metal == "off" or not metal or not width > 0 or not math.isfinite(feed_per_mm):
        return
    mm = deposit_rate_mm3_s(feed_per_mm, s.wire_diameter_mm, s.deposition_efficiency)  # metal per mm of bead
    vol, li, run, n = max(metal, key=lambda m: m[0])
    widths = vol / mm / width
    out["dwell_max_widths"] = round(widths, 3)
    if widths <= s.dwell_warn_widths:
        return
    severity = s.dwell_metal if widths > s.dwell_fail_widths else "warn"
    p, secs = prog.dwells[n][0], prog.dwells[n][1]
    over = sum(1 for m in metal if m[0] / mm / width > s.dwell_warn_widths)
    rep.problem(
        "dwell_metal",
        severity,
        f"layer {layers[li][0]}: a {secs:g} s dwell with the arc on lays {vol:.0f} mm³ in one spot at "
        f"({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}), as much as {widths * width:.0f} mm of the bead ({widths:.1f} bead "
        f"widths; {over} dwell{'s' if over != 1 else ''} beyond {s.dwell_warn_widths:g}): a lump on the layer. "
        "Check the dwell's time and unit (s or ms) in the program and the zone's `dwell`",
        layer=layers[li][0],
        section=run.section,
        value=widths,
        limit=s.dwell_fail_widths if severity != "warn" else s.dwell_warn_widths,
        point=tuple(p),
    )
