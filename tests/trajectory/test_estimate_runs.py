"""estimate._runs on Python numbers with the straight-on test for all segments at once gives the
runs (kinds and lengths, to the bit) of the loop over numpy scalars it replaced, also where
consecutive segments turn by exactly the collinear tolerance."""

from __future__ import annotations

import numpy as np

from waamflow.trajectory.estimate import _runs


def _numpy_loop(dep, is_pass, L, U, cos_tol, min_len):
    runs = []
    cur = 0.0
    for k, i in enumerate(dep):
        straight_on = is_pass[k] and k > 0 and is_pass[k - 1] and U[dep[k - 1]] @ U[i] >= cos_tol
        if straight_on and cur > 0:
            cur += L[i]
            continue
        if cur > 0:
            runs.append((True, cur))
            cur = 0.0
        if is_pass[k]:
            cur = L[i]
        else:
            runs.append((False, L[i]))
    if cur > 0:
        runs.append((True, cur))
    out = []
    for kind, length in runs:
        kind = kind and length >= min_len
        if out and out[-1][0] == kind and not kind:
            out[-1] = (False, out[-1][1] + length)
        else:
            out.append((kind, length))
    return out


def test_runs_are_those_of_the_numpy_scalar_loop():
    rng = np.random.default_rng(11)
    n = 4000
    # a path of straight stretches with turns of 0°, exactly 1° (the tolerance) and more
    turn = np.radians(rng.choice([0.0, 0.0, 0.0, 1.0, 1.0 + 1e-12, 1.0 - 1e-12, 5.0, 90.0], n))
    heading = np.cumsum(turn)
    U = np.column_stack([np.cos(heading), np.sin(heading), np.zeros(n)])
    L = rng.uniform(0.5, 8.0, n)
    L[rng.random(n) < 0.01] = 0.0
    cos_tol = np.cos(np.radians(1.0))
    dep = np.flatnonzero(rng.random(n) < 0.97)
    is_pass = rng.random(len(dep)) < 0.9
    got = _runs(dep, is_pass, L, U, cos_tol, 10.0)
    want = _numpy_loop(dep, is_pass, L, U, cos_tol, 10.0)
    assert len(got) == len(want) > 100
    assert [k for k, _ in got] == [k for k, _ in want]
    assert [float(x) for _, x in got] == [float(x) for _, x in want]
    assert sum(k for k, _ in got) > 50
    assert _runs(dep[:1], is_pass[:1], L, U, cos_tol, 10.0) == _numpy_loop(dep[:1], is_pass[:1], L, U, cos_tol, 10.0)
