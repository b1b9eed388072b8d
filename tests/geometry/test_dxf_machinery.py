"""DXF through ezdxf's own machinery: MINSERT arrays, nested blocks, OCS arcs, binary DXF,
layout choice and the skipped-entities report — drawings generated here."""

import io
import math

import ezdxf
import numpy as np
import pytest

from waamflow.core.errors import InputFileError
from waamflow.geometry.sketch import load_sketch_bytes


def _bytes(doc, fmt="asc", tmp_path=None) -> bytes:
    if fmt == "bin":
        p = tmp_path / "b.dxf"
        doc.saveas(p, fmt="bin")
        return p.read_bytes()
    buf = io.StringIO()
    doc.write(buf)
    return buf.getvalue().encode()


def _length(c):
    return float(np.linalg.norm(np.diff(c, axis=0), axis=1).sum())


def test_minsert_array_gives_25_copies():
    doc = ezdxf.new("R2010", units=4)
    blk = doc.blocks.new("RING")
    blk.add_circle((0, 0), 10)
    ins = doc.modelspace().add_blockref("RING", (0, 0))
    ins.grid(size=(5, 5), spacing=(40, 30))  # 5 rows 40 apart (y) × 5 columns 30 apart (x)
    mid = load_sketch_bytes(_bytes(doc), "m.dxf", height=10).midsurface
    assert len(mid.curves) == 25
    centres = np.array(sorted({(round(float(c[:-1, 0].mean())), round(float(c[:-1, 1].mean()))) for c in mid.curves}))
    assert len(centres) == 25
    assert set(centres[:, 0]) == {0, 30, 60, 90, 120} and set(centres[:, 1]) == {0, 40, 80, 120, 160}
    for c in mid.curves:
        assert _length(c) == pytest.approx(2 * math.pi * 10, rel=1e-3)


def test_nested_blocks_scaled_and_rotated():
    doc = ezdxf.new("R2010", units=4)
    inner = doc.blocks.new("WALL")
    inner.add_line((0, 0), (50, 0))
    outer = doc.blocks.new("PAIR")
    outer.add_blockref("WALL", (0, 0))
    outer.add_blockref("WALL", (0, 20))
    doc.modelspace().add_blockref("PAIR", (100, 100), dxfattribs={"xscale": 2, "yscale": 2, "rotation": 90})
    mid = load_sketch_bytes(_bytes(doc), "n.dxf", height=10).midsurface
    assert len(mid.curves) == 2
    for c in mid.curves:
        assert _length(c) == pytest.approx(100.0)  # 50 × 2
        assert c[:, 0].max() - c[:, 0].min() == pytest.approx(0.0, abs=1e-9)  # rotated to vertical
    xs = sorted(float(c[0, 0]) for c in mid.curves)
    assert xs == pytest.approx([60.0, 100.0])  # (0, 20)·2 rotated 90° → x −40


def test_ocs_arc_with_negative_extrusion_in_world_coordinates():
    doc = ezdxf.new("R2010", units=4)
    # OCS of extrusion (0, 0, -1): OCS x = world −x. Centre (50, 0) OCS → (−50, 0) world.
    doc.modelspace().add_arc((50, 0), 10, 0, 90, dxfattribs={"extrusion": (0, 0, -1)})
    c = load_sketch_bytes(_bytes(doc), "o.dxf", height=10).midsurface.curves[0]
    assert np.hypot(c[:, 0] + 50, c[:, 1]) == pytest.approx(10.0, abs=0.011)
    assert c[:, 0].max() <= -50 + 1e-9 and c[:, 1].min() >= -1e-9  # world quadrant: x ≤ −50, y ≥ 0
    assert _length(c) == pytest.approx(math.pi * 5, rel=1e-3)


