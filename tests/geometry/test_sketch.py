import io
import json
import math

import ezdxf
import numpy as np
import pytest

from waamflow.core.errors import InputFileError
from waamflow.geometry import load_sketch_bytes
from waamflow.geometry.dxf import arc_segments, bulge_points
from waamflow.geometry.sketch import join_curves
from waamflow.slicing import slice_part


def _length(c: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(c, axis=0), axis=1).sum())


def _dxf(build) -> bytes:
    doc = ezdxf.new("R2010", units=4)
    build(doc.modelspace())
    buf = io.StringIO()
    doc.write(buf)
    return buf.getvalue().encode()


def test_json_sketch_curves_height_and_slicing():
    doc = {
        "curves": [[[0, 0], [100, 0]], [[50, 0], [50, 40]], [[0, 60], [30, 60], [30, 90], [0, 90], [0, 60]]],
        "height": 12,
        "z0": 2,
    }
    res = load_sketch_bytes(json.dumps(doc).encode(), "panel.json")
    mid = res.midsurface
    assert mid.height == 12 and mid.z0 == 2 and mid.name == "panel"
    # the T: (50, 0) is an interior point of the first curve, not an end, so nothing joins
    assert sorted(round(_length(c), 9) for c in mid.curves) == [40.0, 100.0, 120.0]
    layers = slice_part(mid, layer_height=1.5)
    assert len(layers) == 8
    assert all(len(l.curves) == 3 and l.region.is_empty for l in layers)
    np.testing.assert_allclose([l.z for l in layers], 2 + 1.5 * np.arange(1, 9))


def test_json_params_override_file_and_units():
    doc = {"curves": [[[0, 0], [1, 0]]], "height": 1}
    mid = load_sketch_bytes(json.dumps(doc).encode(), "s.json", units="cm").midsurface
    assert mid.height == 10 and _length(mid.curves[0]) == pytest.approx(10)
    mid = load_sketch_bytes(json.dumps(doc).encode(), "s.json", height=30.0, z0=5.0).midsurface
    assert (mid.height, mid.z0) == (30.0, 5.0)


@pytest.mark.parametrize(
    "doc,match",
    [
        ({"lines": []}, r'bad.json: expected an object \{"curves"'),
        ({"curves": [[[0, 0]]], "height": 5}, "curve 0 has fewer than two distinct points"),
        ({"curves": [[[0, 0], [1, "a"]]], "height": 5}, "curve 0 is not a list"),
        ({"curves": [[0, 1, 2]], "height": 5}, r"curve 0 must be a list of \[x, y\] points"),
        ({"curves": [[[0, 0], [1, 1]]]}, "no extrusion height"),
        ({"curves": [], "height": 5}, "sketch has no curves"),
    ],
)
def test_json_errors_name_file_and_curve(doc, match):
    with pytest.raises(InputFileError, match=match):
        load_sketch_bytes(json.dumps(doc).encode(), "bad.json")
    with pytest.raises(InputFileError, match="not valid JSON"):
        load_sketch_bytes(b"{curves", "bad.json")


def test_dxf_arc_length_within_chordal_tolerance():
    tol = 0.01
    data = _dxf(lambda msp: msp.add_arc((10, 5), radius=25, start_angle=30, end_angle=120))
    (arc,) = load_sketch_bytes(data, "arc.dxf", height=10, arc_tolerance=tol).midsurface.curves
    true_len = 25 * math.radians(90)
    r = np.hypot(arc[:, 0] - 10, arc[:, 1] - 5)
    np.testing.assert_allclose(r, 25, atol=1e-9)  # vertices on the arc
    mids = (arc[1:] + arc[:-1]) / 2
    sag = 25 - np.hypot(mids[:, 0] - 10, mids[:, 1] - 5)
    assert sag.max() <= tol and sag.max() > tol / 4  # chords as long as the tolerance allows
    assert true_len - 2 * tol < _length(arc) <= true_len
    np.testing.assert_allclose(arc[0], [10 + 25 * math.cos(math.radians(30)), 5 + 25 * math.sin(math.radians(30))])
    assert len(arc) - 1 == arc_segments(25, math.radians(90), tol)


