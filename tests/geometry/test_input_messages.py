"""#24 item 5: input messages name the entity and say what to do; one bad DXF entity is skipped
with a warning naming its handle, not the whole file; DXF repairs are listed; the file-size limit
is said in the setting's own MB; a part thinner than one layer says so; the assembly warning
prints its tolerance. Files generated here (ezdxf, trimesh, OpenCascade)."""

import io
import json

import ezdxf
import numpy as np
import pytest
import trimesh

from waamflow.core.errors import InputFileError, PlanningError
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe


def _run(tmp_path, nodes, edges=()):
    recipe = {"format": "waamflow/1", "name": "t", "nodes": nodes, "edges": list(edges)}
    return execute(build_graph(parse_recipe(recipe)), resolver=FileResolver(tmp_path), workers=1)


def _dxf(tmp_path, fill, name="s.dxf") -> dict:
    doc = ezdxf.new("R2010", units=4)  # mm (ezdxf's default is metres)
    handles = fill(doc.modelspace()) or {}
    buf = io.StringIO()
    doc.write(buf)
    (tmp_path / name).write_text(buf.getvalue())
    return handles


def _sketch(tmp_path, name="s.dxf"):
    return _run(tmp_path, [{"id": "sk", "type": "sketch", "params": {"path": name, "height": 30}}])


def _length(c) -> float:
    return float(np.linalg.norm(np.diff(np.asarray(c), axis=0), axis=1).sum())


def test_radius_0_circle_and_degenerate_entities_are_skipped_by_handle(tmp_path):
    def fill(msp):
        msp.add_line((0, 0), (100, 0))
        return {
            "circle": msp.add_circle((5, 5), 0).dxf.handle,
            "spline": msp.add_spline(fit_points=[(0, 10), (0, 10)]).dxf.handle,
            "lw": msp.add_lwpolyline([(3, 3)]).dxf.handle,
        }

    h = _dxf(tmp_path, fill)
    res = _sketch(tmp_path)  # before: InputFileError for the whole file
    curves = res.outputs["sk"]["mesh"].curves
    assert len(curves) == 1 and _length(curves[0]) == pytest.approx(100.0)
    msgs = [w["message"] for w in res.warnings]
    assert any(f"degenerate entity skipped: CIRCLE (handle {h['circle']}, layer 0): radius 0" in m for m in msgs)
    assert any(f"SPLINE (handle {h['spline']}, layer 0): degenerate" in m and "redraw or delete" in m for m in msgs)
    assert any(f"LWPOLYLINE (handle {h['lw']}, layer 0): 1 vertex" in m for m in msgs)
    assert res.stats["sk"].report["dxf_degenerate_skipped"] == 3
    assert not any("np." in m or "Error" in m for m in msgs)


def test_out_of_plane_entity_error_names_handle_and_direction_without_numpy_text(tmp_path):
    h = _dxf(
        tmp_path,
        lambda msp: {"lw": msp.add_lwpolyline([(0, 0), (10, 0)], dxfattribs={"extrusion": (1, 0, 0)}).dxf.handle},
    )
    with pytest.raises(InputFileError) as err:
        _sketch(tmp_path)
    msg = str(err.value)
    # before: "... (extrusion (np.float64(1.0), np.float64(0.0), np.float64(0.0)))"
    assert f"LWPOLYLINE (handle {h['lw']}, layer 0) does not lie in an XY plane" in msg
    assert "(1, 0, 0)" in msg and "np.float64" not in msg and "flatten" in msg
    assert err.value.node == "sk"


def test_dxf_repairs_are_listed(tmp_path):
    h = _dxf(tmp_path, lambda msp: {"line": msp.add_line((0, 0), (50, 0)).dxf.handle})
    text = (tmp_path / "s.dxf").read_text().split("\n")
    i = next(k for k, v in enumerate(text) if v.strip() == "AcDbLine")
    (tmp_path / "s.dxf").write_text("\n".join(text[: i + 1] + [" 62", "999"] + text[i + 1 :]))  # colour 999
    res = _sketch(tmp_path)
    assert _length(res.outputs["sk"]["mesh"].curves[0]) == pytest.approx(50.0)
    assert any(
        f"DXF read: repaired: Removed invalid color index of LINE(#{h['line']})" in w["message"] for w in res.warnings
    )
    assert res.stats["sk"].report["dxf_repairs"] == 1


def test_file_size_limit_is_said_in_the_settings_mb(tmp_path):
    (tmp_path / "big.stl").write_bytes(b"solid x\n" + b" " * (3 * 2**19))  # 1.5 MB (of 2^20 bytes)
    with pytest.raises(InputFileError) as err:
        _run(tmp_path, [{"id": "m", "type": "mesh", "params": {"path": "big.stl", "max_file_mb": 1.25}}])
    # before: "file big.stl is 1.6 MB, over the 1 MB limit" (decimal MB; a 200 MB setting said 210)
    assert "is 1.5 MB, over the 1.25 MB limit" in str(err.value)
    from waamflow.engine.executor import _over_limit

    assert "over the 200 MB limit" in _over_limit("p.stl", 250 * 2**20, int(200.0 * 2**20))


