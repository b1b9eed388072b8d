"""Measured traces of a robot: read, compared with a simulation, and the study's time model read
off one.

* `read_trace_csv` parses a measured trace (CSV with columns t, x, y, z[, arc][, speed]; s, mm,
  mm/s) into a `MeasuredTrace`; `trace_csv` writes a simulated one (the contract's trace.csv);
* `trace_residuals`: the distances between measured and simulated positions at the measured
  times (after aligning the motion starts), arc-state mismatches and the end-time mismatch —
  what `calibrate.fit_trace` minimises;
* `identify_time_model`: the study's Table-5 constants (robot-study.md) read off a trace of a
  known program, per section, the way the authors read them.

The fits themselves (least squares on a robot profile's constants) are in `calibrate`.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ..core.errors import InputFileError
from ..core.fixedtext import fixed_rows
from ..core.moves import DEPOSIT, Moves
from .simulate import SimulationResult


@dataclass(frozen=True, eq=False)
class MeasuredTrace:
    """t: (k,) s increasing. xyz: (k, 3) mm. arc: (k,) bool or None when not measured.
    speed: (k,) mm/s path speed at each sample, or None when the trace has no speed column."""

    t: np.ndarray
    xyz: np.ndarray
    arc: np.ndarray | None
    speed: np.ndarray | None = None


def read_trace_csv(text: str, source: str = "trace") -> MeasuredTrace:
    """Parse a measured trace CSV: header with t, x, y, z and optionally arc (0/1/true/false)
    and speed (mm/s).

    Bad rows raise InputFileError naming the row (1-based line number of the file).
    """
    reader = csv.reader(io.StringIO(text))
    try:
        header = [h.strip().lower() for h in next(reader)]
    except StopIteration:
        raise InputFileError(f"{source}: empty trace CSV") from None
    need = ["t", "x", "y", "z"]
    missing = [c for c in need if c not in header]
    if missing:
        raise InputFileError(f"{source}: header must name columns t,x,y,z[,arc]; missing {missing}")
    col = {c: header.index(c) for c in need}
    arc_col = header.index("arc") if "arc" in header else None
    speed_col = header.index("speed") if "speed" in header else None
    rows: list[Any] = []
    arcs: list[Any] = []
    speeds: list[Any] = []
    for lineno, row in enumerate(reader, start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) < len(header):
            raise InputFileError(f"{source}: row {lineno}: expected {len(header)} columns, got {len(row)}")
        try:
            vals = [float(row[col[c]]) for c in need]
        except ValueError:
            raise InputFileError(f"{source}: row {lineno}: not a number in {row!r}") from None
        if not all(math.isfinite(v) for v in vals):
            raise InputFileError(f"{source}: row {lineno}: non-finite value in {row!r}")
        if rows and vals[0] <= rows[-1][0]:
            raise InputFileError(f"{source}: row {lineno}: time {vals[0]} does not increase")
        rows.append(vals)
        if speed_col is not None:
            try:
                sp = float(row[speed_col])
            except ValueError:
                raise InputFileError(f"{source}: row {lineno}: speed is not a number: {row[speed_col]!r}") from None
            if not math.isfinite(sp) or sp < 0:
                raise InputFileError(f"{source}: row {lineno}: speed must be a finite number ≥ 0, got {sp}")
            speeds.append(sp)
        if arc_col is not None:
            flag = row[arc_col].strip().lower()
            if flag in ("1", "true", "on", "1.0"):
                arcs.append(True)
            elif flag in ("0", "false", "off", "0.0"):
                arcs.append(False)
            else:
                raise InputFileError(f"{source}: row {lineno}: arc must be 0/1, got {row[arc_col]!r}")
    if len(rows) < 10:
        raise InputFileError(f"{source}: need at least 10 samples, got {len(rows)}")
    a = np.asarray(rows)
    return MeasuredTrace(
        a[:, 0],
        a[:, 1:4],
        np.asarray(arcs, bool) if arc_col is not None else None,
        np.asarray(speeds, float) if speed_col is not None else None,
    )


_CSV_BLOCK = 16384  # rows per buffer of `_csv_rows`
_CSV_DECIMALS = (4, 4, 4, 4, 3, None, 4)  # t,x,y,z,speed,arc,deviation: decimals, None = %d
CSV_SPLIT_ROWS = 50_000  # rows from which `start_trace_csv` hands part of them to a worker
CSV_WORKER_SHARE = 0.6  # of the rows: this process writes the other artifacts meanwhile


def trace_csv(result: SimulationResult) -> str:
    """The simulated trace as CSV (t,x,y,z,speed,arc,deviation) — the contract's trace.csv."""
    return start_trace_csv(result)()


