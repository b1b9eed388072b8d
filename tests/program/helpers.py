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


def wall_recipe(name: str = "robot-wall", post_id: str = "post", **post) -> dict:
    """sketch (`wall.json`, 6 mm) → slice (2 mm) → features → wall-path → sequence → post-process
    `post_id` with params `post`: the small real recipe the program tests run."""
    return {
        "format": "waamflow/1",
        "name": name,
        "nodes": [
            {"id": "sketch", "type": "sketch", "params": {"path": "wall.json", "height": 6.0}},
            {"id": "layers", "type": "slice", "params": {"layer_height": 2.0}},
            {"id": "features", "type": "features", "params": {}},
            {"id": "walls", "type": "wall-path", "params": {"speed": 10.0}},
            {"id": "sequence", "type": "sequence", "params": {}},
            {"id": post_id, "type": "post-process", "params": post},
        ],
        "edges": [
            {"from": "sketch.mesh", "to": "layers.mesh"},
            {"from": "layers.layers", "to": "features.layers"},
            {"from": "layers.layers", "to": "walls.layers"},
            {"from": "features.features", "to": "walls.features"},
            {"from": "walls.toolpath", "to": "sequence.toolpath"},
            {"from": "sequence.toolpath", "to": f"{post_id}.toolpath"},
        ],
    }