def test_binary_dxf_reads_like_ascii(tmp_path):
    doc = ezdxf.new("R2010", units=1)  # inch
    doc.modelspace().add_lwpolyline([(0, 0), (4, 0), (4, 2)])
    a = load_sketch_bytes(_bytes(doc), "a.dxf", height=10)
    b = load_sketch_bytes(_bytes(doc, "bin", tmp_path), "b.dxf", height=10, units="file")
    a = load_sketch_bytes(_bytes(doc), "a.dxf", height=10, units="file")
    assert _bytes(doc, "bin", tmp_path).startswith(b"AutoCAD Binary DXF")
    assert b.units == "in"
    assert np.allclose(a.midsurface.curves[0], b.midsurface.curves[0])
    assert _length(b.midsurface.curves[0]) == pytest.approx(6 * 25.4)


def test_layout_choice():
    doc = ezdxf.new("R2010", units=4)
    doc.modelspace().add_line((0, 0), (100, 0))
    ps = doc.layouts.new("Sheet A")
    ps.add_line((0, 0), (0, 70))
    ps.add_line((0, 70), (30, 70))
    data = _bytes(doc)
    assert _length(load_sketch_bytes(data, "l.dxf", height=5).midsurface.curves[0]) == pytest.approx(100)
    mid = load_sketch_bytes(data, "l.dxf", height=5, layout="Sheet A").midsurface
    assert len(mid.curves) == 1 and _length(mid.curves[0]) == pytest.approx(100)  # 70 + 30 joined
    assert mid.curves[0][:, 1].max() == pytest.approx(70)
    with pytest.raises(InputFileError, match="no layout 'Sheet B'.*Sheet A"):
        load_sketch_bytes(data, "l.dxf", height=5, layout="Sheet B")


def test_hatch_only_drawing_error_lists_skipped_types():
    doc = ezdxf.new("R2010", units=4)
    msp = doc.modelspace()
    for i in range(3):
        h = msp.add_hatch()
        h.paths.add_polyline_path([(i * 20, 0), (i * 20 + 10, 0), (i * 20 + 10, 10)], is_closed=True)
    msp.add_text("note")
    with pytest.raises(InputFileError, match=r"3 HATCH, 1 TEXT"):
        load_sketch_bytes(_bytes(doc), "h.dxf", height=5)
    with pytest.raises(InputFileError, match="not a readable DXF"):
        load_sketch_bytes(b"AutoCAD Binary DXF\r\n\x1a\x00garbage", "bad.dxf", height=5)


def test_a_block_placed_with_z_scale_zero_is_read_flat_and_said():
    """ezdxf's insert_zscale0.dxf: a block reference with z scale 0 stopped the sketch node with a
    bare 'ZeroDivisionError: float division' (ezdxf cannot invert the transform). A sketch's x and
    y do not depend on z: read as 1, named among the read's repairs."""
    doc = ezdxf.new("R2010", units=4)
    blk = doc.blocks.new("WALL")
    blk.add_line((0, 0), (50, 0))
    ref = doc.modelspace().add_blockref("WALL", (10, 20), dxfattribs={"xscale": 2, "yscale": 1})
    ref.dxf.unprotected_set("zscale", 0.0)  # as a file may hold it (ezdxf's own setter makes 0 a 1)
    res = load_sketch_bytes(_bytes(doc), "z.dxf", height=10)
    (c,) = res.midsurface.curves
    assert _length(c) == pytest.approx(100.0) and c[0].tolist() == pytest.approx([10.0, 20.0])
    assert any("block 'WALL' placed with z scale 0: read as 1" in r for r in res.repairs)
    assert not res.defects


def test_a_block_placed_with_x_scale_zero_is_skipped_and_named():
    doc = ezdxf.new("R2010", units=4)
    blk = doc.blocks.new("WALL")
    blk.add_line((0, 0), (50, 0))
    doc.modelspace().add_blockref("WALL", (0, 0)).dxf.unprotected_set("xscale", 0.0)
    doc.modelspace().add_line((0, 0), (0, 40))
    res = load_sketch_bytes(_bytes(doc), "x.dxf", height=10)
    assert len(res.midsurface.curves) == 1  # the line; the collapsed block gives nothing
    (d,) = res.defects
    assert "block 'WALL' placed at scale (0, 1, 1): a zero x or y scale collapses it" in d


