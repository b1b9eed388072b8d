"""wall-path on a solid part's layers (filled regions) planned nothing and said only "no wall to
deposit: layers carry neither curves nor ring regions" (five fan-sliced parts of the mesh fuzz,
2026-11-26): it now names the layers' kind, the first layer and what to use instead."""

import pytest
import trimesh

from waamflow.core.errors import PlanningError
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe


def _walls_of(tmp_path, source: dict):
    """source → slice (2 mm) → wall-path, run from `tmp_path`."""
    recipe = {
        "format": "waamflow/1",
        "name": "walls",
        "nodes": [
            source,
            {"id": "layers", "type": "slice", "params": {"layer_height": 2.0}},
            {"id": "walls", "type": "wall-path", "params": {}},
        ],
        "edges": [{"from": "part.mesh", "to": "layers.mesh"}, {"from": "layers.layers", "to": "walls.layers"}],
    }
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))


def test_wall_path_on_solid_sections_says_what_to_use_instead(tmp_path):
    box = trimesh.creation.box(extents=(40, 30, 10))
    box.apply_translation((0, 0, 5))
    box.export(tmp_path / "block.stl")
    with pytest.raises(PlanningError) as ei:
        _walls_of(tmp_path, {"id": "part", "type": "mesh", "params": {"path": "block.stl"}})
    msg = str(ei.value)
    assert ei.value.node == "walls" and ei.value.exit_code == 3
    assert "5 of 5 layers are filled regions without a hole (first: layer 0, 1200 mm²)" in msg
    assert "mask → strategy" in msg


def test_walls_all_dropped_are_said_so(tmp_path):
    """A 1.5 mm cross (LibreCAD's v10.dxf is a 1.75 mm symbol): every wall lies inside the
    crossing's cutting circle. The message had said the layers carry no curves (and '0 empty')."""
    import ezdxf

    doc = ezdxf.new("R2010", units=4)
    msp = doc.modelspace()
    msp.add_line((-0.75, 0), (0.75, 0))
    msp.add_line((0, -0.75), (0, 0.75))
    doc.saveas(tmp_path / "tiny.dxf")
    with pytest.raises(PlanningError) as ei:
        _walls_of(tmp_path, {"id": "part", "type": "sketch", "params": {"path": "tiny.dxf", "height": 6.0}})
    msg = str(ei.value)
    assert "3 of 3 layers carry curves (the sketch is 1.50 mm across), but every wall was dropped" in msg
    assert "units and scale" in msg
