"""Travel speed per segment from the bead model: planar layers use the thickness, fan layers r·Δθ."""

import math

import numpy as np
import pytest
from shapely.geometry import MultiPolygon, box

from waamflow.core.model import Layer, LayerPaths, SectionPath
from waamflow.curved.bead import BeadModel
from waamflow.curved.fan import FanAxis
from waamflow.curved.speeds import apply_bead_model, layer_report


def path(points, arc=None):
    pts = np.asarray(points, float)
    n = len(pts) - 1
    return SectionPath(
        "s", "wall", pts, np.ones(n, bool) if arc is None else np.asarray(arc, bool), np.ones(n, bool), np.full(n, 5.0)
    )


def test_planar_layer_speed_from_thickness():
    layer = Layer(0, 2.49, 2.49)
    lp = LayerPaths(layer, (path([[0, 0, 2.49], [10, 0, 2.49], [20, 0, 2.49]], arc=[True, False]),))
    out = apply_bead_model(lp, BeadModel())
    v = BeadModel().speed_for_height(2.49)[0][0] / 60.0
    assert out.sections[0].speed.tolist() == pytest.approx([v, 5.0])  # arc-off segment keeps its speed
    assert v * 60 == pytest.approx(838.8, abs=0.5)


def test_fan_layer_speed_from_radius():
    axis = FanAxis(np.zeros(3), np.array([0.0, -1.0, 0.0]), np.array([1.0, 0.0, 0.0]))
    dth = math.radians(1.5)
    region = MultiPolygon([box(80, -5, 120, 5)])
    layer = Layer(0, 1.0, region.centroid.x * dth, region=region, frame=axis.frame(dth))
    local = np.array([[85.0, 0.0], [95.0, 0.0], [105.0, 0.0], [115.0, 0.0]])
    lp = LayerPaths(layer, (path(layer.to_world(local)),))
    out = apply_bead_model(lp, BeadModel())
    need = np.array([90.0, 100.0, 110.0]) * dth  # 2.356, 2.618, 2.880 mm
    assert np.allclose(BeadModel().height(out.sections[0].speed * 60), need, atol=1e-9)
    assert np.all(np.diff(out.sections[0].speed) < 0)  # farther from the axis: slower, taller
    row = layer_report(out, BeadModel())
    assert row["clamped"] == 0 and row["r_min_mm"] == pytest.approx(85.0) and row["r_max_mm"] == pytest.approx(115.0)
    assert row["csratio"] == pytest.approx(100 / 30)
    # 3° layers need 4.7..5.8 mm: every segment clamped to the slowest speed
    thick = Layer(0, 1.0, region.centroid.x * 2 * dth, region=region, frame=axis.frame(2 * dth))
    lp2 = LayerPaths(thick, (path(thick.to_world(local)),))
    out2 = apply_bead_model(lp2, BeadModel())
    assert out2.sections[0].speed.tolist() == pytest.approx([400 / 60] * 3)
    assert layer_report(out2, BeadModel())["clamped"] == 3
