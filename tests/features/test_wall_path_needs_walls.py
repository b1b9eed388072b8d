"""wall-path on a solid part's layers (filled regions) planned nothing and said only "no wall to
deposit: layers carry neither curves nor ring regions" (five fan-sliced parts of the mesh fuzz,
2026-11-26): it now names the layers' kind, the first layer and what to use instead."""

import pytest
import trimesh

from waamflow.core.errors import PlanningError
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe


def test_wall_path_on_solid_sections_says_what_to_use_instead(tmp_path):
    box = trimesh.creation.box(extents=(40, 30, 10))
    box.apply_translation((0, 0, 5))
    box.export(tmp_path / "block.stl")
    recipe = {
        "format": "waamflow/1",
        "name": "block",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "block.stl"}},
            {"id": "layers", "type": "slice", "params": {"layer_height": 2.0}},
            {"id": "walls", "type": "wall-path", "params": {}},
        ],
        "edges": [{"from": "part.mesh", "to": "layers.mesh"}, {"from": "layers.layers", "to": "walls.layers"}],
    }
    with pytest.raises(PlanningError) as ei:
        execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))
    msg = str(ei.value)
    assert ei.value.node == "walls" and ei.value.exit_code == 3
    assert "5 of 5 layers are filled regions without a hole (first: layer 0, 1200 mm²)" in msg
    assert "mask → strategy" in msg