def test_a_dxf_without_curves_says_what_a_sketch_needs():
    """28 runs of the DXF sweep (ezdxf's Minimal_DXF_AC1006.dxf, dxf-parser's blocks2.dxf, ...)
    ended on 'sketch has no curves', naming neither the layout nor what counts as a curve."""
    doc = ezdxf.new("R2010", units=4)
    doc.modelspace().add_point((1, 2))
    with pytest.raises(InputFileError) as ei:
        load_sketch_bytes(_bytes(doc), "p.dxf", height=10)
    assert "no curves in layout 'Model'" in str(ei.value)
    empty = ezdxf.new("R2010", units=4)
    with pytest.raises(InputFileError) as ei:
        load_sketch_bytes(_bytes(empty), "e.dxf", height=10)
    assert "p.dxf" not in str(ei.value) and "e.dxf: no curves in layout 'Model' (0 entities, none a LINE" in str(
        ei.value
    )


def _fragment(*entities: str, header: bool = False) -> bytes:
    """A DXF as some writers leave it: an ENTITIES section with R2000 subclass markers (100 AcDb…)
    and no $ACADVER (no HEADER section, or an empty one)."""
    head = "0\nSECTION\n2\nHEADER\n0\nENDSEC\n" if header else ""
    return (head + "0\nSECTION\n2\nENTITIES\n" + "".join(entities) + "0\nENDSEC\n0\nEOF\n").encode()


LWPOLY = (  # closed 100 × 50 rectangle
    "0\nLWPOLYLINE\n5\n3AC\n100\nAcDbEntity\n8\n0\n100\nAcDbPolyline\n90\n4\n70\n1\n"
    + "".join(f"10\n{x}\n20\n{y}\n" for x, y in ((0, 0), (100, 0), (100, 50), (0, 50)))
)
SPLINE = (  # degree 3, 4 control points on a line from (0, 80) to (90, 80): a straight 90 mm curve
    "0\nSPLINE\n5\n3D\n100\nAcDbEntity\n8\n0\n100\nAcDbSpline\n210\n0.0\n220\n0.0\n230\n1.0\n"
    "70\n8\n71\n3\n72\n8\n73\n4\n74\n0\n"
    + "".join(f"40\n{k}\n" for k in (0, 0, 0, 0, 1, 1, 1, 1))
    + "".join(f"10\n{x}\n20\n80\n30\n0\n" for x in (0, 30, 60, 90))
)


@pytest.mark.parametrize("header", [False, True])
def test_subclassed_entities_without_acadver_are_read_as_r2000_and_said(header):
    """gdsestimating/dxf-parser's test drawings blocks.dxf and splines.dxf: entities written with
    R2000 subclass markers in a file that declares no DXF version (no HEADER, or an empty one).
    ezdxf took them for R12, where LWPOLYLINE and SPLINE do not exist, and refused the file
    ("missing 'AcDbPolyline' subclass"); dxf-parser and CAD programs read them."""
    res = load_sketch_bytes(_fragment(LWPOLY, SPLINE, header=header), "frag.dxf", height=10)
    curves = sorted(res.midsurface.curves, key=len)
    assert len(curves) == 2
    lengths = sorted(_length(c) for c in curves)
    assert lengths == pytest.approx([90.0, 300.0], rel=1e-6)  # the spline, the closed rectangle
    assert any("$ACADVER" in r and "R2000" in r for r in res.repairs)


def test_an_r12_drawing_without_acadver_is_not_relabelled():
    """No subclass markers: an R12 drawing stays R12 (its LINE read, nothing said)."""
    line = "0\nLINE\n8\n0\n10\n0\n20\n0\n30\n0\n11\n40\n21\n0\n31\n0\n"
    res = load_sketch_bytes(_fragment(line), "r12.dxf", height=10)
    assert [round(_length(c), 6) for c in res.midsurface.curves] == [40.0]
    assert not any("$ACADVER" in r for r in res.repairs)


