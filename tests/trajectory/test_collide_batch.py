"""The batched collision broad phase (trajectory.collide, issue 28 item 3) drops no sample that
has a colliding pair: with every checked sample sent to the per-sample check (the algorithm before
the batching), a tight bend under the gravity rule — the torch meets the table — gives the same
collisions (count, bodies, points, s), and the same number of checked samples."""

from __future__ import annotations

import numpy as np

from waamflow.trajectory import collide
from waamflow.trajectory.cell import load_cell

from .test_auto_policy import _bend, _sim


def test_batched_broad_phase_finds_what_the_per_sample_check_finds(tmp_path, monkeypatch):
    moves = _bend(tmp_path, 135.0, 5.0)
    cell = load_cell("kr150_tilt_rotate")
    batched = _sim(cell, moves, "gravity")
    flagged: list[int] = []

    def every_sample(st, q, rows, frames, layer):
        flagged.append(len(rows))
        return np.ones(len(rows), bool)

    monkeypatch.setattr(collide, "_batch_candidates", every_sample)
    plain = _sim(cell, moves, "gravity")
    assert sum(flagged) == plain["collision_samples_checked"] > 100
    assert batched["collision_count"] == plain["collision_count"] > 10
    assert batched["collisions"] == plain["collisions"]
    assert batched["collision_samples_checked"] == plain["collision_samples_checked"]
    assert any(c["bodies"][1] == "positioner:table" for c in batched["collisions"])


def test_checked_samples_are_those_of_the_numpy_scalar_loop():
    """collide._checked on Python numbers picks the samples the loop over numpy scalars picked:
    every one ≥ step_mm after the last checked, the first of each layer and the last sample."""
    import numpy as np

    from waamflow.trajectory.collide import _checked

    def numpy_loop(s, seg, layer_of_seg, step_mm):
        out, last_s, last_layer = [], -np.inf, None
        for i in range(len(s)):
            layer = int(layer_of_seg[seg[i]])
            if s[i] - last_s < step_mm and layer == last_layer and i != len(s) - 1:
                continue
            last_s, last_layer = s[i], layer
            out.append(i)
        return out

    rng = np.random.default_rng(5)
    s = np.cumsum(rng.uniform(0.0, 6.0, 3000))
    s[100:110] = s[100]  # standstill samples
    seg = np.minimum(np.arange(3000) // 3, 999)
    layer_of_seg = np.repeat(np.arange(10), 100)
    got = _checked(s, seg, layer_of_seg, 20.0)
    assert got == numpy_loop(s, seg, layer_of_seg, 20.0)
    assert got[-1] == 2999 and 10 + 3000 * 3.0 / 20.0 * 0.5 < len(got) < 3000
    assert _checked(s[:1], seg[:1], layer_of_seg, 20.0) == [0]
