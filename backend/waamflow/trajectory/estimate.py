"""The study's closed-form cycle-time model — an instant estimate shown beside the simulation.

da Silva Viola et al. 2023 (robot-study.md, "The paper's cycle-time model"), for n passes of
length L at travel speed TS:

    T_total = T_init_accel + T_init_const + (n − 1)·T_trans + (n − 2)·T_straight_const
              + T_final_const + T_final_decel
    T_init_const     = (L − L_init_accel − L_decel)/TS
    T_straight_const = (L − L_accel − L_decel)/TS
    T_final_const    = (L − L_accel − L_final_decel)/TS

The kinematic parameters (T_init_accel, L_init_accel, L_decel, L_accel, T_trans, L_final_decel,
T_final_decel) were identified on the triangular 45° strategy at 10 and 40 mm/s, arc ON
throughout ("on") or OFF outside the OR ("off"); they live in the robot profile's `time_model`.
Other speeds interpolate linearly between the identified ones (clamped outside).

Keys are "<speed>_<protocol>" (any strategy) or "<speed>_<protocol>_<family>" (identified on
that strategy family, e.g. "40_on_triangular": `trace.identify_time_model` writes these from
the user's trace). A section of strategy family f uses f's entries when the profile has them, else
the generic ones, else the entries of the other families (noted); a protocol the profile has no
entry for at all falls back to the study's (`STUDY_TIME_MODEL`, triangular 45° on the KR 100),
with a note. The study identified its constants on triangular 45° only; the shipped profile's
generic entries are those.

For a general toolpath the model is applied per section, pass by pass: passes are maximal runs
of straight, collinear, arc-ON segments inside the section at least `min_pass_mm` long (long
enough to accelerate and stop: L_init_accel + L_final_decel at that speed), each with its own
length; everything between two passes is a transition, timed T_trans + (L_t − L_trans_ref)/TS
where L_trans_ref is the programmed length of the identification's link (triangular 45° with
W_WB = 4.43 mm: 2·2.215/sin 22.5° = 11.576 mm) — the paper's formula when all passes are equal
and every link is that triangle. A section without such passes (oscillate weaves, short zig-zags) has no pass
structure for the model: it is counted as one start-stop move, L/TS + T_init_accel + T_final_decel
− (L_init_accel + L_final_decel)/TS. Travel between sections is counted at the travel speed,
dwells as they are.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..core.moves import DEPOSIT, Moves
from . import study

KEYS = ("T_init_accel", "L_init_accel", "L_decel", "L_accel", "T_trans", "L_final_decel", "T_final_decel")

# the study's identification link: triangular 45° with W_WB = 4.43 mm (2·(W_WB/2)/sin 22.5°)
STUDY_L_TRANS_REF = 2 * (study.W_WB / 2) / math.sin(math.radians(22.5))
STUDY_TIME_MODEL = {f"{v}_{p}": {**vals, "L_trans_ref": STUDY_L_TRANS_REF} for (v, p), vals in study.IDENTIFIED.items()}


def strategy_family(strategy: str) -> str:
    """'triangular45' → 'triangular', 'semi-circular' → 'semicircular' (letters only, lower case)."""
    return re.sub(r"[^a-z]", "", strategy.lower())


def section_strategies(toolpath) -> tuple[str, ...]:
    """The strategy of each section of `core.moves.flatten(toolpath)`, in its section order."""
    from ..core.model import Layered

    items = toolpath.items if isinstance(toolpath, Layered) else toolpath
    return tuple(sp.strategy for lp in items if lp is not None for sp in lp.sections if len(sp.points) >= 2)


def cycle_time(n: int, L: float, TS: float, p: dict[str, float]) -> float:
    """The paper's T_total (s) for n ≥ 1 passes of length L (mm) at TS (mm/s)."""
    if n == 1:
        return p["T_init_accel"] + (L - p["L_init_accel"] - p["L_final_decel"]) / TS + p["T_final_decel"]
    t_init = (L - p["L_init_accel"] - p["L_decel"]) / TS
    t_str = (L - p["L_accel"] - p["L_decel"]) / TS
    t_fin = (L - p["L_accel"] - p["L_final_decel"]) / TS
    return p["T_init_accel"] + t_init + (n - 1) * p["T_trans"] + (n - 2) * t_str + t_fin + p["T_final_decel"]


