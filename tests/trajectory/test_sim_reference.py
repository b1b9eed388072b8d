"""simulate-robot reproduces its recorded figures on the shipped recipes (issue 28 item 3, issue 30
item 3: the speed work on trajectory.simulate / run / kinematics / collide must not change them).

`sim_reference.json` beside this file was written by this module's `--write` mode from the code
before the speed work (commit 91b305d): for curved-bracket (ABB cell, gravity policy, IK +
coal collisions), curved-duct (KUKA cell) and two planar recipes (rectangle-study: arm-only IK;
bead-trials: controller model only), every figure of `<node>.simulation.json` (metrics, warnings,
collisions, kinematics issues, axes, estimate), the corner table, the trace and deposit CSVs
(row counts, column sums and every 997th row) and the solved motion (IK samples, joint angles,
positioner angles per layer: the per-layer choices).

Tolerances, and why: figures are compared at rel 1e-9 / abs 2e-6. The JSON rounds to 6 decimals
(abs 1e-6 either side of a rounding edge: 2e-6), the CSVs to 3-4 decimals (compared at one unit
of their last digit); a vectorised rewrite may sum the same numbers in another order (≈ 1e-16
relative per operation, far below 1e-9 on sums of ~10⁶ terms). Column sums of the CSVs are
sums of rounded values: compared at rel 1e-9 with abs = rows × half a unit of the last digit.
Joint angles (rad) at abs 1e-9: the IK iteration is unchanged, so they are equal to the bit.
Counts (samples, stops, corners, stretches, collisions) and messages are exact.

A deliberate change of the model or of an upstream node changes these figures: re-record with
`.venv/bin/python tests/trajectory/test_sim_reference.py --write` and say why in the commit.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = Path(__file__).with_name("sim_reference.json")
RECIPES = {"curved-bracket": "sim", "curved-duct": "sim", "rectangle-study": "simulate", "bead-trials": "simulate"}
ROW_EVERY = 997
REL, ABS = 1e-9, 2e-6


def _csv(text: str) -> dict:
    head, _, body = text.partition("\n")
    cols = head.split(",")
    rows = [r.split(",") for r in body.splitlines() if r]
    num = []
    for j in range(len(cols)):
        try:
            num.append(np.array([float(r[j]) if r[j] else np.nan for r in rows]))
        except ValueError:  # a text column (section keys)
            num.append(None)
    return {
        "columns": cols,
        "rows": len(rows),
        "sums": {c: float(np.nansum(v)) for c, v in zip(cols, num) if v is not None},
        "sample": [rows[i] for i in range(0, len(rows), ROW_EVERY)],
    }


def _motion(res) -> dict:
    m = (res.kinematics or {}).get("motion")
    if not m:
        return {}
    q = np.asarray(m["q"])
    out = {
        "samples": int(len(q)),
        "q_sum": q.sum(axis=0).tolist(),
        "q_abs_sum": np.abs(q).sum(axis=0).tolist(),
        "q_sample": q[::ROW_EVERY].tolist(),
        "unreachable": int(np.count_nonzero(m["unreachable"])),
    }
    ang = np.asarray(m["positioner_deg"])
    if ang.size:
        out["positioner_sum"] = ang.sum(axis=0).tolist()
        out["positioner_sample"] = ang[::ROW_EVERY].tolist()
    return out


def _per_layer_positioner(res) -> dict:
    """Positioner angles chosen for each layer (mean and range over its IK samples)."""
    m = (res.kinematics or {}).get("motion")
    if not m or not np.asarray(m["positioner_deg"]).size:
        return {}
    ang = np.asarray(m["positioner_deg"])
    s_seg = np.concatenate([[0.0], np.cumsum(res.deposit["length_mm"])])
    seg = np.minimum(np.searchsorted(s_seg, np.asarray(m["s"]), side="right") - 1, len(res.deposit["layer"]) - 1)
    layer_of_sample = res.deposit["layer"][seg]
    out = {}
    for L in np.unique(layer_of_sample):
        a = ang[layer_of_sample == L]
        out[str(int(L))] = [a.mean(axis=0).tolist(), a.min(axis=0).tolist(), a.max(axis=0).tolist()]
    return out


def digest(name: str) -> dict:
    """Run recipe `name` up to its simulate-robot node: the figures this test compares."""
    from waamflow.engine.cache import MemoryCache
    from waamflow.engine.executor import FileResolver, execute
    from waamflow.engine.graph import build_graph
    from waamflow.engine.recipe import load_recipe

    node = RECIPES[name]
    path = ROOT / "graphs" / f"{name}.json"
    run = execute(
        build_graph(load_recipe(path)),
        resolver=FileResolver(path.parent),
        cache=MemoryCache(),
        targets=[node],
        preflight=False,
        workers=1,
    )
    sim = json.loads(run.artifacts[f"{node}.simulation.json"])
    corners = sim.pop("corners")
    res = run.outputs[node]["simulation"]
    return {
        "simulation": sim,
        "corners": {
            "count": len(corners),
            "sums": {
                k: float(np.nansum([c[k] if c[k] is not None else np.nan for c in corners]))
                for k in ("vertex", "interior_deg", "error_mm", "min_speed_mm_s", "mean_speed_mm_s")
            },
            "sample": corners[::ROW_EVERY],
        },
        "trace": _csv(_text(run.artifacts[f"{node}.trace.csv"])),
        "deposit": _csv(_text(run.artifacts[f"{node}.deposit.csv"])),
        "motion": _motion(res),
        "positioner_per_layer": _per_layer_positioner(res),
        "warnings": [w["message"] for w in run.warnings if w.get("node") == node],
    }


def _text(data) -> str:
    return data.decode("utf-8") if isinstance(data, bytes) else data


def _last_digit(text: str) -> float:
    """Half a unit of the last decimal written in a CSV field ("12.345" → 5e-4)."""
    return 0.5 * 10.0 ** -len(text.partition(".")[2]) if "." in text else 0.5


def _compare(got, want, where: str, errors: list[str], abs_tol: float = ABS) -> None:
    if isinstance(want, dict):
        if set(got) != set(want):
            errors.append(f"{where}: keys {sorted(set(got) ^ set(want))} differ")
        for k in want:
            if k in got:
                _compare(got[k], want[k], f"{where}.{k}", errors, abs_tol)
    elif isinstance(want, list):
        if len(got) != len(want):
            errors.append(f"{where}: {len(got)} items, recorded {len(want)}")
            return
        for i, (g, w) in enumerate(zip(got, want)):
            _compare(g, w, f"{where}[{i}]", errors, abs_tol)
    elif isinstance(want, str) and isinstance(got, str) and where.split("[")[0].endswith(".sample") and "." in want:
        try:
            g, w = float(got), float(want)
        except ValueError:
            if got != want:
                errors.append(f"{where}: {got!r} != {want!r}")
            return
        if abs(g - w) > 2 * _last_digit(want) + 1e-12:
            errors.append(f"{where}: {got} != {want}")
    elif isinstance(want, float) and isinstance(got, (int, float)) and not isinstance(got, bool):
        if not (abs(got - want) <= max(REL * abs(want), abs_tol) or (np.isnan(got) and np.isnan(want))):
            errors.append(f"{where}: {got!r} != {want!r} (diff {got - want:.3g})")
    elif got != want:
        errors.append(f"{where}: {got!r} != {want!r}")


def _csv_abs(d: dict) -> float:
    """abs tolerance of a CSV column sum: rows × one unit of the last digit (rounding of each value)."""
    return d["rows"] * 1e-3


@pytest.mark.slow
@pytest.mark.parametrize("name", list(RECIPES))
def test_simulate_robot_reproduces_the_recorded_figures(name):
    want = json.loads(REFERENCE.read_text())[name]
    got = json.loads(json.dumps(digest(name)))
    errors: list[str] = []
    for part in want:
        tol = _csv_abs(want[part]) if part in ("trace", "deposit") else ABS
        if part == "motion":
            tol = 1e-9
        _compare(got[part], want[part], part, errors, tol)
    assert not errors, f"{len(errors)} figures differ from the recording:\n" + "\n".join(errors[:40])


def test_the_comparison_catches_a_changed_figure():
    """The comparison is not vacuous: a time off by 1 µs in a 3500 s run, one more stop, a changed
    warning and a trace row off by two units of its last digit are reported."""
    want = {
        "simulation": {"total_time_s": 3506.798607, "stops": 292.0, "warnings": [{"message": "a"}]},
        "trace": {"rows": 3, "sample": [["0.0120", "-14.4215"]]},
    }
    got = {
        "simulation": {"total_time_s": 3506.798607 + 1e-5, "stops": 293.0, "warnings": [{"message": "b"}]},
        "trace": {"rows": 3, "sample": [["0.0120", "-14.4217"]]},
    }
    errors: list[str] = []
    _compare(got, want, "", errors)
    assert len(errors) == 4, errors
    same: list[str] = []
    _compare(json.loads(json.dumps(want)), want, "", same)
    assert same == []


if __name__ == "__main__" and "--write" in sys.argv:
    out = {name: json.loads(json.dumps(digest(name))) for name in RECIPES}
    REFERENCE.write_text(json.dumps(out, indent=0, sort_keys=True) + "\n")
    print(f"wrote {REFERENCE} ({REFERENCE.stat().st_size} bytes)")
