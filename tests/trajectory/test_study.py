"""The shipped KUKA KR 100 HA + KRC2 profile against the robot study (robot-study.md).

Calibration set: `calibrate.study_targets()` (raster-pass at 40 mm/s, ramps, transitions, corner
errors); the per-case errors of every measured figure are in test_study_validation.py. The
checks here are the study's qualitative observations.
"""

import numpy as np
import pytest

from waamflow.trajectory import study
from waamflow.trajectory.estimate import cycle_time
from waamflow.trajectory.profile import load_profile
from waamflow.trajectory.simulate import simulate

from tolerances_table import STUDY_BANDS

KUKA = load_profile("kuka_kr100ha_krc2")
_cache = {}


def sim(name, build):
    if name not in _cache:
        _cache[name] = simulate(build(), KUKA)
    return _cache[name]


def test_or_pass_layout_and_raster_length():
    assert study.pass_layout(21.5) == (5, pytest.approx(1.89))
    assert study.pass_layout(43.0) == (10, pytest.approx(1.57, abs=0.006))  # study rounds 1.565
    assert study.raster(40).segment_lengths.sum() == pytest.approx(387.910, abs=1e-3)
    assert study.triangular(40, 45).segment_lengths.sum() == pytest.approx(261.301, abs=0.01)


@pytest.mark.parametrize("pattern,key", [("raster", "raster"), ("swiping", "swiping")])
def test_calibration_table_within_5_percent(pattern, key):
    """Time, actual length and deposited volume at 40 mm/s, small OR (waamflow.paths strategies;
    raster is in the calibration set, swiping is held out: MODEL.md per-case table)."""
    m = sim(f"{pattern}40", lambda: study.planned(pattern, 40.0)).metrics
    ref = study.CALIBRATION[key]
    for k in ("total_time_s", "actual_length_mm", "deposited_volume_mm3"):
        assert m[k] == pytest.approx(ref[k], rel=0.05), k


def test_own_raster_reconstruction_matches_too():
    m = sim("raster_own", lambda: study.raster(40.0)).metrics
    assert m["programmed_length_mm"] == pytest.approx(387.910, abs=1e-3)
    assert STUDY_BANDS["raster 40 mm/s total time"].holds(m["total_time_s"])
    assert STUDY_BANDS["raster 40 mm/s deposited volume"].holds(m["deposited_volume_mm3"])


def test_full_stop_at_every_arc_switch():
    # without the transverse backlash transient, so the trace speed is the motion along the path
    res = simulate(study.planned("raster", 40.0), KUKA.with_values(backlash_start_mm=0.0, backlash_end_mm=0.0))
    tr = res.trace
    P = res.programmed
    # every interior vertex of the raster is an arc switch: the nozzle stands still there
    for v in P[1:-1]:
        near = np.hypot(tr["x"] - v[0], tr["y"] - v[1]) < 0.3
        assert near.any()
        assert tr["speed"][near].min() < 0.5
        # and at 40 mm/s it needs ≥ 0.15 s to get going again (jerk-limited ramp + smoothing)
        assert tr["t"][near].max() - tr["t"][near].min() > 0.1
    assert res.metrics["stops"] == len(P)  # 8 switches + both ends
    # arc-ON segments are bracketed by stops: 5 passes deposit, returns do not
    assert res.metrics["arc_on_length_mm"] == pytest.approx(5 * 43.0, rel=0.01)


def test_corner_error_grows_as_the_angle_shrinks_and_with_speed():
    err = {}
    for ang in (90, 60, 45):
        for v in (10, 40):
            r = sim(f"tri{ang}_{v}", lambda: study.planned("triangular", float(v), angle_deg=float(ang)))
            c = r.corners
            mask = np.abs(c["interior_deg"] - ang) < 0.5
            assert mask.any()
            err[ang, v] = c["error_mm"][mask].max()
    assert err[90, 40] < err[60, 40] < err[45, 40]
    for ang in (90, 60, 45):
        assert err[ang, 10] < err[ang, 40]
    assert STUDY_BANDS["corner error 45° 40 mm/s"].holds(err[45, 40])  # measured: 1.62 mm


def test_zigzag_295_corner_errors():
    """Measured 0.8 mm (10 mm/s) and 1.8 mm (40 mm/s) at a 2.95° interior angle."""
    e10 = sim("zz10", lambda: study.reversals(10.0)).metrics["max_corner_error_mm"]
    e40 = sim("zz40", lambda: study.reversals(40.0)).metrics["max_corner_error_mm"]
    assert STUDY_BANDS["corner error 2.95° 10 mm/s"].holds(e10)
    assert STUDY_BANDS["corner error 2.95° 40 mm/s"].holds(e40)


def test_corner_slows_more_when_sharper():
    """Average speed through the corner roughly halves between 157.5° and 2.95° interior angles."""
    tri = sim("tri45_40", lambda: study.planned("triangular", 40.0, angle_deg=45.0)).corners
    zz = sim("zz40", lambda: study.reversals(40.0)).corners
    wide = tri["min_speed_mm_s"][np.abs(tri["interior_deg"] - 157.5) < 0.5].mean()
    sharp = zz["min_speed_mm_s"].mean()
    assert sharp < 0.5 * wide
    # mean speed over the slow-down transient: roughly halves
    ratio = zz["mean_speed_mm_s"].mean() / tri["mean_speed_mm_s"][np.abs(tri["interior_deg"] - 157.5) < 0.5].mean()
    assert 0.4 < ratio < 0.7


