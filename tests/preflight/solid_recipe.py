"""The generic recipe of a solid part's preflight tests: mesh → slice → mask → strategy →
sequence → post (G-code), one strategy for the whole layer."""

import json
from pathlib import Path


def solid_recipe(tmp: Path, name: str, mesh: str, strategy: dict, layer_height: float = 2.0) -> str:
    """Writes `name`.json beside the mesh file `mesh` in `tmp` and returns its path."""
    rec = {
        "format": "waamflow/1",
        "name": name,
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": mesh}},
            {"id": "layers", "type": "slice", "params": {"layer_height": layer_height}},
            {"id": "mask", "type": "mask", "params": {}},
            {"id": "strategy", "type": "strategy", "params": {"default": strategy}},
            {"id": "sequence", "type": "sequence", "params": {"order": "nearest", "retract_height": 5}},
            {"id": "post", "type": "post-process", "params": {"weld_values": {"wire_feed_speed": 4}}},
        ],
        "edges": [
            {"from": "part.mesh", "to": "layers.mesh"},
            {"from": "layers.layers", "to": "mask.layers"},
            {"from": "mask.sections", "to": "strategy.sections"},
            {"from": "strategy.toolpath", "to": "sequence.toolpath"},
            {"from": "sequence.toolpath", "to": "post.toolpath"},
        ],
    }
    (tmp / f"{name}.json").write_text(json.dumps(rec))
    return str(tmp / f"{name}.json")