def test_a_block_library_says_its_blocks_are_not_placed():
    """dxf-parser's blocks.dxf: 300 block definitions and an empty modelspace (its paperspace
    layouts orphaned): the error names the blocks, not only 'no curves'."""
    doc = ezdxf.new("R2010")
    for name in ("BRACKET", "RIB", "SKIN", "BOSS"):
        doc.blocks.new(name).add_line((0, 0), (50, 0))
    with pytest.raises(InputFileError) as err:
        load_sketch_bytes(_bytes(doc), "lib.dxf", height=10)
    text = str(err.value)
    assert "defines 4 block(s)" in text and "'BRACKET', 'RIB', 'SKIN' and 1 more" in text
    assert "places none in this layout" in text


def test_entities_on_layers_turned_off_or_frozen_are_skipped_and_named():
    """vagran/dxf-viewer's layers-off.dxf / layers-frozen.dxf: a drawing hides construction lines
    on layers turned off or frozen; the sketch read them as walls (three 10 mm walls where the
    drawing shows one). Hidden layers are skipped and counted by layer and state."""
    doc = ezdxf.new("R2010")
    doc.layers.add("OFF").off()
    doc.layers.add("FROZEN").freeze()
    doc.layers.add("ON")
    msp = doc.modelspace()
    msp.add_line((0, 0), (10, 0), dxfattribs={"layer": "OFF"})
    msp.add_line((0, 2), (10, 2), dxfattribs={"layer": "ON"})
    msp.add_line((0, 4), (10, 4), dxfattribs={"layer": "FROZEN"})
    msp.add_circle((50, 0), 5, dxfattribs={"layer": "FROZEN"})
    res = load_sketch_bytes(_bytes(doc), "layers.dxf", height=10)
    assert len(res.midsurface.curves) == 1
    assert res.midsurface.curves[0][:, 1] == pytest.approx([2.0, 2.0])
    assert res.skipped == {
        "LINE on layer 'OFF' (off)": 1,
        "LINE on layer 'FROZEN' (frozen)": 1,
        "CIRCLE on layer 'FROZEN' (frozen)": 1,
    }


def test_a_drawing_all_on_hidden_layers_says_so():
    doc = ezdxf.new("R2010")
    doc.layers.add("WALLS").off()
    doc.modelspace().add_line((0, 0), (100, 0), dxfattribs={"layer": "WALLS"})
    with pytest.raises(InputFileError) as err:
        load_sketch_bytes(_bytes(doc), "hidden.dxf", height=10)
    assert "1 LINE on layer 'WALLS' (off)" in str(err.value)
    assert "turn the layer on" in str(err.value)


def test_a_block_keeps_its_visible_entities_and_skips_its_hidden_ones():
    doc = ezdxf.new("R2010")
    doc.layers.add("AUX").freeze()
    blk = doc.blocks.new("RIB")
    blk.add_line((0, 0), (40, 0))  # layer 0: takes the reference's layer
    blk.add_line((0, 5), (40, 5), dxfattribs={"layer": "AUX"})
    doc.modelspace().add_blockref("RIB", (0, 0))
    res = load_sketch_bytes(_bytes(doc), "blk.dxf", height=10)
    assert [round(_length(c), 6) for c in res.midsurface.curves] == [40.0]
    assert res.skipped == {"LINE on layer 'AUX' (frozen)": 1}


def test_a_block_that_places_itself_is_named():
    """vagran/dxf-viewer's block-recursive.dxf: a block whose content places the block again. The
    error said only "block references nested deeper than 16 levels"."""
    doc = ezdxf.new("R2010")
    a = doc.blocks.new("FRAME")
    a.add_line((0, 0), (10, 0))
    b = doc.blocks.new("RIB")
    b.add_blockref("FRAME", (0, 5))
    a.add_blockref("RIB", (0, 5))
    doc.modelspace().add_blockref("FRAME", (0, 0))
    with pytest.raises(InputFileError) as err:
        load_sketch_bytes(_bytes(doc), "loop.dxf", height=10)
    assert "places itself (FRAME → RIB → FRAME)" in str(err.value) or "places itself (RIB → FRAME → RIB)" in str(
        err.value
    )
