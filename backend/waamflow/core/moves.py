"""The whole part program as one flat move list — the common input of simulation and post-processors.

`flatten(toolpath)` walks layers → sections in deposition order and emits, for each section, its
arc-OFF approach (travel) points, then its deposition points. Consecutive sections are joined by
an arc-OFF travel segment (from the previous section's last point through the next section's
`approach` points to its first point).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .model import LayerPaths, Layered

TRAVEL = 0
DEPOSIT = 1


@dataclass(frozen=True, eq=False)
class Moves:
    """A flat polyline with per-segment attributes (all arrays of length n_points - 1 unless noted).

    points: (n, 3) float world mm. tool_axis: (n, 3) unit vectors torch → part.
    kind: int8 TRAVEL/DEPOSIT. arc: bool arc ON. inside: bool inside the section region.
    speed: float mm/s programmed (NaN for travel = use the machine's travel speed).
    layer: int layer index. section: int index into `section_keys`. zone: int index into
    `zone_ids` (-1 for travel). dwell_before: (n,) float s dwell at each point before moving on
    (the interlayer dwell, at the next layer's first point). Zone dwells (e.g. after ignition)
    stay in `zone_params[...]["dwell"]`: their placement is the post-processor's/simulator's call.
    dwell_notes: point index → why it dwells there (`LayerPaths.dwell_note`).
    section_tools: section index → (tool, tool_params) of post-deposition tool sections
    (`SectionPath.tool`); deposition sections are absent.
    """

    points: np.ndarray
    tool_axis: np.ndarray
    kind: np.ndarray
    arc: np.ndarray
    inside: np.ndarray
    speed: np.ndarray
    layer: np.ndarray
    section: np.ndarray
    zone: np.ndarray
    dwell_before: np.ndarray
    section_keys: tuple[str, ...]
    zone_ids: tuple[str, ...]
    zone_params: dict[tuple[int, int], dict[str, float]]  # (section idx, zone idx) → params
    layer_z: dict[int, float]
    dwell_notes: dict[int, str] = field(default_factory=dict)
    section_tools: dict[int, tuple[str, dict[str, float]]] = field(default_factory=dict)

    @property
    def segment_lengths(self) -> np.ndarray:
        return np.asarray(np.linalg.norm(np.diff(self.points, axis=0), axis=1))

    def __len__(self) -> int:
        return len(self.points)


def flatten(toolpath: Layered[LayerPaths] | list[LayerPaths]) -> Moves:
    """Flatten a toolpath into `Moves` (see module doc). Layers that are None (partial runs) are skipped."""
    pts: list[np.ndarray] = []
    axes: list[np.ndarray] = []
    seg: dict[str, list[Any]] = {k: [] for k in ("kind", "arc", "inside", "speed", "layer", "section", "zone")}
    dwell: list[float] = []
    section_keys: list[str] = []
    zone_ids: list[str] = []
    zone_index: dict[str, int] = {}
    zone_params: dict[tuple[int, int], dict[str, float]] = {}
    layer_z: dict[int, float] = {}
    pending_dwell = 0.0
    pending_notes: list[str] = []
    dwell_notes: dict[int, str] = {}
    section_tools: dict[int, tuple[str, dict[str, float]]] = {}
    down = np.array([0.0, 0.0, -1.0])

    items = toolpath.items if isinstance(toolpath, Layered) else toolpath
    for lp in items:
        if lp is None:
            continue
        layer_z[lp.index] = float(lp.layer.z)
        for sp in lp.sections:
            if len(sp.points) < 2:
                continue
            s_idx = len(section_keys)
            section_keys.append(sp.key)
            if sp.tool:
                section_tools[s_idx] = (sp.tool, dict(sp.tool_params))
            # travel: previous end → approach → first point
            travel_pts = [] if sp.approach is None else list(np.asarray(sp.approach, dtype=float))
            travel_pts.append(np.asarray(sp.points[0], dtype=float))
            if pts:
                _add_segments(seg, TRAVEL, False, False, np.nan, lp.index, s_idx, -1, len(travel_pts))
                pts.append(np.array(travel_pts))
                axes.append(np.tile(down, (len(travel_pts), 1)))
                dwell.extend([0.0] * len(travel_pts))
                dwell[-1] += pending_dwell
            elif sp.tool and len(travel_pts) > 1:
                # a tool (roller) starts from its approach above the part, never straight onto it
                pts.append(np.array(travel_pts))
                axes.append(np.tile(down, (len(travel_pts), 1)))
                _add_segments(seg, TRAVEL, False, False, np.nan, lp.index, s_idx, -1, len(travel_pts) - 1)
                dwell.extend([0.0] * (len(travel_pts) - 1) + [pending_dwell])
            else:
                pts.append(np.array(travel_pts[-1:]))
                axes.append(down[None, :])
                dwell.append(pending_dwell)
            if pending_dwell > 0 and pending_notes:
                dwell_notes[len(dwell) - 1] = "; ".join(pending_notes)
            pending_dwell = 0.0
            pending_notes = []
            # deposition
            zones = sp.zone if sp.zone else ("",) * (len(sp.points) - 1)
            z_idx = []
            for z in zones:
                if z not in zone_index:
                    zone_index[z] = len(zone_ids)
                    zone_ids.append(z)
                z_idx.append(zone_index[z])
                zone_params.setdefault((s_idx, zone_index[z]), dict(sp.zone_params.get(z, {})))
            _add_segments(
                seg, DEPOSIT, sp.arc, sp.inside, sp.speed, lp.index, s_idx, np.array(z_idx), len(sp.points) - 1
            )
            pts.append(np.asarray(sp.points[1:], dtype=float))
            ax = np.tile(down, (len(sp.points), 1)) if sp.tool_axis is None else np.asarray(sp.tool_axis, dtype=float)
            axes[-1] = np.vstack([axes[-1][:-1], ax[:1]])
            axes.append(ax[1:])
            dwell.extend([0.0] * (len(sp.points) - 1))
        pending_dwell += float(lp.dwell_after_s)
        if lp.dwell_after_s > 0 and lp.dwell_note:
            pending_notes.append(lp.dwell_note)

    return _assemble(pts, axes, seg, dwell, section_keys, zone_ids, zone_params, layer_z, dwell_notes, section_tools)


def _add_segments(
    seg: dict[str, list[Any]], kind: int, arc: Any, inside: Any, speed: Any, layer: int, section: int, zone: Any, n: int
) -> None:
    """Append n segments' attributes to `seg` (`flatten`): a scalar is repeated, an array taken as is."""
    seg["kind"].append(np.full(n, kind, dtype=np.int8))
    seg["arc"].append(np.asarray(arc, dtype=bool).reshape(-1) if np.ndim(arc) else np.full(n, bool(arc)))
    seg["inside"].append(np.asarray(inside, dtype=bool).reshape(-1) if np.ndim(inside) else np.full(n, bool(inside)))
    seg["speed"].append(np.asarray(speed, dtype=float).reshape(-1) if np.ndim(speed) else np.full(n, float(speed)))
    seg["layer"].append(np.full(n, layer, dtype=np.int32))
    seg["section"].append(np.full(n, section, dtype=np.int32))
    seg["zone"].append(
        np.asarray(zone, dtype=np.int32).reshape(-1) if np.ndim(zone) else np.full(n, zone, dtype=np.int32)
    )


def _assemble(
    pts: list[np.ndarray],
    axes: list[np.ndarray],
    seg: dict[str, list[Any]],
    dwell: list[float],
    section_keys: list[str],
    zone_ids: list[str],
    zone_params: dict[tuple[int, int], dict[str, float]],
    layer_z: dict[int, float],
    dwell_notes: dict[int, str],
    section_tools: dict[int, tuple[str, dict[str, float]]],
) -> Moves:
    """The `Moves` of `flatten`'s lists (empty Moves when no section had two points)."""
    if not pts:
        empty = np.zeros(0)
        return Moves(
            np.zeros((0, 3)),
            np.zeros((0, 3)),
            empty.astype(np.int8),
            empty.astype(bool),
            empty.astype(bool),
            empty,
            empty.astype(np.int32),
            empty.astype(np.int32),
            empty.astype(np.int32),
            empty,
            (),
            (),
            {},
            {},
        )
    cat = {k: (np.concatenate(v) if v else np.zeros(0)) for k, v in seg.items()}
    return Moves(
        points=np.vstack(pts),
        tool_axis=np.vstack(axes),
        kind=cat["kind"].astype(np.int8),
        arc=cat["arc"].astype(bool),
        inside=cat["inside"].astype(bool),
        speed=cat["speed"].astype(float),
        layer=cat["layer"].astype(np.int32),
        section=cat["section"].astype(np.int32),
        zone=cat["zone"].astype(np.int32),
        dwell_before=np.asarray(dwell, dtype=float),
        section_keys=tuple(section_keys),
        zone_ids=tuple(zone_ids),
        zone_params=zone_params,
        layer_z=layer_z,
        dwell_notes=dwell_notes,
        section_tools=section_tools,
    )
