"""The welding position each layer is deposited in, as the program sets the positioner (`weld_position`).

The curved-parts study deposits every layer flat: the positioner turns the part so that the layer's
build direction points straight up (gravity normal to the layer); a bead laid on a layer inclined
far off flat runs down its side. A program written for a cell states the positioner's angles on
its targets (KUKA E1/E2 of each E6POS, ABB's extax of each robtarget, Fanuc group 2's J1/J2, the
Yaskawa station's EC pulses over the post's `'pulse/deg`, G-code rotary words as the header maps
them); before this check the preflight read the points only, so a program with the tilt and turn
swapped, the tilt's sign flipped, radians where degrees belong or the positioner left at zero
passed "ok" while it would weld the duct's upper layers on their side.

Each layer's build direction in the part frame is torch.py's (`build_directions`, given: +z for planar
programs, a fan layer's plane normal; on a layer that is not flat, a helix or a conformal layer,
the direction at the point where a run sets the positioner, from the bead below it:
`local_directions`); the work frame's rotation at the angles the program states
(`Cell.work_pose`, the cell's own kinematics, not the plan's angles) turns it into the world, and
its angle from up is the layer's position: 0° flat. Every distinct set of angles a run states is
judged; angles outside the positioner's axis limits are a failure of their own (the controller
stops there). Programs that name no cell are not judged (the part's orientation in the world is
not known); a run that states no angles on a cell with a positioner is counted unjudged.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from .read import Run
from .torch import local_directions

_NOWHERE = np.full(3, np.nan)


def _angles_text(a: np.ndarray) -> str:
    return ", ".join(f"E{k + 1} {v:.3f}°" for k, v in enumerate(a))


class _Worst:
    """The layer deposited farthest off flat: (angle, layer index, run, angles, point)."""

    def __init__(self) -> None:
        self.angle = -1.0
        self.where: tuple[int, Run, np.ndarray, np.ndarray, np.ndarray] | None = None

    def offer(self, angle: float, idx: int, run: Run, ang: np.ndarray, point: np.ndarray, up: np.ndarray) -> None:
        if angle > self.angle:
            self.angle, self.where = angle, (idx, run, ang, point, up)


def weld_position_problems(
    layers: Sequence[tuple[int, list[Run]]],
    directions: np.ndarray,
    spacing: float | None,
    cell_json: str,
    out: dict,
    rep: Any,
    s: Any,
) -> None:
    """The `weld_position` problems (`s.weld_position`) of a program written for the cell
    `cell_json` (Program.cell; "" = none: not judged): positioner angles outside the axis limits
    (a failure), and the layer whose build direction lies farthest from up in the world, beyond
    `s.weld_position_warn_deg` (a warning) or `s.weld_position_fail_deg`. out: `weld_position_max_deg`
    (that angle), `weld_position_unjudged_runs` (runs whose layer has no build direction or that
    state no positioner angles, and each set of angles a run states with an axis missing).
    directions: each layer's build direction (torch.build_directions), spacing: the layers' (mm)."""
    if s.weld_position == "off" or not cell_json or not layers:
        return
    from ..core.errors import InputFileError
    from ..trajectory.cell import load_cell  # here: the positioner's kinematics (Pinocchio) only for a cell

    cell = load_cell("the program's cell", text=cell_json)
    m = cell.axes
    rotation: dict[tuple[float, ...], np.ndarray | None] = {}
    local = _state_directions(layers, directions, spacing, m)
    worst, unjudged, outside, silent, curved = _Worst(), 0, [], 0, 0
    for (idx, runs), d in zip(layers, directions):
        flat = bool(np.isfinite(d).all())
        for run in runs:
            states = run.ext if m else [(0, np.zeros(0))]
            silent += not states
            if not states:
                unjudged += 1
                continue
            for at, e in states:
                here = d if flat else local.get((id(run), min(at, len(run.points) - 1)), _NOWHERE)
                if not np.isfinite(here).all():
                    unjudged += 1
                    curved += 1
                    continue
                ang = np.asarray(e, float)[:m]
                if len(ang) < m or not np.isfinite(ang).all():
                    unjudged += 1
                    continue
                key = tuple(np.round(ang, 6).tolist())
                if key not in rotation:
                    try:
                        rotation[key] = cell.work_pose(ang)[0]
                    except InputFileError:  # outside the axis limits
                        rotation[key] = None
                R, p = rotation[key], run.points[min(at, len(run.points) - 1)]
                if R is None:
                    outside.append((idx, run, ang, p))
                    continue
                up = R @ here
                angle = float(np.degrees(np.arccos(np.clip(up[2], -1.0, 1.0))))
                worst.offer(angle, idx, run, ang, p, up)
    out["weld_position_unjudged_runs"] = unjudged
    if silent:
        out.setdefault("notes", []).append(
            f"{silent} arc-ON run{'s' if silent != 1 else ''} state{'' if silent != 1 else 's'} no positioner "
            f"angles on cell {cell.name}: the positioner stands where the controller left it, its welding position "
            "is not judged there"
        )
    if curved:
        out.setdefault("notes", []).append(
            f"{curved} positioner state{'s' if curved != 1 else ''} of arc-ON runs on layers that are not flat "
            "(a helix, a conformal layer) with no bead below (nor the plate) within reach: the welding "
            "position is not judged there"
        )
    if outside:
        idx, run, ang, p = outside[0]
        layers_out = sorted({o[0] for o in outside})
        rep.problem(
            "weld_position",
            s.weld_position,
            f"layer {idx}, section {run.section or '?'}: the program sets the positioner to {_angles_text(ang)}, "
            f"outside its axis limits (cell {cell.name}; {len(outside)} run state{'s' if len(outside) != 1 else ''} "
            f"in {len(layers_out)} layer{'s' if len(layers_out) != 1 else ''}): the controller stops there. Check "
            "the angles' axis order (E1 tilt, E2 turn), sign and unit (degrees) against the cell",
            layer=idx,
            section=run.section,
            point=tuple(p),
        )
    _report_worst(worst, cell.name, out, rep, s)


def _report_worst(worst: _Worst, cell_name: str, out: dict, rep: Any, s: Any) -> None:
    """`weld_position_max_deg` and the problem of the state deposited farthest off flat, if beyond
    the warning's angle."""
    if worst.where is None:
        return
    out["weld_position_max_deg"] = round(worst.angle, 2)
    if worst.angle <= s.weld_position_warn_deg:
        return
    idx, run, ang, p, up = worst.where
    severity = s.weld_position if worst.angle > s.weld_position_fail_deg else "warn"
    rep.problem(
        "weld_position",
        severity,
        f"layer {idx}, section {run.section or '?'}: deposited {worst.angle:.0f}° off the flat position (the "
        f"layer's build direction in the world ({up[0]:.2f}, {up[1]:.2f}, {up[2]:.2f}) under the positioner angles "
        f"the program states, {_angles_text(ang) or 'none'}, cell {cell_name}): the bead runs down the layer's side. "
        "Check the positioner angles in the program (axis order E1 tilt / E2 turn, sign, degrees) and the cell "
        "it was written for; a plan held at fixed angles needs the positioner policy auto or gravity",
        layer=idx,
        section=run.section,
        value=worst.angle,
        limit=s.weld_position_fail_deg if severity != "warn" else s.weld_position_warn_deg,
        point=tuple(p),
    )


def _state_directions(
    layers: Sequence[tuple[int, list[Run]]], directions: np.ndarray, spacing: float | None, m: int
) -> dict[tuple[int, int], np.ndarray]:
    """The build direction at the point of each positioner state of the runs on layers that are not
    flat (torch.local_directions: from the bead below it, or +z on the plate), by (id of the run,
    point index); nan where none is found."""
    if not spacing:
        return {}
    runs = [(k, r) for k, (_i, rs) in enumerate(layers) for r in rs]
    asks = [
        (j, min(at, len(r.points) - 1))
        for j, (k, r) in enumerate(runs)
        if not np.isfinite(directions[k]).all()
        for at, _e in (r.ext if m else [(0, None)])
    ]
    if not asks:
        return {}
    pts = np.array([runs[j][1].points[i] for j, i in asks])
    own, index = np.array(asks, int).T
    grow = local_directions(runs, pts, own, index, np.ones(len(asks), bool), spacing)
    return {(id(runs[j][1]), i): grow[n] for n, (j, i) in enumerate(asks)}
