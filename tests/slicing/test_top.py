"""Issue #22 item 4, "the top is reached": the `top` policy of the layer schedule (ceil, nearest,
exact) and the `slice` node's warnings and errors about it."""

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

from waamflow.core.errors import PlanningError
from waamflow.core.tolerances import TOL
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import parse_recipe
from waamflow.slicing import layer_schedule, slice_part
from waamflow.slicing.planes import TOP_MAX_FACTOR, TOP_MIN_FRACTION

from .meshes import as_mesh, box

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"
CROSS_FIRST = [2.0, 1.8]  # the cross's first layers (substrate sink), then 1.5 mm


def test_stated_limits():
    assert (TOP_MIN_FRACTION, TOP_MAX_FACTOR) == (0.5, 1.5)


# ---------------------------------------------------------------------------- ceil (default)
def test_ceil_31_mm_at_2_mm_tops_at_31():
    s = layer_schedule(0.0, 31.0, layer_height=2.0)
    assert len(s) == 16
    assert s.tops[-1] == pytest.approx(31.0, abs=1e-6)
    # remainder 1.0 mm = 0.5 of a 2 mm layer: the last layer is thinned to it
    assert s.thickness[-1] == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(s.tops[:15], 2.0 * np.arange(1, 16), atol=1e-12)
    np.testing.assert_allclose(s.cuts[-1], 30.5)
    assert s.fit.action == "thinned" and s.fit.gap == pytest.approx(0.0, abs=1e-12)
    assert s.fit.layer == 15 and s.fit.nominal == 2.0


def test_ceil_cross_with_first_thicknesses_tops_at_12():
    s = layer_schedule(0.0, 12.0, layer_height=1.5, thicknesses=CROSS_FIRST)
    # 2.0 + 1.8 + 5 × 1.5 = 11.3; the 0.7 mm left (0.47 of a layer) is merged into the layer below
    np.testing.assert_allclose(s.tops, [2.0, 3.8, 5.3, 6.8, 8.3, 9.8, 12.0], atol=1e-12)
    np.testing.assert_allclose(s.thickness, [2.0, 1.8, 1.5, 1.5, 1.5, 1.5, 2.2], atol=1e-12)
    assert s.tops[-1] == 12.0
    assert s.fit.action == "thickened" and s.fit.layer == 6
    np.testing.assert_allclose(s.cuts[-1], 10.9)  # mid-layer of the thickened layer
    np.testing.assert_allclose(np.cumsum(s.thickness)[-1], 12.0)  # layers stack without gap


def test_ceil_thins_a_listed_layer_that_would_pass_the_top():
    s = layer_schedule(0.0, 3.0, layer_height=1.5, thicknesses=CROSS_FIRST)
    # after the 2.0 mm layer 1.0 mm is left: 0.56 of the listed 1.8 mm layer → thinned to 1.0
    np.testing.assert_allclose(s.tops, [2.0, 3.0])
    np.testing.assert_allclose(s.thickness, [2.0, 1.0])
    assert s.fit.nominal == 1.8


def test_ceil_whole_layers_unchanged_within_tolerance():
    s = layer_schedule(0.0, 450.0, layer_height=1.5)  # the bracket
    assert len(s) == 300 and s.fit.action == "exact"
    np.testing.assert_allclose(s.tops, 1.5 * np.arange(1, 301), rtol=0, atol=1e-12)
    assert (s.thickness == 1.5).all()
    # a top within TOL.join of a whole layer (a float32 STL) does not add a sliver layer
    s = layer_schedule(0.0, 30.0 + 0.5 * TOL.join, layer_height=2.0)
    assert len(s) == 15 and (s.thickness == 2.0).all() and s.fit.action == "exact"
    # beyond it, a 0.2 mm remainder (0.1 of a layer) is merged: the top is reached exactly
    s = layer_schedule(0.0, 30.2, layer_height=2.0)
    assert len(s) == 15 and s.tops[-1] == 30.2
    assert s.thickness[-1] == pytest.approx(2.2, abs=1e-12)


