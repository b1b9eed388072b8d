"""Bead models fitted from trials recover a known function from noisy samples."""

import numpy as np
import pytest

from waamflow.core.errors import InputFileError
from waamflow.process.bead_fit import BeadFit, fit_trials, read_trials, Trials


def synthetic(n=40, noise=0.02, seed=3):
    rng = np.random.default_rng(seed)
    wfs = rng.uniform(5, 12, n)          # m/min
    ts = rng.uniform(5, 15, n)           # mm/s
    w = 3.1 * wfs ** 0.55 * ts ** -0.42
    h = 2.4 * wfs ** 0.30 * ts ** -0.35
    return Trials(wfs, ts, w * (1 + noise * rng.standard_normal(n)), h * (1 + noise * rng.standard_normal(n)))


def test_fit_recovers_the_power_law():
    m = fit_trials(synthetic())
    assert m.width.a == pytest.approx(3.1, rel=0.1)
    assert m.width.b == pytest.approx(0.55, abs=0.05) and m.width.c == pytest.approx(-0.42, abs=0.05)
    assert m.height.b == pytest.approx(0.30, abs=0.05) and m.height.c == pytest.approx(-0.35, abs=0.05)
    # the stated standard errors cover the truth (3 sigma)
    assert abs(m.width.b - 0.55) < 3 * m.width.stderr[1]
    assert m.fit["width"]["rmse_mm"] < 0.05 * np.mean(synthetic().width)
    assert len(m.fit["residuals"]) == 40


def test_inverse_and_round_trip():
    m = fit_trials(synthetic(noise=0.0))
    wfs, ts = m.speeds_for(height_mm=2.0, width_mm=5.0)
    assert m.width(wfs, ts) == pytest.approx(5.0, rel=1e-6) and m.height(wfs, ts) == pytest.approx(2.0, rel=1e-6)
    assert m.height(m.wfs_for(2.2, 8.0), 8.0) == pytest.approx(2.2, rel=1e-9)
    back = BeadFit.from_json(m.to_json())
    assert back.width(7.0, 9.0) == pytest.approx(m.width(7.0, 9.0))
    assert m.step_over(6.0) == pytest.approx(4.428)


def test_power_ratio_form():
    t = synthetic(noise=0.0)
    t = Trials(t.wfs, t.ts, 2.0 * (t.wfs / t.ts) ** 0.5, 1.5 * (t.wfs / t.ts) ** 0.3)
    m = fit_trials(t, form="power-ratio")
    assert m.width.b == pytest.approx(0.5, abs=1e-4) and m.width.c == pytest.approx(-0.5, abs=1e-4)
    with pytest.raises(ValueError, match="independently"):
        # both laws depend on WFS/TS only: height and width cannot be chosen apart
        BeadFit(m.width, m.width, m.wfs_range, m.ts_range).speeds_for(2.0, 5.0)


def test_csv_errors_name_row_and_column():
    good = "wfs [m/min],ts [mm/s],width [mm],height [mm]\n8,10,5,2\n9,10,5.5,2.1\n7,8,5,2\n"
    assert len(read_trials(good).wfs) == 3
    with pytest.raises(InputFileError, match="row 3, column 'width"):
        read_trials(good.replace("5.5", "x"))
    with pytest.raises(InputFileError, match="lacks column"):
        read_trials("wfs,ts,width\n1,2,3\n")
