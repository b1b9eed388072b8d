"""Controller model on general programs: dwells, zones, speed changes, exact stops, layers."""

import numpy as np
import pytest

from waamflow.core.model import Layer, LayerPaths, Layered, SectionPath
from waamflow.core.moves import flatten
from waamflow.trajectory.profile import load_profile
from waamflow.trajectory.simulate import SimOptions, simulate

KUKA = load_profile("kuka_kr100ha_krc2").with_values(backlash_start_mm=0.0, backlash_end_mm=0.0)
L_SHAPE = np.array([[0, 0, 5], [60, 0, 5], [60, 40, 5], [120, 40, 5]], float)


def section(points, speed=20.0, zone=(), zone_params=None, key="bs1/A", arc=None):
    m = len(points) - 1
    return SectionPath(
        key=key,
        strategy="t",
        points=np.asarray(points, float),
        arc=np.ones(m, bool) if arc is None else np.asarray(arc, bool),
        inside=np.ones(m, bool),
        speed=np.broadcast_to(np.asarray(speed, float), (m,)).copy(),
        zone=tuple(zone),
        zone_params=zone_params or {},
    )


def moves(*layers):
    return flatten(
        Layered(
            tuple(
                LayerPaths(Layer(index=i, z=5.0 + i, thickness=1.0), secs, dwell_after_s=d)
                for i, (secs, d) in enumerate(layers)
            )
        )
    )


def test_ignition_dwell_adds_time_and_metal():
    base = simulate(moves(((section(L_SHAPE),), 0.0)), KUKA).metrics
    dw = simulate(moves(((section(L_SHAPE),), 0.0)), KUKA, SimOptions(ignition_dwell_s=0.5)).metrics
    assert dw["total_time_s"] - base["total_time_s"] == pytest.approx(0.5, abs=1e-6)
    assert dw["deposited_volume_mm3"] - base["deposited_volume_mm3"] == pytest.approx(0.5 * 94.25, rel=0.01)
    assert dw["actual_length_mm"] == pytest.approx(base["actual_length_mm"], abs=1e-6)


def test_zone_dwell_and_zone_wire_feed():
    zp = {"start": {"wire_feed_speed": 6.0, "dwell": 0.3}, "z1": {"wire_feed_speed": 3.0}}
    sp = section(L_SHAPE, zone=("start", "z1", "z1"), zone_params=zp)
    m = simulate(moves(((sp,), 0.0)), KUKA, SimOptions(wire_diameter_mm=1.2)).metrics
    area = np.pi * 1.2**2 / 4
    rate_start, rate_z1 = 6000 / 60 * area, 3000 / 60 * area
    const = simulate(moves(((sp,), 0.0)), KUKA).metrics
    assert const["total_time_s"] == pytest.approx(m["total_time_s"])  # the dwell is there in both
    # the first 60 mm (plus the 0.3 s dwell) at the start zone's rate, the rest at z1's
    lo, hi = rate_z1 * m["arc_on_time_s"], rate_start * m["arc_on_time_s"]
    assert lo < m["deposited_volume_mm3"] < hi
    assert m["programmed_volume_mm3"] == pytest.approx(60 / 20 * rate_start + 100 / 20 * rate_z1, rel=1e-6)


def test_interlayer_dwell_and_travel_between_layers():
    one = simulate(moves(((section(L_SHAPE),), 0.0)), KUKA).metrics
    up = L_SHAPE[::-1] + [0, 0, 1.0]
    two = simulate(moves(((section(L_SHAPE),), 4.0), ((section(up),), 0.0)), KUKA).metrics
    # second layer starts 1 mm above where the first ended: 4 s dwell + 1 mm travel + a second layer
    assert two["total_time_s"] > 2 * one["total_time_s"] + 4.0
    assert two["total_time_s"] < 2 * one["total_time_s"] + 4.0 + 1.0
    # arc OFF while waiting; the first layer's arc-OFF lag lies inside the two-layer cycle, while a
    # single layer's lag after its last motion is reported apart (arc_off_lag_after_end_s)
    assert two["arc_on_time_s"] == pytest.approx(2 * one["arc_on_time_s"] + one["arc_off_lag_after_end_s"], abs=0.01)
    # in place (same height): the arc still goes OFF for the dwell and ON again
    flat = simulate(moves(((section(L_SHAPE),), 4.0), ((section(L_SHAPE[::-1]),), 0.0)), KUKA).metrics
    assert flat["total_time_s"] == pytest.approx(2 * one["total_time_s"] + 4.0, abs=0.01)
    assert flat["arc_on_time_s"] == pytest.approx(2 * one["arc_on_time_s"] + one["arc_off_lag_after_end_s"], abs=0.01)


def test_exact_stops_without_blending():
    blended = simulate(moves(((section(L_SHAPE, 40.0),), 0.0)), KUKA).metrics
    exact = simulate(moves(((section(L_SHAPE, 40.0),), 0.0)), KUKA, SimOptions(cdis=0.0)).metrics
    assert exact["max_corner_error_mm"] < 0.02
    assert blended["max_corner_error_mm"] > 0.3
    assert exact["total_time_s"] > blended["total_time_s"]
    assert exact["actual_length_mm"] == pytest.approx(160.0, abs=0.05)


