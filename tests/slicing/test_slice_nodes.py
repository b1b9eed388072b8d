"""mesh/sketch → slice through the engine: params, artifacts, warnings, error exit codes."""

import json

import numpy as np
import pytest

from waamflow.core.errors import InputFileError, RecipeError
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe

from .meshes import box, tube, union


def _recipe(source: dict, slice_params: dict | None = None) -> dict:
    return {
        "format": "waamflow/1",
        "name": "t",
        "nodes": [source, {"id": "layers", "type": "slice", "params": slice_params or {}}],
        "edges": [{"from": f"{source['id']}.mesh", "to": "layers.mesh"}],
    }


def _run(tmp_path, recipe):
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))


def test_mesh_slice_recipe_writes_layers_json(tmp_path):
    tube(20, 30, 30).export(tmp_path / "tube.stl")
    res = _run(tmp_path, _recipe({"id": "part", "type": "mesh", "params": {"path": "tube.stl"}}, {"layer_height": 1.5}))
    doc = json.loads(res.artifacts["layers.layers.json"])
    assert res.layer_count == 20 and len(doc["layers"]) == 20
    assert [l["z"] for l in doc["layers"]][:3] == [1.5, 3.0, 4.5]
    target = np.pi * (30**2 - 20**2)
    assert all(abs(l["area_mm2"] - target) / target < 0.01 for l in doc["layers"])
    assert all(len(l["polygons"]) == 1 and len(l["polygons"][0]["holes"]) == 1 for l in doc["layers"])
    assert res.warnings == []


def test_mesh_units_transform_and_thicknesses(tmp_path):
    box((1, 1, 1)).export(tmp_path / "b.stl")
    src = {
        "id": "part",
        "type": "mesh",
        "params": {"path": "b.stl", "units": "cm", "transform": {"translate": [0, 0, 5]}},
    }
    res = _run(tmp_path, _recipe(src, {"layer_height": 2.0, "thicknesses": [1.0, 1.0], "start_offset": 0.0}))
    layers = res.outputs["layers"]["layers"]
    np.testing.assert_allclose([l.z for l in layers], [6.0, 7.0, 9.0, 11.0, 13.0, 15.0])
    assert all(l.area == pytest.approx(100.0) for l in layers)


def test_gap_between_bodies_warns_with_layer(tmp_path):
    union(box((10, 10, 3)), box((10, 10, 3), corner=(0, 0, 6))).export(tmp_path / "two.stl")
    res = _run(tmp_path, _recipe({"id": "part", "type": "mesh", "params": {"path": "two.stl"}}, {"layer_height": 1.0}))
    assert [w["layer"] for w in res.warnings] == [3, 4, 5]
    assert all(w["node"] == "layers" for w in res.warnings)


def test_open_mesh_is_invalid_input(tmp_path):
    tm = box((10, 10, 10))
    tm.update_faces(np.arange(2, len(tm.faces)))
    tm.export(tmp_path / "open.stl")
    with pytest.raises(InputFileError) as err:
        _run(tmp_path, _recipe({"id": "part", "type": "mesh", "params": {"path": "open.stl", "as": "solid"}}))
    assert err.value.exit_code == 2 and err.value.node == "part"
    assert "open edges" in str(err.value)
    # 'as': 'auto' (default) reads an open mesh as a single-wall surface and says so
    res = _run(tmp_path, _recipe({"id": "part", "type": "mesh", "params": {"path": "open.stl"}}))
    assert res.outputs["part"]["mesh"].surface
    assert any("open" in w["message"] and "surface" in w["message"] for w in res.warnings)


def test_sketch_slice_curves_on_each_layer(tmp_path):
    (tmp_path / "s.json").write_text(json.dumps({"curves": [[[0, 0], [100, 0], [100, 50]]], "height": 9}))
    res = _run(tmp_path, _recipe({"id": "sk", "type": "sketch", "params": {"path": "s.json"}}, {"layer_height": 1.5}))
    doc = json.loads(res.artifacts["layers.layers.json"])
    assert len(doc["layers"]) == 6
    assert all(
        l["curves"] == [[[0.0, 0.0], [100.0, 0.0], [100.0, 50.0]]] and l["polygons"] == [] for l in doc["layers"]
    )


def test_bad_slice_params_are_recipe_errors(tmp_path):
    box((1, 1, 1)).export(tmp_path / "b.stl")
    for params in ({"layer_height": 0}, {"thicknesses": [1, -1]}, {"z_min": 5, "z_max": 1}, {"typo": 1}):
        with pytest.raises(RecipeError):
            _run(tmp_path, _recipe({"id": "part", "type": "mesh", "params": {"path": "b.stl"}}, params))


def test_direction_writes_frames_and_sketch_refuses_tilt(tmp_path):
    box((10, 10, 4)).export(tmp_path / "b.stl")
    res = _run(
        tmp_path,
        _recipe(
            {"id": "part", "type": "mesh", "params": {"path": "b.stl"}}, {"layer_height": 2.0, "direction": [0, 1, 0]}
        ),
    )
    doc = json.loads(res.artifacts["layers.layers.json"])
    assert len(doc["layers"]) == 5 and all(l["area_mm2"] == 40.0 for l in doc["layers"])
    frame = np.array(doc["layers"][0]["frame"])
    np.testing.assert_allclose(frame[:3, 2], [0, 1, 0], atol=1e-12)  # layer normal = build direction
    np.testing.assert_allclose(frame[:3, 3], [0, 2, 0], atol=1e-12)  # origin on the layer's top plane
    (tmp_path / "s.json").write_text(json.dumps({"curves": [[[0, 0], [1, 0]]], "height": 3}))
    with pytest.raises(RecipeError, match="extruded along \\+Z"):
        _run(tmp_path, _recipe({"id": "sk", "type": "sketch", "params": {"path": "s.json"}}, {"direction": [1, 0, 0]}))
