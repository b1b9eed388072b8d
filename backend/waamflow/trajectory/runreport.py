"""What a simulated program's run reports: the contract's `<node>.simulation.json` (`simulation_json`),
the per-segment deposit table (`deposit_csv`) and the tables of the kinematics check behind them — the
positioner's metrics and stretches (`_positioner_report`) and the range and peak speed of every arm
and positioner axis (`_axes_report`).

Split from `trajectory.run` (issue 27): that module solves (program settings, kinematics, the
positioner plan, the simulation); this one turns the results into the reported files. Every name
stays importable from `trajectory.run`. Units: mm, s, deg.
"""

from __future__ import annotations

import math
from itertools import chain
from typing import Any, Callable

import numpy as np

from ..core.moves import Moves
from .simulate import METRIC_UNITS, SimOptions, SimulationResult


def _positioner_report(cell, moves: Moves, ang, clipped, cap, turn_s, speed) -> tuple[dict, list[dict]]:
    """Positioner metrics (per axis range, largest step) and its stretches: `axis_limit` where the
    policy's angle was clipped into the axis range, `axis_speed` where an axis speed caps the path
    speed (per layer and section; s in mm of programmed path)."""
    from .cell import positioner_kin
    from .kinematics import _stretches

    m = ang.shape[1]
    out: dict[str, float] = {}
    for j in range(m):
        out[f"positioner_e{j + 1}_min_deg"] = float(ang[:, j].min())
        out[f"positioner_e{j + 1}_max_deg"] = float(ang[:, j].max())
    out["positioner_max_step_deg"] = float(np.abs(np.diff(ang, axis=0)).max(initial=0.0))
    finite = np.isfinite(cap)
    out["positioner_min_speed_cap_mm_s"] = float(cap[finite].min()) if finite.any() else math.inf
    out["positioner_speed_capped_segments"] = float(np.count_nonzero(cap < speed))
    out["positioner_turn_in_place_s"] = float(turn_s[moves.segment_lengths <= 1e-6].sum())
    if m == 0:
        return out, []
    names = [f"E{j + 1}" for j in range(m)]
    pk = positioner_kin(cell.positioner.urdf)
    s_pt = np.concatenate([[0.0], np.cumsum(moves.segment_lengths)])
    seg_pt = np.minimum(np.arange(len(s_pt)), len(s_pt) - 2)
    issues = []
    for st in _stretches("axis_limit", clipped, s_pt, seg_pt, moves.layer, moves.section, moves.section_keys):
        k = np.flatnonzero(clipped & (s_pt >= st["s_from"]) & (s_pt <= st["s_to"]))
        hit = [
            names[j]
            for j in range(m)
            if np.any(np.isclose(ang[k, j], pk.lower_deg[j]) | np.isclose(ang[k, j], pk.upper_deg[j]))
        ]
        st.update(axes=hit, detail=f"{', '.join(hit) or 'axis'} clipped into its range: the layer is not turned flat")
        issues.append(st)
    flag = np.zeros(len(s_pt), bool)
    slow = np.flatnonzero(cap < speed)
    flag[slow] = True
    for st in _stretches("axis_speed", flag, s_pt, seg_pt, moves.layer, moves.section, moves.section_keys):
        segs = slow[(s_pt[slow] >= st["s_from"]) & (s_pt[slow] <= st["s_to"])]
        d = np.abs(ang[segs + 1] - ang[segs]) / pk.speed_deg_s
        st["axes"] = sorted({names[j] for j in d.argmax(axis=1)})
        st["detail"] = (
            f"path speed capped to {cap[segs].min():.1f} mm/s by positioner speed "
            f"({', '.join(st['axes'])}: {', '.join(f'{v:.0f}' for v in pk.speed_deg_s)} deg/s)"
        )
        issues.append(st)
    return out, issues


