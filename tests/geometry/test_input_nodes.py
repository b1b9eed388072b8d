"""The mesh and sketch nodes through the engine: file reading, caps, warnings."""

import io

import ezdxf
import pytest
import trimesh

from waamflow.core.errors import InputFileError
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe


def _run(tmp_path, node):
    recipe = {"format": "waamflow/1", "name": "t", "nodes": [node], "edges": []}
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path))


def test_mesh_node_caps_and_missing_file(tmp_path):
    trimesh.creation.icosphere(subdivisions=2).export(tmp_path / "s.stl")  # 320 triangles
    res = _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "s.stl", "units": "m"}})
    mesh = res.outputs["m"]["mesh"]
    assert len(mesh.faces) == 320
    assert mesh.bounds[1][0] == pytest.approx(1000.0)
    with pytest.raises(InputFileError, match="320 triangles exceed the cap of 100") as err:
        _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "s.stl", "max_triangles": 100}})
    assert err.value.node == "m"
    with pytest.raises(InputFileError):
        _run(tmp_path, {"id": "m", "type": "mesh", "params": {"path": "nope.stl"}})


def test_sketch_node_dxf_warns_about_skipped_entities(tmp_path):
    doc = ezdxf.new("R2010", units=4)
    msp = doc.modelspace()
    msp.add_lwpolyline([(0, 0), (100, 0), (100, 50)])
    msp.add_text("panel A")
    msp.add_line((5, 5), (5, 5))
    buf = io.StringIO()
    doc.write(buf)
    (tmp_path / "p.dxf").write_text(buf.getvalue())
    res = _run(tmp_path, {"id": "sk", "type": "sketch", "params": {"path": "p.dxf", "height": 20, "z0": 1}})
    mid = res.outputs["sk"]["mesh"]
    assert (mid.height, mid.z0, len(mid.curves)) == (20.0, 1.0, 1)
    assert len(res.warnings) == 1
    assert "1 TEXT" in res.warnings[0]["message"] and "1 zero-length LINE" in res.warnings[0]["message"]
