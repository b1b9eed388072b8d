"""Artifact JSON (core/serialize.py): orjson with numpy arrays writes exactly what json.dumps of
the lists writes, and refuses NaN/infinity as json.dumps(allow_nan=False) does."""

import json
import math

import numpy as np
import pytest
from shapely.geometry import Polygon

from waamflow.core import serialize
from waamflow.core.model import Layer, LayerPaths, Layered, SectionPath, as_multipolygon


def _layers():
    th = np.linspace(0, 2 * math.pi, 181)[:-1]
    ring = Polygon(np.c_[80 * np.cos(th), 80 * np.sin(th)], [np.c_[74 * np.cos(th), 74 * np.sin(th)][::-1]])
    frame = np.eye(4)
    frame[:3, 3] = [1.23456789, -0.00004, 2.0]
    return Layered(
        tuple(Layer(i, 1.5 * (i + 1), 1.5, as_multipolygon(ring), frame=frame if i % 2 else None) for i in range(5))
    )


def _toolpath(layers):
    out = []
    for lay in layers:
        pts = lay.to_world(np.c_[np.linspace(0, 100, 41), np.sin(np.linspace(0, 3, 41)) * 7.123456])
        n = len(pts) - 1
        sp = SectionPath(
            "bs1/A",
            "parallel",
            pts,
            np.arange(n) % 3 > 0,
            np.ones(n, bool),
            np.full(n, 6.5),
            tool_axis=np.tile([0.0, 0.0, -1.0], (len(pts), 1)),
        )
        out.append(LayerPaths(lay, (sp,)))
    return Layered(tuple(out))


def test_artifact_json_is_byte_identical_to_json_dumps_of_the_lists():
    layers = _layers()
    for doc in (serialize.layers_json(layers), serialize.toolpath_json(_toolpath(layers))):
        text = serialize.dumps(doc)
        reference = json.dumps(json.loads(text), separators=(",", ":"), allow_nan=False)
        assert text == reference
        assert len(text) > 10_000
    lay = json.loads(serialize.dumps(serialize.layers_json(layers)))["layers"]
    assert len(lay) == 5 and len(lay[0]["polygons"][0]["exterior"]) == 181
    assert lay[1]["frame"][0][3] == 1.2346 and lay[1]["frame"][1][3] == -0.0
    assert isinstance(serialize.coords([[1.0, 2.0]]), list)  # the API's per-layer forms stay lists


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), np.array([1.0, np.nan])])
def test_nan_or_infinity_is_an_error(bad):
    with pytest.raises(ValueError, match="not JSON compliant"):
        serialize.dumps({"layers": [{"z": 1.0, "v": bad}]})


@pytest.mark.parametrize(
    "bad",
    [
        [0.5, 2.0, float("nan")],  # a list of numbers (checked in one sum)
        [1, True, float("-inf")],
        [None, 3.0, float("inf")],  # speeds with null: element by element
        ["z1", {"a": [1.0, float("nan")]}],  # nested under a string
        (1e308, float("inf")),
    ],
)
def test_non_finite_values_are_found_in_every_kind_of_list(bad):
    with pytest.raises(ValueError, match="not JSON compliant"):
        serialize.dumps({"layers": [{"v": bad}]})


def test_finite_lists_pass_even_when_their_sum_would_overflow():
    doc = {"big": [1e308, 1e308, -1e308], "zones": ["start", "z1", "end"], "mixed": [None, 1.5, "x", True]}
    assert json.loads(serialize.dumps(doc))["big"] == [1e308, 1e308, -1e308]


def test_a_report_is_indented_json_that_reads_back_the_same_with_no_value_as_null():
    """`dumps_report` (preflight.json): the same content as json.dumps, indented 2, UTF-8 text kept
    (a message's "≤" and "°"), numpy figures written as numbers, and a non-finite float as null,
    where json.dumps wrote `NaN`, which a browser's JSON.parse refuses."""
    report = {
        "verdict": "warn",
        "problems": [{"message": "gap ≤ 2 mm at 45°", "value": 0.0014, "point": [1.5, -2.0, 3.25]}],
        "layers": [{"index": k, "uncovered_share": k / 7} for k in range(3)],
        "top_gap_mm": None,
    }
    out = serialize.dumps_report(report)
    assert json.loads(out) == report
    assert "gap ≤ 2 mm at 45°".encode() in out
    assert out.splitlines()[1] == b'  "verdict": "warn",'
    assert json.loads(serialize.dumps_report({"a": float("nan"), "b": np.float64(2.5), "c": np.arange(3)})) == {
        "a": None,
        "b": 2.5,
        "c": [0, 1, 2],
    }
