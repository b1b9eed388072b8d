"""An open mesh is read as a single-wall surface (per-layer curves, no region). The mask and the
strategy fill areas: they planned nothing without a word, and the run stopped at the post's
preflight with "program post has no arc-ON motion", naming neither the cause nor a layer
(stanford-bunny.obj, teapot.obj, lego.ply and five more open meshes). The mask now stops at the
first such layer and says what to do."""

import numpy as np
import pytest
import trimesh

from waamflow.core.errors import PlanningError
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe


def _recipe() -> dict:
    return {
        "format": "waamflow/1",
        "name": "open",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": "cup.stl"}},
            {"id": "layers", "type": "slice", "params": {"layer_height": 2.0}},
            {"id": "mask", "type": "mask", "params": {}},
        ],
        "edges": [{"from": "part.mesh", "to": "layers.mesh"}, {"from": "layers.layers", "to": "mask.layers"}],
    }


def test_an_open_mesh_stops_at_the_mask_with_the_cause(tmp_path):
    box = trimesh.creation.box(extents=(40, 30, 20))
    box.apply_translation((0, 0, 10))
    top = np.flatnonzero(box.face_normals[:, 2] > 0.99)  # a cup: the box without its lid
    cup = trimesh.Trimesh(box.vertices, np.delete(box.faces, top, axis=0), process=False)
    assert len(top) == 2 and not cup.is_watertight
    cup.export(tmp_path / "cup.stl")
    with pytest.raises(PlanningError) as ei:
        execute(build_graph(parse_recipe(_recipe())), resolver=FileResolver(tmp_path))
    err = ei.value
    assert (err.node, err.layer, err.exit_code) == ("mask", 0, 3)
    assert "no area to segment, only 1 curve(s)" in str(err) and "features → wall-path" in str(err)


def test_a_closed_mesh_is_segmented(tmp_path):
    box = trimesh.creation.box(extents=(40, 30, 20))
    box.apply_translation((0, 0, 10))
    box.export(tmp_path / "cup.stl")
    res = execute(build_graph(parse_recipe(_recipe())), resolver=FileResolver(tmp_path))
    secs = res.outputs["mask"]["sections"]
    assert len(secs) == 10 and all(len(ls.sections) == 1 for ls in secs)
    assert secs[0].sections[0].region.area == pytest.approx(1200.0)
