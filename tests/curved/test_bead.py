"""Bead-height model of Rauch et al. 2021 and the CSratio rule."""

import math

import numpy as np
import pytest

from waamflow.curved.bead import BeadModel, csratio, dtheta_window, min_csratio

# the study's measured mean heights (mm) at its travel speeds (mm/min)
MEASURED = {500: 3.04, 675: 2.61, 850: 2.49, 1025: 2.34, 1200: 2.17}


def test_model_matches_measured_means_within_fit_error():
    m = BeadModel()
    for ts, h in MEASURED.items():
        assert float(m.height(ts)) == pytest.approx(h, abs=0.15)
    assert float(m.height(850)) == pytest.approx(2.4773, abs=1e-4)
    assert m.h_range == pytest.approx((2.23588, 3.22852), abs=1e-5)


def test_inverse_returns_the_speed():
    m = BeadModel()
    ts = np.linspace(400, 1200, 81)
    back, out = m.speed_for_height(m.height(ts))
    assert np.allclose(back, ts, atol=1e-6) and not out.any()
    # measured 2.49 mm at 850 mm/min: the inverse gives a speed within the fit's scatter
    v, _ = m.speed_for_height(2.49)
    assert v[0] == pytest.approx(838.8, abs=0.5)
    assert abs(v[0] - 850) < 50


def test_out_of_range_heights_are_clamped_and_flagged():
    v, out = BeadModel().speed_for_height([2.0, 2.5, 3.5])
    assert v.tolist() == pytest.approx([1200.0, 830.135, 400.0], abs=1e-3)
    assert out.tolist() == [True, False, True]


def test_other_materials_and_invalid_models():
    lin = BeadModel(0.0, -0.002, 4.0, 300, 900)  # linear fit: H 3.4 → 2.2
    v, _ = lin.speed_for_height(3.0)
    assert v[0] == pytest.approx(500.0)
    with pytest.raises(ValueError, match="monotonic"):
        BeadModel(1e-5, -0.016, 8.0, 400, 1200)  # vertex at 800 mm/min
    with pytest.raises(ValueError):
        BeadModel(ts_min=1200, ts_max=400)
    # a0 = 1 with the study's a1, a2: heights -1.08..-0.08 mm over 400..1200 mm/min. It was taken,
    # and a bead node with it failed later as `ValueError: need 0 < H_min < H_max` (API fuzz)
    with pytest.raises(ValueError, match=r"H\(Ts\) reaches -1\.077 mm at Ts = 1200 mm/min: .*a0"):
        BeadModel(1.2245e-06, -0.0032, 1.0, 400, 1200)
    assert BeadModel(1.2245e-06, -0.0032, 4.3126, 400, 1200).h_range[0] == pytest.approx(2.23588)


def test_a_bead_node_with_a_model_of_no_height_is_refused_where_it_is_set():
    from waamflow.core.errors import RecipeError
    from waamflow.engine.graph import _validate_params
    from waamflow.nodes.curved import BeadModelNode

    with pytest.raises(RecipeError, match=r"H\(Ts\) reaches -1\.077 mm") as err:
        _validate_params("bead", BeadModelNode, {"a0": 1.0})
    assert err.value.node == "bead"


def test_min_csratio_bound():
    assert min_csratio(2.2, 3.2) == pytest.approx(2.7, abs=1e-12)
    assert csratio(83.5, 116.5) == pytest.approx(100 / 33)
    # CSratio ≥ its minimum ⇔ r_min/r_max ≥ H_min/H_max ⇔ a Δθ fits both ends
    rng = np.random.default_rng(3)
    for _ in range(200):
        r_min = rng.uniform(10, 200)
        r_max = r_min + rng.uniform(0.5, 100)
        lo, hi = dtheta_window(r_min, r_max, 2.2, 3.2)
        ok = csratio(r_min, r_max) >= min_csratio(2.2, 3.2)
        assert ok == (r_min / r_max >= 2.2 / 3.2) == (lo <= hi)


def test_dtheta_window():
    lo, hi = dtheta_window(83.5, 116.5, 2.2, 3.2)
    assert math.degrees(lo) == pytest.approx(1.50959, abs=1e-4)
    assert math.degrees(hi) == pytest.approx(1.57379, abs=1e-4)