def _axes_report(arm, ks, cap, speed, cell, ang, moves: Moves) -> list[dict]:
    """Per axis (arm A1..A6, positioner E1..): range used, limits, speed limit and the largest
    speed reached at the simulated path speed (programmed, capped), all in deg and deg/s."""
    v = np.minimum(speed, cap)
    rows = []
    ds = np.diff(ks.s)
    k = np.flatnonzero(ds > 1e-9)
    vs = v[ks.seg[k]]
    for j in range(arm.model.nq):
        qd = np.abs(np.diff(ks.q[:, j]))[k] / ds[k] * vs
        rows.append(
            {
                "axis": f"A{j + 1}",
                "joint": arm.model.names[j + 1],
                "min_deg": round(float(np.degrees(ks.q[:, j].min())), 4),
                "max_deg": round(float(np.degrees(ks.q[:, j].max())), 4),
                "lower_deg": round(float(np.degrees(arm.lower[j])), 4),
                "upper_deg": round(float(np.degrees(arm.upper[j])), 4),
                "speed_limit_deg_s": round(float(np.degrees(arm.qd_max[j])), 4),
                "peak_speed_deg_s": round(float(np.degrees(qd.max(initial=0.0))), 4),
            }
        )
    if cell is not None and ang is not None and ang.shape[1]:
        from .cell import positioner_kin

        pk = positioner_kin(cell.positioner.urdf)
        L = moves.segment_lengths
        for j in range(ang.shape[1]):
            d = np.abs(np.diff(ang[:, j]))
            moving = L > 1e-6
            sp = np.where(moving, d / np.maximum(L, 1e-12) * v, np.where(d > 0, pk.speed_deg_s[j], 0.0))
            rows.append(
                {
                    "axis": f"E{j + 1}",
                    "joint": pk.names[j],
                    "min_deg": round(float(ang[:, j].min()), 4),
                    "max_deg": round(float(ang[:, j].max()), 4),
                    "lower_deg": round(float(pk.lower_deg[j]), 4),
                    "upper_deg": round(float(pk.upper_deg[j]), 4),
                    "speed_limit_deg_s": round(float(pk.speed_deg_s[j]), 4),
                    "peak_speed_deg_s": round(float(sp.max(initial=0.0)), 4),
                }
            )
    return rows


MAX_CORNERS = 5000  # rows of simulation.json's corner table


def _clean(v):
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return round(v, 6) if isinstance(v, float) else v


def simulation_json(res: SimulationResult, opt: SimOptions) -> dict:
    """The contract's `<node>.simulation.json`: metrics at top level plus units, estimate, warnings."""
    out = {k: _clean(float(v)) for k, v in res.metrics.items()}
    out["units"] = {k: METRIC_UNITS.get(k, "") for k in res.metrics}
    out["estimate"] = {k: _clean(float(v)) for k, v in res.estimate.items()}
    out["estimate_total_time_s"] = out["estimate"].get("total_time_s")
    out["warnings"] = [{"message": m, "layer": l, "section": s} for m, l, s in res.warnings]
    if "collision_count" in res.metrics:
        out["collision_count"] = int(res.metrics["collision_count"])
        out["collisions"] = [
            {
                "layer": c.layer,
                "section": c.section,
                "bodies": list(c.bodies),
                "point_mm": list(c.point_mm),
                "s_mm": round(c.s_mm, 3),
            }
            for c in res.collisions
        ]
    if res.kinematics:
        out["axes"] = res.kinematics.get("axes", [])
        out["kinematics_issues"] = [
            {k: (round(v, 3) if isinstance(v, float) else v) for k, v in it.items()}
            for it in res.kinematics.get("issues", [])
        ]
        if res.kinematics.get("positioner_plan"):
            out["positioner_plan"] = res.kinematics["positioner_plan"]
    out["robot_profile"] = res.profile.get("name")
    junction = opt.blend == "junction" or res.profile.get("junction_deviation_mm", 0.0) > 0
    out["settings"] = {
        "cdis_mm": None if junction else opt.cdis,
        "blend": "junction" if junction else opt.blend,
        "junction_deviation_mm": res.profile.get("junction_deviation_mm") if junction else None,
        "lookahead_blocks": res.profile.get("lookahead_blocks") if junction else None,
        "travel_speed_mm_s": opt.travel_speed or res.profile.get("travel_speed"),
        "controller": opt.controller or None,
        "ignition_dwells": (len(opt.ignition_dwells_s) if opt.ignition_dwells_s is not None else None),
        "ignition_dwell_total_s": (round(sum(opt.ignition_dwells_s), 6) if opt.ignition_dwells_s is not None else None),
        "wire_feed_mm3_s": opt.wire_feed_mm3_s,
        "speed_override_mm_s": opt.speed_override,
        "interpolation_cycle_s": opt.interpolation_cycle_s or res.profile.get("interpolation_cycle_s"),
    }
    c = res.corners
    keys = ("vertex", "interior_deg", "error_mm", "min_speed_mm_s", "mean_speed_mm_s")
    # the first MAX_CORNERS only, as Python numbers (a 39k-vertex path: 0.1 s for the whole table before)
    cols = [np.asarray(c.get(k, []))[:MAX_CORNERS].tolist() for k in keys]
    out["corners"] = [
        {
            "vertex": int(v),
            "interior_deg": round(float(a), 3),
            "error_mm": round(float(e), 4),
            "min_speed_mm_s": _clean(float(sp)),
            "mean_speed_mm_s": _clean(float(mv)),
        }
        for v, a, e, sp, mv in zip(*cols)
    ]
    return out


