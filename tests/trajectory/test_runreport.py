"""deposit.csv written a run of rows at a time is the text of one f-string per row (the form it
had before, kept here as the reference), on rows that take every branch: no ratio (programmed
deposit 0, negative, NaN), arc flags 0/1/NaN, a section outside the keys, NaN and ±inf numbers,
negative zero and values on a rounding edge."""

from __future__ import annotations

import io

import numpy as np

from waamflow.trajectory.runreport import _DEPOSIT_BLOCK, _deposit_csv


def _per_row(d: dict, keys) -> str:
    buf = io.StringIO()
    buf.write("segment,layer,section,s_mm,length_mm,arc,programmed_mm3_per_mm,actual_mm3_per_mm,ratio\n")
    cols = zip(
        np.asarray(d["layer"]).tolist(),
        np.asarray(d["section"]).tolist(),
        np.asarray(d["s_mm"], float).tolist(),
        np.asarray(d["length_mm"], float).tolist(),
        np.asarray(d["arc"]).tolist(),
        np.asarray(d["programmed_mm3_per_mm"], float).tolist(),
        np.asarray(d["actual_mm3_per_mm"], float).tolist(),
    )
    for i, (layer, sec, s_mm, length, arc, prog, act) in enumerate(cols):
        ratio = f"{act / prog:.4f}" if prog > 0 else ""
        buf.write(
            f"{i},{int(layer)},{keys[sec] if 0 <= sec < len(keys) else ''},{s_mm:.3f},"
            f"{length:.3f},{int(bool(arc))},{prog:.4f},{act:.4f},{ratio}\n"
        )
    return buf.getvalue()


def _deposit(n: int, rng) -> dict:
    prog = rng.uniform(0.0, 20.0, n)
    prog[rng.random(n) < 0.2] = 0.0
    act = rng.uniform(0.0, 30.0, n)
    special = [np.nan, np.inf, -np.inf, -0.0, 0.00005, 1.00005, 2.5, -1e-9]
    for col in (prog, act):
        idx = rng.choice(n, 40, replace=False)
        col[idx] = rng.choice(special, 40)
    return {
        "layer": rng.integers(0, 200, n),
        "section": rng.integers(-1, 4, n),
        "s_mm": np.cumsum(rng.uniform(0, 3, n)),
        "length_mm": rng.uniform(0, 3, n),
        "arc": rng.choice([0.0, 1.0, np.nan], n),
        "programmed_mm3_per_mm": prog,
        "actual_mm3_per_mm": act,
    }


def test_deposit_csv_is_the_per_row_text():
    rng = np.random.default_rng(3)
    keys = ("ring0", "ring1", "infill")  # section 3 and -1 are outside: empty
    n = 2 * _DEPOSIT_BLOCK + 777  # runs that span blocks, and a short last block
    d = _deposit(n, rng)
    got = _deposit_csv(d, keys)
    assert got == _per_row(d, keys)
    assert got.count("\n") == n + 1
    assert ",inf," in got and ",nan," in got and ",-0.0000," in got
    rows = got.splitlines()[1:]
    no_ratio = int(np.count_nonzero(~(d["programmed_mm3_per_mm"] > 0)))
    assert sum(r.endswith(",") for r in rows) == no_ratio > 100


def test_deposit_csv_of_few_rows():
    rng = np.random.default_rng(4)
    for n in (0, 1, 2, 5):
        d = _deposit(max(n, 40), rng)
        d = {k: v[:n] for k, v in d.items()}
        assert _deposit_csv(d, ("a",)) == _per_row(d, ("a",))
    bools = _deposit(40, rng)
    bools["arc"] = np.arange(40) % 3 == 0  # a bool column, as the simulation writes it
    assert _deposit_csv(bools, ("a", "b")) == _per_row(bools, ("a", "b"))