def test_semicircular_most_accurate():
    semi = sim("semi40", lambda: study.planned("semicircular", 40.0)).metrics
    for name, kw in (
        ("triangular", {"angle_deg": 45.0}),
        ("triangular", {"angle_deg": 90.0}),
        ("rectangular", {}),
        ("spiral", {}),
        ("swiping", {}),
    ):
        other = sim(f"{name}{kw}", lambda: study.planned(name, 40.0, **kw)).metrics
        assert semi["max_corner_error_mm"] < other["max_corner_error_mm"]
        assert semi["length_ratio"] > other["length_ratio"]


def test_length_ratios():
    """≈0.998 raster, 0.95–0.97 smooth/in-OR strategies, ≈0.89 swiping at 40 mm/s."""
    assert STUDY_BANDS["raster length ratio 40 mm/s"].holds(
        sim("raster40", lambda: study.planned("raster", 40.0)).metrics["length_ratio"]
    )
    # swiping: 0.914 — the derived swiping reverses at 4.4°, the study's at 2.95° (cuts more)
    assert STUDY_BANDS["swiping length ratio 40 mm/s"].holds(
        sim("swiping40", lambda: study.planned("swiping", 40.0)).metrics["length_ratio"]
    )
    for name, kw in (("semicircular", {}), ("triangular", {"angle_deg": 60.0}), ("rectangular", {}), ("spiral", {})):
        r = sim(f"{name}{kw}", lambda: study.planned(name, 40.0, **kw)).metrics["length_ratio"]
        assert STUDY_BANDS["smooth / in-OR length ratio 40 mm/s"].holds(r), name  # study: 0.95–0.97 (see the table)


def test_arc_off_outside_is_slower_and_leaks_inside():
    for v in (10.0, 40.0):
        on = sim(f"tri45on{v}", lambda: study.planned("triangular", v, angle_deg=45.0)).metrics
        off = sim(f"tri45off{v}", lambda: study.planned("triangular", v, angle_deg=45.0, arc_outside="off")).metrics
        assert off["total_time_s"] > on["total_time_s"]
        assert off["stops"] == on["stops"] + 8  # 4 links × 2 boundary crossings
        assert off["arc_off_time_inside_s"] > 0.02
        assert off["deposited_volume_mm3"] < on["deposited_volume_mm3"]


@pytest.mark.parametrize("size", [study.SMALL_OR, study.LARGE_OR])
@pytest.mark.parametrize("v", [10.0, 40.0])
def test_triangular45_against_identified_time_model(size, v):
    """Outside the calibration set: the authors' closed-form model with the identified parameters
    reproduces their arc-ON measurements within 0.4 %; the simulation stays within 5 % of it on
    both OR sizes (identified on the small one; −1.6 … +2.9 %, MODEL.md per-case table)."""
    n, _ = study.pass_layout(size[0])
    ref = cycle_time(n, size[1], v, study.IDENTIFIED[(int(v), "on")])
    t = simulate(study.triangular(v, 45.0, True, size=size), KUKA).metrics["total_time_s"]
    assert t == pytest.approx(ref, rel=0.05)


@pytest.mark.parametrize("v", [10.0, 40.0])
def test_deposit_piles_up_where_the_torch_slows(v):
    res = sim(f"tri45_{v:g}", lambda: study.planned("triangular", v, angle_deg=45.0))
    d = res.deposit
    ratio = d["actual_mm3_per_mm"][d["arc"]] / d["programmed_mm3_per_mm"][d["arc"]]
    # short link segments (the 45° apex slows the torch at either speed) get more metal than
    # programmed (3–5 % at 10 mm/s, 5–8 % at 40 mm/s); long passes close to it
    long_ = d["length_mm"][d["arc"]] > 30
    assert np.median(ratio[long_]) == pytest.approx(1.0, abs=0.1)
    assert ratio[~long_].min() > np.median(ratio[long_]) + 0.025
    assert ratio[~long_].max() > np.median(ratio[long_]) + 0.045
    # volume bookkeeping: per-segment volumes add up to the total
    total = (d["actual_mm3_per_mm"] * d["length_mm"]).sum()
    assert total == pytest.approx(res.metrics["deposited_volume_mm3"], rel=0.01)


def test_straight_line_transients():
    """100 mm at 40 mm/s: +0.2 mm transverse at the start, −0.1 mm at the end, within ±0.03 mm
    in between; acceleration and deceleration at the ends."""
    res = simulate(study.straight_line(40.0), KUKA)
    tr = res.trace
    mid = (tr["x"] > 10) & (tr["x"] < 90)
    assert np.abs(tr["y"][mid]).max() < 0.03
    assert tr["y"][0] == pytest.approx(0.2, abs=0.01)
    assert tr["y"][-1] == pytest.approx(-0.1, abs=0.01)
    assert tr["speed"][mid].mean() == pytest.approx(40.0, rel=0.01)
    # the study's ramps lose (0.204 − 4.212/40) + (0.192 − 3.862/40) = 0.195 s against 40 mm/s
    assert res.metrics["total_time_s"] == pytest.approx(100 / 40 + 0.195, abs=0.05)
