"""Figures read off a simulated result the way the study read them off its measurements
(robot-study.md, "Identified kinematic parameters"): acceleration phases, pass transitions, the
time over a stretch of path, corner errors. `calibrate` fits the profile to them.

Split off `calibrate.py` for the structure rule: these read a simulation, they fit nothing.
"""

from __future__ import annotations

import numpy as np

from .simulate import SimulationResult


def accel_phases(result: SimulationResult, speed: float, frac: float = 0.99) -> dict[str, float]:
    """Initial acceleration / final deceleration of a single start-stop move: times (s) and
    lengths (mm) from rest to `frac`·speed and back (the study's T/L_init_accel, T/L_final_decel)."""
    tr = result.trace
    v, t, s = tr["speed"], tr["t"], tr["s"]
    moving = np.flatnonzero(v > 1e-3)
    i0, i1 = moving[0] - 1 if moving[0] > 0 else 0, moving[-1] + 1
    reach = np.flatnonzero(v >= frac * speed)
    ia, ib = reach[0], reach[-1]
    return {
        "T_init_accel": float(t[ia] - t[i0]),
        "L_init_accel": float(s[ia] - s[i0]),
        "T_final_decel": float(t[min(i1, len(t) - 1)] - t[ib]),
        "L_final_decel": float(s[min(i1, len(s) - 1)] - s[ib]),
    }


def identify_passes(result: SimulationResult, speed: float, frac: float = 0.99) -> dict[str, float]:
    """The study's identified kinematic parameters, read off a simulated pass program the way the
    authors read them off their measurement (robot-study.md, "Identified kinematic parameters").

    Passes = the programmed segments inside the OR (straight, in order); constant speed = at least
    `frac`·speed. T/L_init_accel: motion start → first constant speed; T/L_final_decel: last
    constant speed → stop. Between consecutive passes: L_decel = the pass length left after its
    constant speed, L_accel = the next pass's length before its constant speed (mm, along the
    pass) and T_trans = the time from the one to the other (means over the transitions)."""
    tr = result.trace
    v, t, s, seg = tr["speed"], tr["t"], tr["s"], tr["segment"]
    xyz = np.column_stack([tr["x"], tr["y"], tr["z"]])
    P = result.programmed
    passes = np.unique(seg[tr["inside"]])
    fast = v >= frac * speed
    first, last, l_acc, l_dec = [], [], [], []
    for k in passes:
        idx = np.flatnonzero((seg == k) & fast)
        if not len(idx):
            raise ValueError(f"pass {int(k)} never reaches {frac:.0%} of {speed:g} mm/s")
        u = (P[k + 1] - P[k]) / np.linalg.norm(P[k + 1] - P[k])
        first.append(idx[0])
        last.append(idx[-1])
        l_acc.append(float((xyz[idx[0]] - P[k]) @ u))
        l_dec.append(float((P[k + 1] - xyz[idx[-1]]) @ u))
    moving = np.flatnonzero(v > 1e-3)
    i0 = max(moving[0] - 1, 0)
    i1 = min(moving[-1] + 1, len(t) - 1)
    out = {
        "T_init_accel": float(t[first[0]] - t[i0]),
        "L_init_accel": float(s[first[0]] - s[i0]),
        "T_final_decel": float(t[i1] - t[last[-1]]),
        "L_final_decel": float(s[i1] - s[last[-1]]),
        "passes": float(len(passes)),
    }
    if len(passes) > 1:
        out["L_decel"] = float(np.mean(l_dec[:-1]))
        out["L_accel"] = float(np.mean(l_acc[1:]))
        out["T_trans"] = float(np.mean(t[first[1:]] - t[last[:-1]]))
    return out


def stretch_time(result: SimulationResult, l_decel: float, l_accel: float) -> float:
    """Mean time (s) the simulated motion takes from `l_decel` mm before the end of one pass to
    `l_accel` mm after the start of the next (passes = programmed segments inside the OR): the
    study's T_trans measured over the study's own stretch of path, so it does not hang on where
    a speed threshold is crossed."""
    tr = result.trace
    t, seg = tr["t"], tr["segment"]
    xyz = np.column_stack([tr["x"], tr["y"], tr["z"]])
    P = result.programmed
    passes = np.unique(seg[tr["inside"]])
    out = []
    for k0, k1 in zip(passes[:-1], passes[1:]):
        u0 = (P[k0 + 1] - P[k0]) / np.linalg.norm(P[k0 + 1] - P[k0])
        u1 = (P[k1 + 1] - P[k1]) / np.linalg.norm(P[k1 + 1] - P[k1])
        i0 = np.flatnonzero(seg == k0)
        i1 = np.flatnonzero(seg == k1)
        left = (P[k0 + 1] - xyz[i0]) @ u0  # pass length still ahead, decreasing
        done = (xyz[i1] - P[k1]) @ u1  # pass length behind, increasing
        ta = np.interp(-l_decel, -left, t[i0]) if left.min() < l_decel else t[i0[-1]]
        tb = np.interp(l_accel, done, t[i1]) if done.max() > l_accel else t[i1[-1]]
        out.append(tb - ta)
    return float(np.mean(out))


def corner_error(result: SimulationResult, lo: float, hi: float) -> float:
    """The largest corner error (mm) over the corners whose interior angle is in [lo, hi] deg."""
    c = result.corners
    m = (c["interior_deg"] >= lo) & (c["interior_deg"] <= hi)
    return float(np.max(c["error_mm"][m])) if m.any() else float("nan")