def test_ceil_overshoot_when_no_layer_can_take_the_remainder():
    # 0.4 mm of part at 1.5 mm layers: too thin for a layer (< 0.75) and no layer below to thicken
    s = layer_schedule(0.0, 0.4, layer_height=1.5)
    assert len(s) == 1 and s.fit.action == "overshoot"
    assert s.thickness[0] == pytest.approx(0.75) and s.tops[0] == pytest.approx(0.75)
    assert s.fit.gap == pytest.approx(-0.35)
    assert s.cuts[0] == pytest.approx(0.2)  # cut in the part's material, not above it
    # the merge limit: 10.3 mm at 1 mm with thickening to at most 1.2×: 0.3 mm left → one layer more
    s = layer_schedule(0.0, 10.3, layer_height=1.0, max_factor=1.2)
    assert len(s) == 11 and s.fit.action == "overshoot"
    assert s.tops[-1] == pytest.approx(10.5) and s.thickness[-1] == pytest.approx(0.5)
    assert s.fit.gap == pytest.approx(-0.2) and s.cuts[-1] == pytest.approx(10.15)


def test_ceil_with_z_range_and_start_offset():
    s = layer_schedule(0.0, 30.0, layer_height=2.0, z_min=3.0, z_max=20.0)
    # 17 mm from 3 to 20: 8 layers to 19, then 1.0 mm (0.5 of a layer) thinned
    assert len(s) == 9 and s.tops[-1] == 20.0 and s.thickness[-1] == pytest.approx(1.0)
    s = layer_schedule(5.0, 15.0, layer_height=1.5, start_offset=0.75)
    assert s.tops[-1] == 15.0 and s.thickness[-1] == pytest.approx(1.75)


def test_layer_count_keeps_only_the_first_layers():
    s = layer_schedule(0.0, 12.0, layer_height=1.5, layer_count=8)
    assert len(s) == 8 and s.tops[-1] == 12.0 and s.total == 8
    s = layer_schedule(0.0, 31.0, layer_height=2.0, layer_count=3)
    np.testing.assert_allclose(s.tops, [2.0, 4.0, 6.0])
    assert s.total == 16 and s.fit.reached == 31.0


# ---------------------------------------------------------------------------- nearest, exact
def test_nearest_is_the_old_rounding_with_its_gap():
    s = layer_schedule(0.0, 31.0, layer_height=2.0, top_policy="nearest")
    assert len(s) == 15 and s.tops[-1] == 30.0 and s.fit.gap == pytest.approx(1.0)
    s = layer_schedule(0.0, 12.0, layer_height=1.5, thicknesses=CROSS_FIRST, top_policy="nearest")
    assert s.tops[-1] == pytest.approx(11.3) and s.fit.gap == pytest.approx(0.7) and s.fit.layer == 6
    s = layer_schedule(0.0, 31.2, layer_height=2.0, top_policy="nearest")  # 0.6 of a layer left: rounds up
    assert s.tops[-1] == 32.0 and s.fit.gap == pytest.approx(-0.8)


def test_exact_fails_with_heights_that_fit():
    with pytest.raises(PlanningError) as err:
        layer_schedule(0.0, 31.0, layer_height=2.0, top_policy="exact")
    msg = str(err.value)
    assert err.value.exit_code == 3
    for text in ("31 mm", "2 mm", "15.5 layers", "1.9375 mm (16 layers)", "2.0667 mm (15 layers)"):
        assert text in msg
    assert err.value.layer == 15
    with pytest.raises(PlanningError) as err:
        layer_schedule(0.0, 12.0, layer_height=1.5, thicknesses=CROSS_FIRST, top_policy="exact")
    # 8.2 mm above the listed 3.8 mm: 5.4667 layers of 1.5
    for text in ("12 mm", "1.5 mm", "8.2 mm", "1.3667 mm (6 layers)", "1.64 mm (5 layers)"):
        assert text in str(err.value)
    s = layer_schedule(0.0, 12.0, layer_height=1.5, top_policy="exact")
    assert len(s) == 8 and s.fit.action == "exact"
    # with z_max the layers aim at z_max, and the message says so
    with pytest.raises(PlanningError) as err:
        layer_schedule(0.0, 30.0, layer_height=2.0, z_min=3.0, z_max=20.0, top_policy="exact")
    for text in ("17 mm (from 3 to z_max 20 mm)", "1.8889 mm (9 layers)", "2.125 mm (8 layers)"):
        assert text in str(err.value)


# ---------------------------------------------------------------------------- meshes and node
def test_slice_part_31_mm_box_reaches_its_top():
    layers = slice_part(as_mesh(box((10, 10, 31))), layer_height=2.0)
    assert len(layers) == 16 and layers[-1].z == 31.0 and layers[-1].thickness == pytest.approx(1.0)
    assert all(l.area == pytest.approx(100.0) for l in layers)
    layers = slice_part(as_mesh(box((10, 10, 0.4))), layer_height=1.5)  # overshoot layer: cut inside
    assert len(layers) == 1 and layers[0].area == pytest.approx(100.0)
    old = slice_part(as_mesh(box((10, 10, 31))), layer_height=2.0, top="nearest")
    assert old[-1].z == 30.0


