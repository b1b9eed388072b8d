"""The deposit's bottom: against the part's bottom and against the plate.

The plate is z = 0 of the program's frame: the substrate's top, where `mesh` `placement: on_plate`
puts a part and where every shipped example starts (first beads at z 1.5-2.3 mm). Two faults
passed the preflight before this check: a slice started above the part's bottom (a tube sliced
from `z_min` 4.5 mm: the first bead at z 6.0, 4.5 mm of the part never built and the bead laid on
nothing; the top, the coverage of the layers deposited and the wire balance, within 2 %, all
passed) and a part centred on the origin (as CAD often exports it: beads down to z -13.5, the
torch driven into the substrate).

- `bottom_gap` (fail): the lowest arc-ON point lies more than `bottom_gap_max_layers` layer
  heights above where a first layer on the part's bottom would (bottom + one layer height).
- `plate` (`s.plate`): a motion below z = 0 (arc ON or travel), or a part whose lowest point is
  more than `bottom_gap_max_layers` layer heights above the plate.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from .read.core import ProgramRead, Run

PLATE_TOL_MM = 0.01  # below z = 0 by more than a post's rounding (3 decimals) and a little


#: The bottom gap's advice, which `run_preflight` replaces when the plan has layers below the
#: deposit that weld nothing (preflight/__init__.py `_planned_empty`).
FROM_BOTTOM = ": slice from the part's bottom (clear the slice's `z_min`) or check for skipped layers"


def bottom_problems(
    part: Any,
    prog: ProgramRead,
    layers: Sequence[tuple[int, list[Run]]],
    h: float | None,
    out: dict,
    rep: Any,
    s: Any,
) -> None:
    """Add `deposit_bottom_mm` and `bottom_gap_mm` to `out` and the problems to `rep`. h: the
    typical layer height (None: not known, no gap is judged)."""
    low_run = min(prog.runs, key=lambda r: float(np.nanmin(r.points[:, 2])))
    k = int(np.nanargmin(low_run.points[:, 2]))
    low_pt = low_run.points[k]
    z_low = float(low_pt[2])
    out["deposit_bottom_mm"] = round(z_low, 3)
    gap = z_low - part.bottom - h if part is not None and h else None
    out["bottom_gap_mm"] = None if gap is None else round(gap, 3)
    where = {"layer": low_run.layer, "section": low_run.section}
    limit = s.bottom_gap_max_layers * h if h else None
    if gap is not None and limit is not None and gap > limit + 1e-6:
        first = layers[0][0] if layers else low_run.layer
        rep.problem(
            "bottom_gap",
            "fail",
            f"the deposit starts {gap:.2f} mm above the part's bottom ({part.bottom:.2f} mm): the first "
            f"deposited layer ({first}) lies at z = {z_low:.3f} mm where a first layer on the part's bottom "
            f"would lie at {part.bottom + h:.3f} mm, so the part below is never built and the first bead is "
            f"laid on nothing{FROM_BOTTOM}",
            value=gap,
            limit=limit,
            point=[round(float(v), 3) for v in low_pt],
            **where,
        )
    if s.plate == "off":
        return
    _below_plate(part, prog, low_run, low_pt, rep, s)
    if part is not None and limit is not None and part.bottom > limit + 1e-6:
        rep.problem(
            "plate",
            s.plate,
            f"the part's lowest point is {part.bottom:.2f} mm above the plate (z = 0 of the program's frame, the "
            f"substrate's top): the first bead (layer {low_run.layer}, z = {z_low:.3f} mm) is laid on nothing. "
            "Put the part on the plate (mesh `placement: on_plate`), or set the preflight's `plate` to off when "
            "the program's z = 0 is not the substrate's top (a build on an existing part)",
            value=part.bottom,
            limit=limit,
            point=[round(float(v), 3) for v in low_pt],
            **where,
        )


def _below_plate(part: Any, prog: ProgramRead, low_run: Run, low_pt: np.ndarray, rep: Any, s: Any) -> None:
    """The `plate` problem of a motion below z = 0, arc ON or travel, whichever goes lower."""
    z_arc = float(low_pt[2])
    z_travel = prog.travel_z_min
    if min(z_arc, z_travel) >= -PLATE_TOL_MM:
        return
    if z_arc <= z_travel:
        what = f"welds down to z = {z_arc:.3f} mm (layer {low_run.layer}, section {low_run.section})"
        pt, layer, section = low_pt, low_run.layer, low_run.section
    else:
        assert prog.travel_low is not None
        pt, layer = prog.travel_low
        section = None
        what = f"travels down to z = {z_travel:.3f} mm" + (f" (in layer {layer})" if layer is not None else "")
    if part is not None and part.bottom < -PLATE_TOL_MM:
        fix = (
            f"the part reaches z = {part.bottom:.3f} mm: put it on the plate (mesh `placement: on_plate`) or "
            "raise it (mesh `transform`)"
        )
    else:
        fix = "the part does not reach below z = 0: check the post-processor's frame and offsets"
    rep.problem(
        "plate",
        s.plate,
        f"the program {what}: below the plate (z = 0 of the program's frame, the substrate's top), into the "
        f"substrate; {fix}. Set the preflight's `plate` to off only when the program's z = 0 is not the substrate's top",
        layer=layer,
        section=section,
        value=min(z_arc, z_travel),
        limit=0.0,
        point=[round(float(v), 3) for v in pt],
    )
