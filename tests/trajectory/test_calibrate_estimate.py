"""Calibration from a measured trace, trace CSV errors, and the closed-form estimate."""

import pytest

from waamflow.core.errors import InputFileError
from waamflow.trajectory import study
from waamflow.trajectory.calibrate import fit_trace, read_trace_csv, trace_csv
from waamflow.trajectory.estimate import cycle_time, estimate_moves, model_params
from waamflow.trajectory.profile import load_profile
from waamflow.trajectory.simulate import simulate

KUKA = load_profile("kuka_kr100ha_krc2")


def test_trace_csv_round_trip():
    res = simulate(study.raster(40.0), KUKA)
    meas = read_trace_csv(trace_csv(res))
    assert len(meas.t) == len(res.trace["t"])
    assert meas.xyz[-1] == pytest.approx([res.trace["x"][-1], res.trace["y"][-1], res.trace["z"][-1]], abs=1e-4)
    assert meas.arc.sum() == res.trace["arc"].sum()


@pytest.mark.parametrize(
    "text,row",
    [
        ("t,x,y,z\n0,0,0,0\n0.012,1,0,abc\n", 3),
        ("t,x,y,z\n0,0,0,0\n0.012,1,0\n", 3),
        ("t,x,y,z\n0,0,0,0\n0.012,1,0,0\n0.010,2,0,0\n", 4),
        ("t,x,y,z,arc\n0,0,0,0,1\n0.012,1,0,0,maybe\n", 3),
        ("t,x,y,z\n0,0,0,0\n\n0.012,nan,0,0\n", 4),
    ],
)
def test_bad_trace_rows_name_the_row(text, row):
    with pytest.raises(InputFileError, match=f"row {row}:"):
        read_trace_csv(text, source="m.csv")


def test_trace_csv_blocks_write_what_one_row_at_a_time_writes(monkeypatch):
    """trace_csv writes a block of rows per buffer (core.fixedtext): byte for byte the rows %
    formats one by one, across block edges (a 7-row block: hundreds of edges) and with a short
    last block."""
    import numpy as np

    from waamflow.trajectory import trace

    res = simulate(study.raster(40.0), KUKA)
    tr = res.trace
    rows = np.column_stack([tr["t"], tr["x"], tr["y"], tr["z"], tr["speed"], tr["arc"].astype(float), tr["deviation"]])
    one_by_one = "t,x,y,z,speed,arc,deviation\n" + "".join(
        "%.4f,%.4f,%.4f,%.4f,%.3f,%d,%.4f\n" % tuple(r) for r in rows.tolist()
    )
    assert len(rows) % 7 != 0 and len(rows) > 700
    monkeypatch.setattr(trace, "_CSV_BLOCK", 7)
    assert trace.trace_csv(res) == one_by_one
    monkeypatch.setattr(trace, "_CSV_BLOCK", 8192)
    assert trace.trace_csv(res) == one_by_one


def test_trace_csv_needs_the_columns():
    with pytest.raises(InputFileError, match="missing"):
        read_trace_csv("t,x,y\n0,0,0\n")


def test_fit_recovers_the_constants_of_a_known_robot():
    """Measure a 'robot' with known constants on a triangular program, then fit a wrong profile."""
    truth = KUKA.with_values(path_acc=900.0, smoothing_s=0.09, backlash_start_mm=0.0, backlash_end_mm=0.0)
    program = study.triangular(40.0, 60.0)
    meas = read_trace_csv(trace_csv(simulate(program, truth)))
    start = truth.with_values(path_acc=500.0, smoothing_s=0.15)
    fitted, info = fit_trace(start, program, meas, ("path_acc", "smoothing_s"))
    assert info["cost_after"] < 0.05 * info["cost_before"]
    assert fitted.path_acc == pytest.approx(900.0, rel=0.1)
    assert fitted.smoothing_s == pytest.approx(0.09, rel=0.1)
    assert info["rms_position_error_mm"] < 0.05


def test_cycle_time_formula_by_hand():
    p = study.IDENTIFIED[(40, "on")]
    n, L, TS = 5, 43.0, 40.0
    by_hand = 0.204 + (43 - 4.212 - 2.5) / 40 + 4 * 0.426 + 3 * (43 - 2.2 - 2.5) / 40 + (43 - 2.2 - 3.862) / 40 + 0.192
    assert cycle_time(n, L, TS, p) == pytest.approx(by_hand, abs=1e-12)
    assert by_hand == pytest.approx(6.803, abs=1e-3)


def test_model_params_interpolate_in_speed():
    p = model_params(KUKA.time_model, 25.0, "on")
    assert p["T_init_accel"] == pytest.approx((0.144 + 0.204) / 2)
    assert model_params(KUKA.time_model, 60.0, "off")["T_trans"] == pytest.approx(0.408)


def test_estimate_of_a_study_program_and_beside_the_simulation():
    mv = study.planned("triangular", 40.0, angle_deg=45.0)
    est = estimate_moves(mv, KUKA.time_model, 100.0)
    assert est.passes == 5
    assert est.total_time_s == pytest.approx(cycle_time(5, 43.0, 40.0, study.IDENTIFIED[(40, "on")]), abs=1e-5)
    sim = simulate(mv, KUKA).metrics["total_time_s"]
    assert sim == pytest.approx(est.total_time_s, rel=0.05)  # MODEL.md per-case table: +2.9 %


def test_shipped_profile_is_strict_json_and_documents_its_fit():
    import json

    from waamflow.trajectory.calibrate import SHIPPED_FIT, study_targets
    from waamflow.trajectory.profile import ROBOTS_DIR, shipped_profiles

    assert "kuka_kr100ha_krc2" in shipped_profiles()

    def no_nan(c):
        raise ValueError(f"non-strict JSON constant {c}")

    d = json.loads((ROBOTS_DIR / "kuka_kr100ha_krc2.json").read_text(), parse_constant=no_nan)
    assert set(d["fit"]["fitted"]) == set(SHIPPED_FIT)
    assert len(d["fit"]["targets"]) == len(study_targets()) and "validation" in d["fit"]
    assert "least_squares" in d["notes"]
    for k in SHIPPED_FIT:
        assert getattr(KUKA, k) == d[k]


@pytest.mark.parametrize(
    "pattern,kw", [("semicircular", {}), ("triangular", {"angle_deg": 90.0}), ("rectangular", {}), ("parallel", {})]
)
def test_generalised_estimate_at_10_mm_s(pattern, kw):
    """Per-pass lengths and transitions scaled from the identified link: within 3 % of the
    simulation at 10 mm/s on the study's other strategies (the closed form ignores corner
    slow-downs, which matter more at 40 mm/s)."""
    mv = study.planned(pattern, 10.0, **kw)
    est = estimate_moves(mv, KUKA.time_model, 100.0).total_time_s
    assert est == pytest.approx(simulate(mv, KUKA).metrics["total_time_s"], rel=0.03)
