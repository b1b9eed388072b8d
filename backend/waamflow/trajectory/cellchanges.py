"""Cell changes the `auto` positioner plan suggests when a layer has no passing candidate.

Each kind of change — the part turned on a 1-axis table, a shipped 2-axis cell with the same arm,
a riser under the part, a longer torch, the robot base moved away from the positioner — is applied
to the cell's JSON data (`modified_cell`) and the whole plan re-run on the modified cell
(`trajectory.cellplan.plan_auto`); per kind the smallest change that passes every layer is
suggested (`suggest_changes`). Units: mm, deg.
"""

from __future__ import annotations

import numpy as np

from .cell import Cell
from .collide import BEAD_HALF_MM

RISERS_MM = (50.0, 100.0, 150.0, 200.0, 250.0, 300.0, 400.0)
TORCH_EXTENSIONS_MM = (100.0, 200.0)
BASE_SHIFTS_MM = (100.0, 200.0, 300.0, 400.0, 600.0)


def suggest_changes(
    cell: Cell, moves, arm, limits, step_mm, step_deg, collision_step_mm, collisions, failed: dict | None = None
) -> list[dict]:
    """Cell changes whose `auto` plan passes every layer (each re-planned from scratch); per kind
    the smallest that works."""
    from .cell import load_cell, shipped_cells
    from .cellplan import plan_auto  # the plan imports this module
    from .kinematics import load_arm

    out = []
    base = cell.model_dump(mode="json")

    def works(data: dict, arm_=None) -> bool:
        c = Cell.model_validate(data)
        c._meshes = cell._meshes
        a = arm_ or arm
        args = (c, moves, a, limits, step_mm, step_deg, collision_step_mm, collisions)
        if (
            failed is not None
            and failed.get("reason") == "no candidate"
            and not plan_auto(*args, suggest=False, only=failed["layer"], quick=True).ok
        ):
            return False  # the layer that failed still fails: no need for the whole plan
        return plan_auto(*args, suggest=False).ok

    if cell.axes == 1:
        for yaw in (90.0, -90.0):
            ch = {"change": "turn the part on the table", "yaw_deg": yaw}
            if works(modified_cell(base, ch, moves)):
                ch["text"] = f"turn the part {yaw:+g}° about the table axis (work_frame yaw + {yaw:g}°)"
                out.append({**ch, "verified": True})
                break
        for name in shipped_cells():
            try:
                other = load_cell(name)
            except Exception:  # a shipped cell that does not load is no suggestion
                continue
            if other.axes == 2 and other.robot_urdf == cell.robot_urdf:
                a2 = load_arm(other.robot_urdf, tuple(other.tool.tcp_mm), home_deg=other.robot_home_deg)
                if plan_auto(
                    other.load_meshes(),
                    moves,
                    a2,
                    limits,
                    step_mm,
                    step_deg,
                    collision_step_mm,
                    collisions,
                    suggest=False,
                ).ok:
                    out.append(
                        {
                            "change": "2-axis positioner",
                            "cell": name,
                            "verified": True,
                            "text": f"a 2-axis tilt/rotate positioner: the shipped cell {name}",
                        }
                    )
                    break
    for h in RISERS_MM:
        ch = {"change": "riser", "riser_mm": h}
        if works(modified_cell(base, ch, moves)):
            out.append(
                {
                    **ch,
                    "verified": True,
                    "text": f"a riser of {h:g} mm under the part (work frame +{h:g} mm on the table)",
                }
            )
            break
    for ext in TORCH_EXTENSIONS_MM:
        ch = {"change": "longer torch", "extension_mm": ext}
        d = modified_cell(base, ch, moves)
        a2 = load_arm(cell.robot_urdf, tuple(d["tool"]["tcp_mm"]), home_deg=cell.robot_home_deg)
        if works(d, a2):
            out.append(
                {**ch, "verified": True, "text": f"a torch {ext:g} mm longer (TCP at {d['tool']['tcp_mm'][2]:g} mm)"}
            )
            break
    for sh in BASE_SHIFTS_MM:
        ch = {"change": "robot base moved", "shift_mm": sh}
        d = modified_cell(base, ch, moves)
        if d["robot_base"] == base["robot_base"]:
            break
        if works(d):
            out.append(
                {
                    **ch,
                    "verified": True,
                    "text": f"the robot base {sh:g} mm further from the positioner (at "
                    f"{', '.join(f'{v:g}' for v in d['robot_base']['xyz_mm'])} mm)",
                }
            )
            break
    return out


def modified_cell(cell: dict, change: dict, moves) -> dict:
    """A cell (as JSON data) with one suggested change applied: `riser` (riser_mm: the work frame
    raised on the table and a cylinder under the part, as wide as its first layer's beads), `longer torch`
    (extension_mm: TCP and torch shapes moved along the torch, a neck-wide cylinder in the gap),
    `robot base moved` (shift_mm: away from the positioner base, horizontally), `turn the part on
    the table` (yaw_deg: added to the work frame's yaw)."""
    d = _copy(cell)
    kind = change["change"]
    if kind == "riser":
        h = float(change["riser_mm"])
        P = np.asarray(moves.points, float)
        lay = np.asarray(moves.layer)
        first = P[np.flatnonzero(lay == lay.min())] if len(lay) else P
        foot = (float(np.hypot(first[:, 0], first[:, 1]).max()) if len(first) else 30.0) + BEAD_HALF_MM
        w = d["work_frame"]["xyz_mm"]
        d["work_frame"]["xyz_mm"] = [w[0], w[1], w[2] + h]
        d["positioner"]["shapes"].append(
            {
                "name": "riser",
                "kind": "cylinder",
                "size_mm": [foot, foot, h],
                "xyz_mm": [w[0], w[1], w[2] + h / 2 - 1.0],
            }
        )
    elif kind == "longer torch":
        ext = float(change["extension_mm"])
        tcp = d["tool"]["tcp_mm"]
        d["tool"]["tcp_mm"] = [tcp[0], tcp[1], tcp[2] + ext]
        shapes = d["tool"]["shapes"]
        r = max([s["size_mm"][0] for s in shapes if s["kind"] == "cylinder"] or [25.0])
        for s in shapes:
            s["xyz_mm"] = [s["xyz_mm"][0], s["xyz_mm"][1], s["xyz_mm"][2] + ext]
        shapes.append({"name": "extension", "kind": "cylinder", "size_mm": [r, r, ext], "xyz_mm": [0.0, 0.0, ext / 2]})
    elif kind == "robot base moved":
        pb = np.asarray(d["positioner"]["base"]["xyz_mm"], float) if d.get("positioner") else np.zeros(3)
        rb = np.asarray(d["robot_base"]["xyz_mm"], float)
        away = (rb - pb)[:2]
        if np.linalg.norm(away) > 1e-6:
            away = away / np.linalg.norm(away) * float(change["shift_mm"])
            d["robot_base"]["xyz_mm"] = [float(rb[0] + away[0]), float(rb[1] + away[1]), float(rb[2])]
    elif kind == "turn the part on the table":
        d["work_frame"]["yaw_deg"] = (d["work_frame"]["yaw_deg"] + float(change["yaw_deg"]) + 180.0) % 360.0 - 180.0
    else:
        raise ValueError(f"unknown cell change {kind!r}")
    return d


def _copy(d: dict) -> dict:
    import json

    return json.loads(json.dumps(d))