def start_trace_csv(result: SimulationResult, submit: Callable[..., Any] | None = None) -> Callable[[], str]:
    """`trace_csv` in two steps: call, then call what it returns for the text. With submit
    (`Context.submit`) and a long trace, the last `CSV_WORKER_SHARE` of the rows are formatted
    in a worker from the first call on, while the caller writes its other artifacts; rows are
    formatted one by one, so where the text is cut does not change it."""
    tr = result.trace
    cols = np.column_stack([tr["t"], tr["x"], tr["y"], tr["z"], tr["speed"], tr["arc"].astype(float), tr["deviation"]])
    cut = len(cols)
    fut = None
    if submit is not None and len(cols) >= CSV_SPLIT_ROWS:
        cut = len(cols) - int(CSV_WORKER_SHARE * len(cols))
        fut = submit(_csv_rows, cols[cut:])
        if fut is None:
            cut = len(cols)

    def finish() -> str:
        head = "t,x,y,z,speed,arc,deviation\n" + _csv_rows(cols[:cut])
        if fut is None:
            return head
        try:
            tail = fut.result()
        except Exception:  # the worker failed: the rows here
            tail = _csv_rows(cols[cut:])
        return head + tail

    return finish


def _csv_rows(cols: np.ndarray) -> str:
    """The CSV rows of `trace_csv`'s columns (n, 7): the text of "%.4f,%.4f,%.4f,%.4f,%.3f,%d,%.4f\n"
    per row, its digits worked out by numpy on whole columns, _CSV_BLOCK rows at a time
    (`core.fixedtext`; 292k rows: 0.38 -> 0.17 s)."""
    return fixed_rows(cols, _CSV_DECIMALS, _CSV_BLOCK)


def _motion_start(t: np.ndarray, xyz: np.ndarray, tol: float = 0.05) -> float:
    moved = np.linalg.norm(xyz - xyz[0], axis=1) > tol
    return float(t[np.argmax(moved)]) if moved.any() else float(t[0])