def test_dxf_entities_lines_polylines_bulges_circle():
    def build(msp):
        msp.add_line((0, 0), (50, 0))
        msp.add_line((50, 0), (50, 30))  # joins the first line end to end
        msp.add_lwpolyline([(100, 0, 0, 0, 1), (120, 0, 0, 0, 0)], format="xyseb")  # half circle r 10, CCW
        msp.add_lwpolyline([(0, 100), (40, 100), (40, 140)], close=True)
        msp.add_polyline2d([(200, 0), (210, 0), (210, 10)])
        msp.add_circle((300, 300), radius=5)
        msp.add_text("label")

    res = load_sketch_bytes(_dxf(build), "part.dxf", height=20, arc_tolerance=0.005)
    curves = res.midsurface.curves
    assert res.skipped == {"TEXT": 1}
    lengths = sorted(round(_length(c), 2) for c in curves)
    assert len(curves) == 5
    half = next(c for c in curves if 99 <= c[:, 0].min() < 150)
    # chords of sagitta ≤ tol: each of the n chords is short by ≈ r·Δ³/24, Δ = π/n
    assert len(half) - 1 == arc_segments(10, math.pi, 0.005) == 50
    assert 10 * math.pi - _length(half) == pytest.approx(50 * 10 * (math.pi / 50) ** 3 / 24, rel=1e-3)
    assert half[len(half) // 2][1] == pytest.approx(-10, abs=1e-6)  # CCW from (100,0) to (120,0) passes below
    assert 80.0 in lengths and 20.0 in lengths  # joined L; polyline2d
    closed = next(c for c in curves if c[:, 1].min() >= 99)
    assert np.array_equal(closed[0], closed[-1]) and _length(closed) == pytest.approx(40 + 40 + math.hypot(40, 40))
    circle = next(c for c in curves if c[:, 0].min() > 290)
    n = len(circle) - 1
    assert np.array_equal(circle[0], circle[-1]) and n == arc_segments(5, 2 * math.pi, 0.005)
    assert _length(circle) == pytest.approx(2 * n * 5 * math.sin(math.pi / n), rel=1e-12)


def test_dxf_mirrored_arc_ocs():
    data = _dxf(
        lambda msp: msp.add_arc((10, 0), radius=5, start_angle=0, end_angle=90, dxfattribs={"extrusion": (0, 0, -1)})
    )
    (arc,) = load_sketch_bytes(data, "m.dxf", height=1).midsurface.curves
    # OCS with extrusion −Z mirrors x: centre (−10, 0), from (−15, 0) to (−10, 5)
    np.testing.assert_allclose(arc[0], [-15, 0], atol=1e-9)
    np.testing.assert_allclose(arc[-1], [-10, 5], atol=1e-9)


def test_dxf_errors_name_entity():
    data = _dxf(lambda msp: msp.add_circle((0, 0), radius=0))
    # a radius-0 circle is skipped by handle (#24); with nothing else in the file, nothing is left
    with pytest.raises(
        InputFileError, match=r"bad.dxf: no curves in layout 'Model'.*CIRCLE \(handle \w+, layer 0\): radius 0"
    ):
        load_sketch_bytes(data, "bad.dxf", height=5)
    with pytest.raises(InputFileError, match="no extrusion height"):
        load_sketch_bytes(_dxf(lambda msp: msp.add_line((0, 0), (1, 0))), "x.dxf")
    with pytest.raises(InputFileError, match="not a readable DXF"):
        load_sketch_bytes(b"\x00\x01 not a dxf", "x.dxf", height=5)


def test_join_keeps_junctions():
    star = [np.array([[0.0, 0], [10, 0]]), np.array([[0.0, 0], [0, 10]]), np.array([[0.0, 0], [-10, 0]])]
    assert len(join_curves(star, 1e-6)) == 3
    chain = [
        np.array([[0.0, 0], [10, 0]]),
        np.array([[10.0, 10], [10, 0]]),
        np.array([[10.0, 10], [0, 10]]),
        np.array([[0.0, 10], [0, 0]]),
    ]
    (loop,) = join_curves(chain, 1e-6)
    assert len(loop) == 5 and np.array_equal(loop[0], loop[-1]) and _length(loop) == 40


def test_bulge_arc_geometry():
    pts = bulge_points((1, 0), (-1, 0), 1.0, 1e-3)  # half circle CCW through (0, 1)
    np.testing.assert_allclose(np.hypot(*pts.T), 1, atol=1e-12)
    assert pts[:, 1].min() >= -1e-12
    pts = bulge_points((1, 0), (0, 1), -math.tan(3 * math.pi / 8), 1e-3)  # 270° clockwise
    np.testing.assert_allclose(np.hypot(*pts.T), 1, atol=1e-12)
    n = len(pts) - 1
    assert _length(pts) == pytest.approx(2 * n * math.sin(0.75 * math.pi / n), rel=1e-12)


def test_dxf_zero_length_line_is_skipped_and_reported():
    def build(msp):
        msp.add_line((0, 0), (0, 0))
        msp.add_line((0, 0), (10, 0))

    res = load_sketch_bytes(_dxf(build), "d.dxf", height=3)
    assert res.skipped == {"zero-length LINE": 1}
    assert [_length(c) for c in res.midsurface.curves] == [10.0]
