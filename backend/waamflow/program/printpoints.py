"""Print points JSON in the layout of compas_slicer (`PrintOrganizer.output_printpoints_dict`).

compas_slicer (ETH Zürich, compas-dev/compas_slicer) is what robotic AM groups already feed to
their robot drivers (compas_rrc, compas_fab); its print-points file is a flat JSON object
`{"0": {...}, "1": {...}, ...}`, one entry per point in print order, each the `PrintPoint.to_data()`
dictionary. We write one entry per toolpath point (= `Moves.points`, the samples every
post-processor renders) with its keys:

* ``point`` [x, y, z] mm; ``layer_height`` mm — the layer's thickness, or the local height
  r·Δθ on a fan (curved) layer;
* ``up_vector`` — unit vector from the part towards the torch (−tool axis);
  ``mesh_normal`` — unit vector normal to the path in the layer, ``up_vector × tangent``
  (the wall's side; compas_slicer's up vector is ``normal × (p − p_next)``, the same triad);
* ``frame`` ``{"point", "xaxis", "yaxis"}`` — compas' Frame data as compas_slicer builds it,
  xaxis = up × normal (= −tangent), yaxis = normal;
* ``extruder_toggle`` — arc on during the motion *leaving* this point (to the next one; the
  last point's is off), as compas_slicer sets it (a path's points true, its last one false) and
  draws it (a bead from point i to i+1 where point i's toggle is true); ``velocity`` mm/s of the
  motion *to* this point (a robot target's speed; arc-off travel: the travel speed);
  ``wait_time`` s — the torch waits at the point, the arc as its toggle says: the ignition and
  zone dwells (arc on) where the run ignites or the zone starts, the interlayer dwell (arc off)
  at the point before the run's first (the travel to it leaves from there); ``blend_radius``
  mm — 0 where the program makes an exact stop (arc switches, waits, the end), else the blend
  distance;
* ``closest_support_pt`` null, ``distance_to_support`` null, ``is_feasible`` true (not computed
  here), ``attributes`` ``{"zone", "tangent"}``;
* beside compas_slicer's keys: ``layer`` (index) and ``section`` (key) of the motion to the point.

A driver's loop over the points: move to the point (its velocity, its blend radius), set the
arc to its toggle, wait its wait_time. Until 2026-11-27 the toggle was the motion *arriving* at
the point (the cutter-location CSV's convention, `program/cl.py`): read as compas_slicer reads
it, every run lost its first segment and welded the travel after its last point, and the
interlayer dwell was one wait with the ignition dwell at the run's start, arc on.
"""

from __future__ import annotations

import json

import numpy as np

from ..core.model import LayerPaths, Layered
from ..core.moves import Moves
from ..core.errors import PlanningError
from .plan import ArcOff, ArcOn, Dwell, Motion, Plan

_X = np.array([1.0, 0.0, 0.0])


def point_layer_heights(toolpath: Layered[LayerPaths] | None, moves: Moves) -> np.ndarray:
    """(n,) layer height (mm) at every point of `moves`: the layer's thickness, the local r·Δθ on
    a fan layer; NaN when the layers are unknown (a bare move list)."""
    n = len(moves.points)
    out = np.full(n, np.nan)
    if toolpath is None or n == 0:
        return out
    from ..curved.fan import local_height, to_local

    layers = {
        lp.index: lp.layer for lp in (toolpath.items if isinstance(toolpath, Layered) else toolpath) if lp is not None
    }
    seg_layer = _arriving_segment_values(moves, moves.layer)
    for li in np.unique(seg_layer):
        layer = layers.get(int(li))
        if layer is None:
            continue
        idx = np.flatnonzero(seg_layer == li)
        out[idx] = local_height(layer, to_local(layer, moves.points[idx]))
    return out


def _arriving_segment_values(moves: Moves, seg_values: np.ndarray) -> np.ndarray:
    """Per point, the value of the segment arriving at it (point 0: the first segment's)."""
    n = len(moves.points)
    if n < 2:
        return np.zeros(n, dtype=np.asarray(seg_values).dtype)
    return np.concatenate([seg_values[:1], seg_values])


def _unit(v: np.ndarray) -> np.ndarray:
    nrm = np.linalg.norm(v, axis=1, keepdims=True)
    return np.where(nrm > 1e-12, v / np.maximum(nrm, 1e-12), 0.0)