def trace_residuals(result: SimulationResult, meas: MeasuredTrace, max_samples: int = 3000) -> np.ndarray:
    """Position errors (mm) at measured times after aligning motion starts, + arc mismatch (mm-equivalent 1 per sample)."""
    tr = result.trace
    sim_xyz = np.column_stack([tr["x"], tr["y"], tr["z"]])
    shift = _motion_start(tr["t"], sim_xyz) - _motion_start(meas.t, meas.xyz)
    stride = max(1, len(meas.t) // max_samples)
    tm = meas.t[::stride] + shift
    sim = np.column_stack([np.interp(tm, tr["t"], sim_xyz[:, i]) for i in range(3)])
    res = [np.linalg.norm(sim - meas.xyz[::stride], axis=1)]
    if meas.arc is not None:
        arc_sim = np.interp(tm, tr["t"], tr["arc"].astype(float)) > 0.5
        res.append((arc_sim != meas.arc[::stride]).astype(float))
    # end-time mismatch (s → scaled to mm by 10 mm/s): the measured motion's duration matters
    res.append(np.array([10.0 * ((tr["t"][-1] - shift) - meas.t[-1])]))
    return np.concatenate(res)


# ---------------------------------------------------------------------------------------------
# the study's time model (Table 5) from a measured trace
# ---------------------------------------------------------------------------------------------
def _section_passes(moves: Moves, dep: np.ndarray, collinear_deg: float, min_len: float) -> list[tuple[int, int]]:
    """(first, last) segment indices of the section's passes: maximal runs of consecutive,
    collinear, arc-ON, inside segments at least `min_len` mm long (as `estimate._runs`)."""
    P, L = moves.points, moves.segment_lengths
    U = np.diff(P, axis=0) / np.maximum(L, 1e-12)[:, None]
    cos_tol = math.cos(math.radians(collinear_deg))
    out: list[list[int]] = []
    for i in dep:
        if not (moves.arc[i] and moves.inside[i]):
            continue
        if out and out[-1][1] == i - 1 and U[i - 1] @ U[i] >= cos_tol:
            out[-1][1] = i
        else:
            out.append([int(i), int(i)])
    return [(a, b) for a, b in out if L[a : b + 1].sum() >= min_len]


def _crossing(t, x, v, i, j, thr):
    """Time and position where the speed crosses `thr` between samples i and j (linear)."""
    if not (0 <= j < len(t)) or v[j] >= thr or v[i] == v[j]:
        return t[i], x[i]
    w = (thr - v[j]) / (v[i] - v[j])
    return t[j] + w * (t[i] - t[j]), x[j] + w * (x[i] - x[j])


def _pass_rows(
    moves: Moves,
    passes: list[tuple[int, int]],
    meas: MeasuredTrace,
    v: np.ndarray,
    thr: float,
    line_tol_mm: float,
    cursor: int,
) -> tuple[list[dict] | None, int]:
    """The trace read along each pass of a section (`identify_time_model`): per pass, the
    instants / positions where the speed enters and leaves `thr`, the lengths before / after,
    the pass line (p0, u) and the samples (j0, j1). Each pass is searched from `cursor` (the
    sample after the previous pass's run). Returns (rows, the new cursor), rows None when a pass
    is not in the trace (the cursor then stays after the last pass found)."""
    t, x = meas.t, meas.xyz
    P, L = moves.points, moves.segment_lengths
    cos_along = math.cos(math.radians(25.0))
    rows = []
    for a, b in passes:
        p0, p1 = P[a], P[b + 1]
        ln = float(L[a : b + 1].sum())
        u = (p1 - p0) / ln
        rel = x[cursor:] - p0
        proj = rel @ u
        lat = np.linalg.norm(rel - proj[:, None] * u, axis=1)
        on = np.flatnonzero((lat < line_tol_mm) & (proj > -line_tol_mm) & (proj < ln + line_tol_mm)) + cursor
        if not len(on):
            return None, cursor
        block = on[: np.argmax(np.diff(on) > 1) + 1] if np.any(np.diff(on) > 1) else on
        inner = block[(proj[block - cursor] >= 0.0) & (proj[block - cursor] <= ln)]
        # only motion along the pass counts: a raster's return or the travel to the next
        # section can leave (or reach) the pass line at full speed, heading elsewhere
        step = x[np.minimum(inner + 1, len(x) - 1)] - x[np.maximum(inner - 1, 0)]
        along = step @ u > cos_along * np.linalg.norm(step, axis=1)
        fast = inner[(v[inner] >= thr) & along]
        if not len(fast):
            return None, cursor
        ta, xa = _crossing(t, x, v, fast[0], fast[0] - 1, thr)
        tb, xb = _crossing(t, x, v, fast[-1], fast[-1] + 1, thr)
        rows.append(
            {
                "ta": ta,
                "tb": tb,
                "p0": p0,
                "u": u,
                "l_acc": float(np.clip((xa - p0) @ u, 0.0, ln)),
                "l_dec": float(np.clip(ln - (xb - p0) @ u, 0.0, ln)),
                "j0": int(fast[0]),
                "j1": int(fast[-1]),
            }
        )
        cursor = int(block[-1]) + 1
    return rows, cursor


def _section_entry(
    moves: Moves,
    passes: list[tuple[int, int]],
    rows: list[dict],
    meas: MeasuredTrace,
    v: np.ndarray,
    rest: np.ndarray,
    lag: float,
) -> dict:
    """One section's Table-5 figures from its passes' `rows` (`identify_time_model`): motion
    start / stop `lag` samples off the last / first sample at `rest` around the passes."""
    t, x = meas.t, meas.xyz
    L = moves.segment_lengths
    before = np.flatnonzero(rest[: rows[0]["j0"]])
    after = np.flatnonzero(rest[rows[-1]["j1"] :]) + rows[-1]["j1"]
    # a trace that begins (ends) in motion: its first (last) sample is the start (stop)
    if len(before):
        r0 = int(before[-1])
        t_start = t[r0] + lag * (t[min(r0 + 1, len(t) - 1)] - t[r0])
    else:
        t_start = t[0]
    if len(after):
        r1 = int(after[0])
        t_stop = t[r1] - lag * (t[r1] - t[max(r1 - 1, 0)])
    else:
        t_stop = t[-1]
    x_start = np.array([np.interp(t_start, t, x[:, i]) for i in range(3)])
    x_stop = np.array([np.interp(t_stop, t, x[:, i]) for i in range(3)])
    first, last = rows[0], rows[-1]
    passes_len = [float(L[a : b + 1].sum()) for a, b in passes]
    links = [float(L[b0 + 1 : a1].sum()) for (_, b0), (a1, _) in zip(passes[:-1], passes[1:])]
    return {
        "T_init_accel": first["ta"] - t_start,
        "L_init_accel": first["l_acc"] - float((x_start - first["p0"]) @ first["u"]),
        "L_decel": float(np.mean([r["l_dec"] for r in rows[:-1]])),
        "L_accel": float(np.mean([r["l_acc"] for r in rows[1:]])),
        "T_trans": float(np.mean([r1_["ta"] - r0_["tb"] for r0_, r1_ in zip(rows[:-1], rows[1:])])),
        "L_final_decel": float((x_stop - last["p0"]) @ last["u"]) - (passes_len[-1] - last["l_dec"]),
        "T_final_decel": t_stop - last["tb"],
        "L_trans_ref": float(np.mean(links)),
        "passes": len(rows),
    }


def identify_time_model(
    moves: Moves,
    meas: MeasuredTrace,
    strategies: tuple[str, ...] | None = None,
    frac: float = 0.99,
    line_tol_mm: float = 0.5,
    collinear_deg: float = 1.0,
    min_pass_mm: float = 10.0,
    rest_frac: float = 0.0005,
    source: str = "trace",
) -> tuple[dict, dict]:
    """The study's Table-5 constants of the measured robot, read off its trace of the known program
    `moves` the way the authors read them (robot-study.md; `identify_passes` on a simulation).

    Per section with at least two passes (`_section_passes`; protocol "off" when any of its
    deposition is arc OFF, else "on"; TS = the passes' median programmed speed): the trace samples
    of each pass are the first contiguous run after the previous pass's that lie within
    `line_tol_mm` of the pass line; "constant speed" is ≥ `frac`·TS, its first / last instant
    interpolated between samples; only samples between the pass's ends that move along the pass
    (within 25° of its direction) count (a blend run at full speed past the end does not make
    L_decel negative; a raster's return or the travel to the next section, which leave the pass
    line at speed in another direction, are not the pass). T/L_init_accel: motion start → the
    first pass's constant speed; T/L_final_decel: the last pass's constant speed → stop; L_decel /
    L_accel: the pass length after / before its constant speed (means over the transitions; all
    lengths along the pass line, so transverse backlash does not count);
    T_trans: last constant speed of a pass → first of the next (mean); L_trans_ref: the mean
    programmed length between consecutive passes. Motion start / stop: half a sample after the
    last / before the first sample at rest (speed ≤ `rest_frac`·TS) — 1.5 samples when the speed is
    derived from positions (central differences smear a start over one sample each side); a
    trace that begins or ends in motion (as simulate-robot's) starts / stops at its first / last
    sample.

    Sections with the same (speed, protocol[, strategy family]) are averaged. Returns (time_model
    keyed "<TS>_<protocol>[_<family>]" — the family when `strategies` (one per section, as
    `estimate.section_strategies`) is given —, info with per-section rows and skipped sections)."""
    from .estimate import KEYS as TM_KEYS, strategy_family

    t, x = meas.t, meas.xyz
    if meas.speed is not None:
        v, lag = meas.speed, 0.5
    else:
        v, lag = np.linalg.norm(np.gradient(x, t, axis=0), axis=1), 1.5
    cursor = 0
    groups: dict[str, list[dict]] = {}
    info: dict = {"sections": [], "skipped": []}
    for sec in np.unique(moves.section):
        idx = np.flatnonzero(moves.section == sec)
        dep = idx[moves.kind[idx] == DEPOSIT]
        passes = _section_passes(moves, dep, collinear_deg, min_pass_mm)
        if len(passes) < 2:
            info["skipped"].append(f"section {moves.section_keys[sec]}: {len(passes)} pass(es), need 2")
            continue
        TS = float(np.median(np.concatenate([moves.speed[a : b + 1] for a, b in passes])))
        protocol = "off" if np.any(~moves.arc[dep]) else "on"
        rows, cursor = _pass_rows(moves, passes, meas, v, frac * TS, line_tol_mm, cursor)
        if rows is None:
            info["skipped"].append(
                f"section {moves.section_keys[sec]}: a pass is not in the trace at "
                f"{frac:.0%} of {TS:g} mm/s within {line_tol_mm} mm of its line"
            )
            continue
        ent = _section_entry(moves, passes, rows, meas, v, v <= rest_frac * TS, lag)
        key = f"{round(TS, 1):g}_{protocol}"
        if strategies is not None and sec < len(strategies) and strategy_family(strategies[sec]):
            key += "_" + strategy_family(strategies[sec])
        groups.setdefault(key, []).append(ent)
        info["sections"].append({"section": moves.section_keys[sec], "key": key, **ent})
    tm: dict[str, dict[str, Any]] = {}
    for key, ents in groups.items():
        tm[key] = {k: round(float(np.mean([e[k] for e in ents])), 6) for k in (*TM_KEYS, "L_trans_ref")}
        tm[key].update(passes=int(sum(e["passes"] for e in ents)), sections=len(ents), source=source)
    return tm, info