def test_part_thinner_than_a_layer_says_its_size_and_what_to_do(tmp_path):
    box = trimesh.creation.box(extents=(0.06, 0.04, 0.03))  # a 60 × 40 × 30 mm part written in m
    box.apply_translation((0, 0, 0.015))
    box.export(tmp_path / "tiny.stl")
    nodes = [
        {"id": "m", "type": "mesh", "params": {"path": "tiny.stl"}},
        {"id": "layers", "type": "slice", "params": {"layer_height": 1.5, "top": "nearest"}},
    ]
    with pytest.raises(PlanningError) as err:  # before: "no layers: the slicing range ... is empty"
        _run(tmp_path, nodes, [{"from": "m.mesh", "to": "layers.mesh"}])
    msg = str(err.value)
    assert "the part is 0.03 mm tall (from 0 mm to 0.03 mm" in msg and "layer height 1.5 mm" in msg
    assert "top 'ceil'" in msg and "'units'" in msg and err.value.node == "layers"
    # 'ceil' (the default) slices it: one layer of 0.75 mm over the 0.03 mm part, warned as an overshoot
    nodes[1]["params"]["top"] = "ceil"
    res = _run(tmp_path, nodes, [{"from": "m.mesh", "to": "layers.mesh"}])
    assert len(res.outputs["layers"]["layers"]) == 1
    assert any("only 0.06 mm across" in w["message"] for w in res.warnings)


def test_one_mm_drawing_extruded_30_mm_is_reported_implausible(tmp_path):
    # the size check counts the drawing's own extent: a 914 mm yard drawing read as 1 mm with a
    # 30 mm extrusion passed it before
    (tmp_path / "s.json").write_text(json.dumps({"curves": [[[0, 0], [1, 0], [1, 1]]]}))
    res = _run(tmp_path, [{"id": "sk", "type": "sketch", "params": {"path": "s.json", "height": 30}}])
    assert any("part is only 1 mm across" in w["message"] for w in res.warnings)


def test_assembly_warning_prints_its_tolerance(tmp_path):
    pytest.importorskip("OCP")
    from OCP.BRep import BRep_Builder
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Pnt
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    from OCP.TopoDS import TopoDS_Compound

    comp = TopoDS_Compound()
    b = BRep_Builder()
    b.MakeCompound(comp)
    b.Add(comp, BRepPrimAPI_MakeBox(10, 10, 10).Shape())
    b.Add(comp, BRepPrimAPI_MakeBox(gp_Pnt(30, 0, 0), 10, 20, 10).Shape())
    w = STEPControl_Writer()
    w.Transfer(comp, STEPControl_AsIs)
    w.Write(str(tmp_path / "two.step"))
    res = _run(tmp_path, [{"id": "m", "type": "mesh", "params": {"path": "two.step", "chordal_tolerance": 0.02}}])
    msg = next(w["message"] for w in res.warnings if "flattened" in w["message"])
    assert "2 bodies flattened" in msg and "tessellated within 0.02 mm" in msg and "{" not in msg


def test_a_ply_naming_a_missing_texture_is_read_and_the_readers_note_is_a_warning(tmp_path, capsys):
    """trimesh's test model fuze.ply names a texture ('comment TextureFile fuze uv.jpg') that is not
    beside it: trimesh logged "unable to load image!" with a traceback, which `waamflow run` printed
    on stderr. Its note is now the mesh node's warning; nothing reaches stderr; the part is read."""
    cube = trimesh.creation.box(extents=(20.0, 20.0, 10.0))
    v, f = cube.vertices, cube.faces
    lines = ["ply", "format ascii 1.0", "comment TextureFile missing uv.jpg", f"element vertex {len(v)}"]
    lines += ["property float x", "property float y", "property float z", f"element face {len(f)}"]
    lines += ["property list uchar int vertex_indices", "property list uchar float texcoord", "end_header"]
    lines += [f"{x} {y} {z}" for x, y, z in v]
    lines += [f"3 {a} {b} {c} 6 0 0 1 0 0 1" for a, b, c in f]
    (tmp_path / "tex.ply").write_text("\n".join(lines) + "\n")
    res = _run(tmp_path, [{"id": "part", "type": "mesh", "params": {"path": "tex.ply"}}])
    notes = [w["message"] for w in res.warnings if "the file reader (trimesh) says" in w["message"]]
    assert notes == ["tex.ply: the file reader (trimesh) says: unable to load image! (only the geometry is read)"]
    assert res.stats["part"].report["volume_mm3"] == pytest.approx(4000.0)
    err = capsys.readouterr().err
    assert "Traceback" not in err and "unable to load image" not in err
