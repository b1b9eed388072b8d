"""The smallest recipe that makes a wall program from a mesh: mesh → slice → wall-path → G-code post
(a 6 mm bead at 10 mm/s, 5 m/min of wire: the bench vase's, wire/part 1.0 in the preflight)."""

from __future__ import annotations


def wall_recipe(stl: str, layer_height: float = 1.5, name: str = "tube") -> dict:
    """The recipe for the mesh file `stl` (relative to the recipe's folder)."""
    return {
        "format": "waamflow/1",
        "name": name,
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": stl}},
            {"id": "layers", "type": "slice", "params": {"layer_height": layer_height}},
            {"id": "walls", "type": "wall-path", "params": {"speed": 10.0, "bead_width": 6.0}},
            {
                "id": "post",
                "type": "post-process",
                "params": {"format": "gcode", "weld_values": {"wire_feed_speed": 5.0}},
            },
        ],
        "edges": [
            {"from": "part.mesh", "to": "layers.mesh"},
            {"from": "layers.layers", "to": "walls.layers"},
            {"from": "walls.toolpath", "to": "post.toolpath"},
        ],
    }
