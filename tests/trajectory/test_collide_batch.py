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