def _entries(time_model: dict, protocol: str, family: str | None) -> tuple[dict[float, dict], str]:
    """(speed → entry, which) for protocol: family's entries, else generic, else other families'
    (`which` names the choice: "family", "generic" or "other:<families>")."""
    fam: dict[str, dict[float, dict]] = {}
    for key, vals in time_model.items():
        sp, prot, *rest = key.split("_")
        if prot == protocol:
            fam.setdefault(rest[0] if rest else "", {})[float(sp)] = vals
    if family and family in fam:
        return fam[family], "family"
    if "" in fam:
        return fam[""], "generic"
    if not fam:
        return {}, ""
    names = sorted(fam)
    table: dict[float, list] = {}
    for f in names:
        for v, vals in fam[f].items():
            table.setdefault(v, []).append(vals)
    return (
        {
            v: {
                k: float(np.mean([e[k] for e in es]))
                for k in es[0]
                if isinstance(es[0][k], (int, float)) and all(k in e for e in es)
            }
            for v, es in table.items()
        },
        "other:" + ",".join(names),
    )


def model_params(time_model: dict, speed: float, protocol: str, family: str | None = None) -> dict[str, float]:
    """Identified parameters at `speed` (mm/s) for protocol "on"/"off" (and strategy `family`:
    see the module doc for the choice of entries), interpolated in speed."""
    table, _ = _entries(time_model, protocol, family)
    if not table:
        raise ValueError(f"robot profile has no time_model entries for protocol {protocol!r}")
    speeds = sorted(table)
    out = {k: float(np.interp(speed, speeds, [table[s][k] for s in speeds])) for k in KEYS}
    if all("L_trans_ref" in table[s] for s in speeds):
        out["L_trans_ref"] = float(np.interp(speed, speeds, [table[s]["L_trans_ref"] for s in speeds]))
    return out


@dataclass(frozen=True)
class Estimate:
    total_time_s: float
    passes: int
    sections: int
    method: str = "closed-form (da Silva Viola et al. 2023)"
    notes: tuple[str, ...] = ()


def estimate_moves(
    moves: Moves,
    time_model: dict,
    travel_speed: float,
    collinear_deg: float = 1.0,
    min_pass_mm: float = 10.0,
    strategies: tuple[str, ...] | None = None,
) -> Estimate:
    """Closed-form estimate of a whole program (see module doc). strategies: each section's
    strategy (`section_strategies`), for strategy-specific entries of the time model."""
    P = moves.points
    if len(P) < 2:
        return Estimate(0.0, 0, 0)
    notes: dict[str, None] = {}
    L = moves.segment_lengths
    U = np.diff(P, axis=0) / np.maximum(L, 1e-12)[:, None]
    total = float(moves.dwell_before.sum())
    n_pass_all = 0
    sections = 0
    cos_tol = np.cos(np.radians(collinear_deg))
    for sec in np.unique(moves.section):
        idx = np.flatnonzero(moves.section == sec)
        dep = idx[moves.kind[idx] == DEPOSIT]
        trav = idx[moves.kind[idx] != DEPOSIT]
        total += float(L[trav].sum()) / travel_speed
        if len(dep) == 0:
            continue
        sections += 1
        is_pass = moves.arc[dep] & moves.inside[dep]
        protocol = "off" if np.any(~moves.arc[dep]) else "on"
        speed = (
            float(np.nanmedian(np.where(is_pass, moves.speed[dep], np.nan)))
            if is_pass.any()
            else float(np.nanmedian(moves.speed[dep]))
        )
        if not np.isfinite(speed) or speed <= 0:
            speed = travel_speed
        family = strategy_family(strategies[sec]) if strategies is not None and sec < len(strategies) else None
        table, which = _entries(time_model, protocol, family)
        if not table:
            notes[
                f"no time-model entry for arc {protocol.upper()} ({protocol!r}) in the profile: "
                f"the study's (KUKA KR 100, triangular 45°) used"
            ] = None
            p = model_params(STUDY_TIME_MODEL, speed, protocol)
        else:
            if which.startswith("other:") and family:
                notes[
                    f"strategy {family!r}: no time-model entry of its own for arc {protocol.upper()}, "
                    f"those identified on {which[6:]} used"
                ] = None
            p = model_params(time_model, speed, protocol, family)
        runs = _runs(dep, is_pass, L, U, cos_tol, max(min_pass_mm, p["L_init_accel"] + p["L_final_decel"]))
        passes = [length for kind, length in runs if kind]
        if not passes:
            total += cycle_time(1, float(L[dep].sum()), speed, p)
            continue
        total += _section_time(runs, speed, p)
        n_pass_all += len(passes)
    return Estimate(total, n_pass_all, sections, notes=tuple(notes))


