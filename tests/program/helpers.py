"""Expected values computed straight from the move list (independent of the writers)."""

from __future__ import annotations

import numpy as np

from waamflow.core.moves import Moves


def arc_runs(moves: Moves) -> list[tuple[int, int]]:
    """Maximal arc-on segment ranges [a, b) → points a..b."""
    runs, a = [], None
    for i, on in enumerate(moves.arc):
        if on and a is None:
            a = i
        if not on and a is not None:
            runs.append((a, i))
            a = None
    if a is not None:
        runs.append((a, len(moves.arc)))
    return runs


def polyline_length(pts: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