DEPOSIT_SPLIT_SEGMENTS = 5000  # segments from which `start_deposit_files` hands them to a worker


def start_deposit_files(
    res: SimulationResult, submit: Callable[..., Any] | None = None
) -> Callable[[], tuple[str, str]]:
    """deposit.csv (`deposit_csv`) and deposit.svg (`compensate.deposit_svg`) in two steps: call,
    then call what it returns for the texts. With submit (`Context.submit`) and a long program
    they are written in a worker from the first call on (here when it fails): the same texts."""
    task = (res.deposit, tuple(res.section_keys))
    n = len(res.deposit.get("length_mm", ()))
    fut = submit(deposit_files, task) if submit is not None and n >= DEPOSIT_SPLIT_SEGMENTS else None

    def finish() -> tuple[str, str]:
        if fut is not None:
            try:
                return fut.result()
            except Exception:  # the worker failed: written here
                pass
        return deposit_files(task)

    return finish


def deposit_files(task: tuple[dict, tuple[str, ...]]) -> tuple[str, str]:
    """(deposit.csv, deposit.svg) of a simulation's `deposit` and section keys."""
    from .compensate import deposit_svg  # compensate imports run, which imports this module

    deposit, keys = task
    return _deposit_csv(deposit, keys), deposit_svg(deposit)


def deposit_csv(res: SimulationResult) -> str:
    """Per programmed segment: where too much or too little metal lands (mm³ per mm of path)."""
    return _deposit_csv(res.deposit, res.section_keys)


def _deposit_csv(d: dict, keys) -> str:
    """`deposit_csv` of a deposit dict and the section keys: one % per run of rows with (or
    without: programmed deposit 0) a ratio, its Python numbers as the arguments — the text of
    one f-string per row (tests/trajectory/test_runreport.py), without a Python step per row."""
    layer = np.asarray(d["layer"]).tolist()
    sec = np.asarray(d["section"]).tolist()
    s_mm = np.asarray(d["s_mm"], float).tolist()
    length = np.asarray(d["length_mm"], float).tolist()
    arc = (np.asarray(d["arc"]) != 0).astype(int).tolist()  # bool(x): NaN is True, as x != 0
    prog_a = np.asarray(d["programmed_mm3_per_mm"], float)
    act_a = np.asarray(d["actual_mm3_per_mm"], float)
    n = min(len(layer), len(sec), len(s_mm), len(length), len(arc), len(prog_a), len(act_a))
    prog_a, act_a = prog_a[:n], act_a[:n]
    has = prog_a > 0  # NaN: no ratio
    with np.errstate(all="ignore"):  # inf / inf is NaN, as in Python
        ratio = np.divide(act_a, prog_a, out=np.zeros(n), where=has).tolist()
    names = [keys[k] if 0 <= k < len(keys) else "" for k in sec[:n]]
    cols = (range(n), layer, names, s_mm, length, arc, prog_a.tolist(), act_a.tolist(), ratio)
    row = "%d,%d,%s,%.3f,%.3f,%d,%.4f,%.4f,"
    fmt = {True: row + "%.4f\n", False: row + "%.0s\n"}  # %.0s: the unused ratio writes nothing
    out = ["segment,layer,section,s_mm,length_mm,arc,programmed_mm3_per_mm,actual_mm3_per_mm,ratio\n"]
    cuts = np.concatenate([[0], np.flatnonzero(has[1:] != has[:-1]) + 1, [n]]).tolist() if n else [0]
    flags = has.tolist()
    for a, b in zip(cuts[:-1], cuts[1:]):
        for i in range(a, b, _DEPOSIT_BLOCK):
            j = min(b, i + _DEPOSIT_BLOCK)
            out.append((fmt[flags[a]] * (j - i)) % tuple(chain.from_iterable(zip(*(c[i:j] for c in cols)))))
    return "".join(out)


_DEPOSIT_BLOCK = 4096  # rows per % call in `_deposit_csv`