def _runs(dep, is_pass, L, U, cos_tol, min_len) -> list[tuple[bool, float]]:
    """The section's deposition as alternating (is_pass, length mm): passes are straight,
    collinear runs of arc-ON inside segments at least min_len long; the rest are transitions."""
    runs: list[tuple[bool, float]] = []
    cur = 0.0
    # Python numbers (the same sums as numpy scalars'), the straight-on test for all at once
    for straight_on, passing, length in zip(_straight_on(dep, is_pass, U, cos_tol), is_pass.tolist(), L[dep].tolist()):
        if straight_on and cur > 0:
            cur += length
            continue
        if cur > 0:
            runs.append((True, cur))
            cur = 0.0
        if passing:
            cur = length
        else:
            runs.append((False, length))
    if cur > 0:
        runs.append((True, cur))
    # short "passes" are part of the transitions; merge neighbours of the same kind
    out: list[tuple[bool, float]] = []
    for kind, length in runs:
        kind = kind and length >= min_len
        if out and out[-1][0] == kind and not kind:
            out[-1] = (False, out[-1][1] + length)
        else:
            out.append((kind, length))
    return out


def _straight_on(dep: np.ndarray, is_pass: np.ndarray, U: np.ndarray, cos_tol: float) -> list[bool]:
    """Per deposition segment k of a section: it and the one before are pass segments and turn
    by less than the collinear tolerance (U[dep[k-1]] @ U[dep[k]] ≥ cos_tol). The dot products
    for all at once; those within 1e-9 of the tolerance again one by one, as `@` gives them (a
    sum in another order differs in the last bits only: the same answers)."""
    k = len(dep)
    out = np.zeros(k, dtype=bool)
    if k > 1:
        both = np.asarray(is_pass[1:] & is_pass[:-1], dtype=bool)
        a, b = dep[:-1], dep[1:]
        dots = np.einsum("ij,ij->i", U[a], U[b])
        out[1:] = both & (dots >= cos_tol)
        for j in np.flatnonzero(both & (np.abs(dots - cos_tol) <= 1e-9)).tolist():
            out[j + 1] = U[a[j]] @ U[b[j]] >= cos_tol
    return out.tolist()


def _section_time(runs: list[tuple[bool, float]], TS: float, p: dict[str, float]) -> float:
    """The paper's model over passes of individual lengths; a transition of programmed length Lt
    takes T_trans + (Lt − L_trans_ref)/TS (the identified T_trans is for the triangular 45° link,
    L_trans_ref mm long); stretches before the first / after the last pass at TS."""
    kinds = [k for k, _ in runs]
    first, last = kinds.index(True), len(kinds) - 1 - kinds[::-1].index(True)
    l_ref = p.get("L_trans_ref", float("nan"))
    t = p["T_init_accel"] + p["T_final_decel"]
    for i, (kind, length) in enumerate(runs):
        if i < first or i > last:
            t += length / TS
        elif kind:
            a = p["L_init_accel"] if i == first else p["L_accel"]
            d = p["L_final_decel"] if i == last else p["L_decel"]
            t += (length - a - d) / TS
        else:
            t += p["T_trans"] + ((length - l_ref) / TS if np.isfinite(l_ref) else 0.0)
    return t


def estimate_result(moves: Moves, est: Estimate):
    """An estimate-only `SimulationResult`: metrics (total_time_s, programmed_length_mm, ...), empty trace."""
    from .simulate import SimulationResult

    empty = np.zeros(0)
    L = float(moves.segment_lengths.sum())
    metrics = {
        "total_time_s": est.total_time_s,
        "programmed_length_mm": L,
        "estimate_passes": float(est.passes),
        "estimate_sections": float(est.sections),
        "estimate_only": 1.0,
    }
    trace = {k: empty for k in ("t", "x", "y", "z", "speed", "deviation", "s")}
    trace.update(
        arc=empty.astype(bool), layer=empty.astype(np.int32), section=empty.astype(np.int32), inside=empty.astype(bool)
    )
    return SimulationResult(
        metrics,
        trace,
        np.asarray(moves.points, float),
        np.asarray(moves.arc, bool),
        np.asarray(moves.points, float),
        {},
        tuple(moves.section_keys),
        estimate={"total_time_s": est.total_time_s},
    )