def test_blend_geometry_at_low_speed():
    """At 5 mm/s the controller smoothing barely cuts: corner errors are the blend geometry's."""
    arc = simulate(moves(((section(L_SHAPE, 5.0),), 0.0)), KUKA, SimOptions(cdis=5.0)).metrics
    par = simulate(moves(((section(L_SHAPE, 5.0),), 0.0)), KUKA, SimOptions(cdis=5.0, blend="zone")).metrics
    # KUKA-like: blending starts d = apo_min + v·apo_time before the vertex (not the whole CDIS
    # at this speed); arc apex d·tan(α/4) from the vertex, α = 90°
    d = KUKA.apo_min_mm + 5.0 * KUKA.apo_time_s
    assert arc["max_corner_error_mm"] == pytest.approx(d * np.tan(np.pi / 8), abs=0.05)
    # ABB-like zone 5 mm: parabola apex d·cos(45°)/2 = 1.77 mm from the vertex
    assert par["max_corner_error_mm"] == pytest.approx(5 * np.cos(np.pi / 4) / 2, abs=0.1)


def test_speed_change_on_a_straight_line_without_stop():
    line = np.array([[0, 0, 5], [50, 0, 5], [100, 0, 5]], float)
    res = simulate(moves(((section(line, speed=[40.0, 10.0]),), 0.0)), KUKA)
    tr = res.trace
    assert res.metrics["stops"] == 2
    at_change = np.abs(tr["x"] - 50.0) < 0.5
    assert tr["speed"][at_change].min() > 5.0  # no stop at the speed change
    # the interpolator reaches 10 mm/s at the boundary; the smoothing settles within ~1 mm after
    after = (tr["x"] > 52.0) & (tr["x"] < 60.0)
    assert tr["speed"][after].max() < 10.5
    mid_first = np.abs(tr["x"] - 25.0) < 1.0
    assert tr["speed"][mid_first].mean() == pytest.approx(40.0, rel=0.02)
    assert res.metrics["total_time_s"] == pytest.approx(50 / 40 + 50 / 10, rel=0.08)


def test_arc_off_travel_section_change_stops_and_counts_outside():
    a = section(L_SHAPE, key="bs1/A")
    b = section(L_SHAPE + [0, 60, 0], key="bs1/B")
    res = simulate(moves(((a, b), 0.0)), KUKA)
    m = res.metrics
    assert res.section_keys == ("bs1/A", "bs1/B")
    assert m["stops"] == 4  # start, A off, B on, end
    assert m["time_outside_s"] > 60 / 100  # the 60 mm arc-OFF travel at 100 mm/s
    assert set(np.unique(res.trace["section"])) == {0, 1}


def test_no_motion_is_a_planning_error():
    from waamflow.core.errors import PlanningError

    still = np.array([[1, 1, 5], [1, 1, 5]], float)
    with pytest.raises(PlanningError, match="no motion"):
        simulate(moves(((section(still),), 0.0)), KUKA)


def test_long_programs_sample_at_the_cycle_with_the_same_figures(monkeypatch):
    import waamflow.trajectory.fine as sim_mod
    from waamflow.trajectory import study

    fine = simulate(study.planned("triangular", 40.0, angle_deg=45.0), KUKA).metrics
    monkeypatch.setattr(sim_mod, "MAX_FINE_SAMPLES", 0)
    coarse = simulate(study.planned("triangular", 40.0, angle_deg=45.0), KUKA).metrics
    for k in ("total_time_s", "actual_length_mm", "deposited_volume_mm3", "max_corner_error_mm"):
        assert coarse[k] == pytest.approx(fine[k], rel=0.01), k


def test_random_programs_keep_the_bookkeeping():
    """Random polylines (duplicates, reversals, tiny and long moves, arc switches, dwells, both
    blend modes): time increases, metrics are finite, the per-segment deposit adds up to the
    total, time splits into inside + outside, the path never gets longer than programmed."""
    from waamflow.core.errors import PlanningError

    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(30):
        layers = []
        for li in range(int(rng.integers(1, 3))):
            secs = []
            for si in range(int(rng.integers(1, 3))):
                n = int(rng.integers(2, 25))
                pts = np.cumsum(rng.normal(0, rng.choice([0.05, 1, 10]), (n, 3)) * [1, 1, 0.1], axis=0) + [0, 0, 5 + li]
                if rng.random() < 0.3:
                    pts[rng.integers(1, n)] = pts[rng.integers(0, n - 1)]
                if rng.random() < 0.3 and n > 3:
                    pts[2] = pts[0]  # exact reversal
                m = n - 1
                secs.append(
                    SectionPath(
                        key=f"s{si}",
                        strategy="f",
                        points=pts,
                        arc=rng.random(m) < 0.8,
                        inside=rng.random(m) < 0.7,
                        speed=rng.choice([5.0, 10.0, 40.0, 100.0], m),
                    )
                )
            layers.append(
                LayerPaths(
                    Layer(index=li, z=5.0 + li, thickness=1.0), tuple(secs), dwell_after_s=float(rng.choice([0.0, 0.5]))
                )
            )
        mv = flatten(Layered(tuple(layers)))
        opt = SimOptions(
            cdis=float(rng.choice([0.0, 1.0, 5.0])),
            blend=str(rng.choice(["cdis", "zone"])),
            ignition_dwell_s=float(rng.choice([0.0, 0.3])),
        )
        try:
            res = simulate(mv, KUKA, opt)
        except PlanningError:
            continue
        m = res.metrics
        assert np.all(np.diff(res.trace["t"]) > 0)
        assert all(np.isfinite(v) for v in m.values())
        total = (res.deposit["actual_mm3_per_mm"] * res.deposit["length_mm"]).sum()
        assert total == pytest.approx(m["deposited_volume_mm3"], rel=1e-9, abs=1e-9)
        assert m["time_inside_s"] + m["time_outside_s"] == pytest.approx(m["total_time_s"], abs=1e-9)
        assert m["actual_length_mm"] <= m["programmed_length_mm"] + 1e-6
        checked += 1
    assert checked >= 25