def _recipe(stl: str, slice_params: dict) -> dict:
    return {
        "format": "waamflow/1",
        "name": "t",
        "nodes": [
            {"id": "part", "type": "mesh", "params": {"path": stl}},
            {"id": "layers", "type": "slice", "params": slice_params},
        ],
        "edges": [{"from": "part.mesh", "to": "layers.mesh"}],
    }


def _run(tmp_path, stl, params):
    return execute(build_graph(parse_recipe(_recipe(stl, params))), resolver=FileResolver(tmp_path))


def test_node_ceil_writes_the_thinned_last_layer(tmp_path):
    box((10, 10, 31)).export(tmp_path / "b.stl")
    res = _run(tmp_path, "b.stl", {"layer_height": 2.0})
    doc = json.loads(res.artifacts["layers.layers.json"])["layers"]
    assert len(doc) == 16 and (doc[-1]["index"], doc[-1]["z"], doc[-1]["thickness"]) == (15, 31.0, 1.0)
    assert (doc[0]["z"], doc[0]["thickness"]) == (2.0, 2.0)
    assert res.warnings == []


def test_node_cross_thicknesses_reach_12(tmp_path):
    res = _run(GRAPHS, "parts/cross.stl", {"layer_height": 1.5, "thicknesses": CROSS_FIRST})
    layers = res.outputs["layers"]["layers"]
    assert [round(l.z, 9) for l in layers] == [2.0, 3.8, 5.3, 6.8, 8.3, 9.8, 12.0]
    assert layers[-1].thickness == pytest.approx(2.2) and res.warnings == []


def test_node_nearest_warns_with_the_gap(tmp_path):
    box((10, 10, 31)).export(tmp_path / "b.stl")
    res = _run(tmp_path, "b.stl", {"layer_height": 2.0, "top": "nearest"})
    assert res.outputs["layers"]["layers"][-1].z == 30.0
    [w] = res.warnings
    assert w["layer"] == 14 and w["node"] == "layers"
    assert "30 mm" in w["message"] and "1 mm below" in w["message"] and "31 mm" in w["message"]
    res = _run(
        tmp_path, "b.stl", {"layer_height": 1.5, "top": "nearest"}
    )  # 20 layers reach 30; the 1 mm left is over half a layer: rounds up to 31.5
    [w] = res.warnings
    assert w["layer"] == 20 and "0.5 mm above" in w["message"]


def test_node_exact_fails_with_exit_3(tmp_path):
    box((10, 10, 31)).export(tmp_path / "b.stl")
    with pytest.raises(PlanningError) as err:
        _run(tmp_path, "b.stl", {"layer_height": 2.0, "top": "exact"})
    assert err.value.exit_code == 3 and err.value.node == "layers" and err.value.layer == 15
    assert "1.9375 mm (16 layers)" in str(err.value) and "2.0667 mm (15 layers)" in str(err.value)


def test_node_overshoot_and_layer_count_are_warned(tmp_path):
    box((10, 10, 10.3)).export(tmp_path / "b.stl")
    res = _run(tmp_path, "b.stl", {"layer_height": 1.0, "top_max_factor": 1.2})
    [w] = res.warnings
    assert w["layer"] == 10 and "0.2 mm above" in w["message"] and "10.3 mm" in w["message"]
    res = _run(GRAPHS, "parts/cross.stl", {"layer_height": 1.5, "layer_count": 2})
    [w] = res.warnings
    assert w["layer"] == 1 and "first 2 of 8 layers" in w["message"] and "9 mm below" in w["message"]
    res = _run(GRAPHS, "parts/cross.stl", {"layer_height": 1.5, "layer_count": 8})
    assert res.warnings == []


@pytest.mark.parametrize(
    "stl, height, layers", [("bracket.stl", 1.5, 300), ("cross.stl", 1.5, 8), ("slotted-wall.stl", 1.5, 10)]
)
def test_shipped_parts_keep_their_whole_layers(stl, height, layers):
    z = trimesh.load(GRAPHS / "parts" / stl).bounds[:, 2]
    s = layer_schedule(float(z[0]), float(z[1]), layer_height=height)
    assert len(s) == layers and s.fit.action == "exact"
    np.testing.assert_allclose(s.tops, z[0] + height * np.arange(1, layers + 1), atol=1e-12)