def frames(moves: Moves) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(up, tangent, normal), each (n, 3) unit: up = −tool axis, tangent = direction of the path
    at the point (the leaving segment; the arriving one at the end or where the leaving one is
    parallel to up), normal = up × tangent."""
    pts = moves.points
    n = len(pts)
    up = _unit(-np.asarray(moves.tool_axis, float).reshape(-1, 3))
    if n < 2:
        return up, np.tile(_X, (n, 1)), np.cross(up, np.tile(_X, (n, 1)))
    seg = _unit(np.diff(pts, axis=0))
    leave = np.vstack([seg, seg[-1:]])
    arrive = np.vstack([seg[:1], seg])
    tangent = leave.copy()
    for cand in (arrive, np.tile(_X, (n, 1)), np.tile(np.array([0.0, 1.0, 0.0]), (n, 1))):
        # a tangent along `up` (a vertical travel move) has no direction in the layer: take the next candidate
        bad = np.linalg.norm(tangent - np.sum(tangent * up, axis=1, keepdims=True) * up, axis=1) < 1e-6
        if not bad.any():
            break
        tangent[bad] = cand[bad]
    tangent = _unit(tangent - np.sum(tangent * up, axis=1, keepdims=True) * up)
    normal = _unit(np.cross(up, tangent))
    return up, tangent, normal


def _toggles_and_waits(plan: Plan) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(extruder_toggle, wait_time s, exact stop) per point of the plan, as compas_slicer reads
    them: the toggle of point i is the arc of the motion leaving it (segment i → i+1; the last
    point's is off), and a wait at point i is spent with the arc as that toggle says. A dwell
    whose arc state differs from its point's toggle (the interlayer dwell, arc off, at the point
    where the next run ignites) waits at the point before, where the arc is off, the arriving
    travel leaving from there."""
    moves = plan.moves
    n = len(moves.points)
    toggle = np.zeros(n, bool)
    if n >= 2:
        toggle[:-1] = np.asarray(moves.arc, bool)
    wait = np.zeros(n)
    stop = np.zeros(n, bool)
    arc = False
    for s in plan.steps:
        if isinstance(s, ArcOn):
            arc = True
        elif isinstance(s, ArcOff):
            arc = False
        elif isinstance(s, Dwell):
            at = s.point
            if arc != bool(toggle[at]):
                at -= 1
                if at < 0 or bool(toggle[at]) != arc:
                    raise PlanningError(
                        f"print points cannot hold the {s.reason} dwell of {s.seconds:g} s at point {s.point} "
                        f"(arc {'on' if arc else 'off'}): the arc of the motion leaving that point is "
                        f"{'on' if toggle[s.point] else 'off'} and no point before it has the arc "
                        f"{'on' if arc else 'off'}; write this program in another format, or move the dwell"
                    )
            wait[at] += s.seconds
            stop[at] = True
        elif isinstance(s, Motion):
            if s.circular:
                raise ValueError("print points need one motion per point: switch arc fitting off")
            stop[s.end] |= s.stop
    return toggle, wait, stop


def print_points(
    plan: Plan, layer_heights: np.ndarray, travel_speed: float, blend_distance: float, decimals: int = 4
) -> dict[str, dict]:
    """The print-points dictionary (see module doc) of a program plan without fitted arcs."""
    moves = plan.moves
    pts = moves.points
    n = len(pts)
    toggle, wait, stop = _toggles_and_waits(plan)
    up, tangent, normal = frames(moves)
    xaxis = np.cross(up, normal)
    if n >= 2:
        speed = _arriving_segment_values(
            moves, np.where(np.isfinite(moves.speed) & (moves.speed > 0), moves.speed, travel_speed)
        )
        speed[0] = travel_speed
        layer = _arriving_segment_values(moves, moves.layer)
        section = _arriving_segment_values(moves, moves.section)
        zone = _arriving_segment_values(moves, moves.zone)
    else:
        speed = np.full(n, travel_speed)
        layer = section = zone = np.zeros(n, int)

    def r(v) -> list[float]:
        return [round(float(x), decimals) + 0.0 for x in v]

    out: dict[str, dict] = {}
    for i in range(n):
        z = int(zone[i])
        lh = float(layer_heights[i]) if i < len(layer_heights) and np.isfinite(layer_heights[i]) else None
        out[str(i)] = {
            "point": r(pts[i]),
            "layer_height": None if lh is None else round(lh, decimals),
            "mesh_normal": r(normal[i]),
            "up_vector": r(up[i]),
            "frame": {"point": r(pts[i]), "xaxis": r(xaxis[i]), "yaxis": r(normal[i])},
            "extruder_toggle": bool(toggle[i]),
            "velocity": round(float(speed[i]), decimals),
            "wait_time": round(float(wait[i]), 6),
            "blend_radius": 0.0 if stop[i] else float(blend_distance),
            "closest_support_pt": None,
            "distance_to_support": None,
            "is_feasible": True,
            "attributes": {
                "zone": moves.zone_ids[z] if i > 0 and 0 <= z < len(moves.zone_ids) else "",
                "tangent": r(tangent[i]),
            },
            "layer": int(layer[i]),
            "section": moves.section_keys[int(section[i])] if moves.section_keys else "",
        }
    return out


def write_print_points(
    plan: Plan, layer_heights: np.ndarray, travel_speed: float = 100.0, blend_distance: float = 1.0
) -> str:
    """The print-points JSON text (one line per point, keys in compas_slicer's order)."""
    pp = print_points(plan, layer_heights, travel_speed, blend_distance)
    body = ",\n".join(f"  {json.dumps(k)}: {json.dumps(v, allow_nan=False)}" for k, v in pp.items())
    return "{\n" + body + "\n}\n" if body else "{}\n"
