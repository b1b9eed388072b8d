"""The faster paths of the simulation compute exactly what the plain ones did (issue 28 item 3):
chunked nearest segments, row norms, the span positions, the dwell lines of a program."""

from __future__ import annotations

import random

import numpy as np

from waamflow.trajectory import fine, run
from waamflow.trajectory.blend import polyline_distance
from waamflow.trajectory.speedplan import evaluate


def test_row_norms_are_numpys_to_the_bit():
    v = np.random.default_rng(3).normal(scale=[1e-3, 10.0, 1e4], size=(5000, 3))
    assert np.array_equal(fine.row_norms(v), np.linalg.norm(v, axis=1))


def test_chunked_nearest_segment_is_the_polyline_distance(monkeypatch):
    rng = np.random.default_rng(5)
    P = np.cumsum(rng.normal(size=(300, 3)), axis=0)
    guess = np.sort(rng.integers(0, 299, 5000))
    q = P[guess] + rng.random((5000, 1)) * (P[guess + 1] - P[guess]) + rng.normal(scale=0.05, size=(5000, 3))
    want = polyline_distance(q, P, guess, reach=2)
    monkeypatch.setattr(fine, "CHUNK", 777)  # several chunks and a short last one
    got = fine.nearest_segment(q, P, guess, reach=2)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    assert int((got[1] != guess).sum()) > 0  # the search moved some samples off their guess


def test_span_positions_are_evaluates():
    from waamflow.trajectory import study
    from waamflow.trajectory.blend import blend_path
    from waamflow.trajectory.profile import load_profile
    from waamflow.trajectory.speedplan import plan_spans, profile_spans

    kuka = load_profile("kuka_kr100ha_krc2")
    mv = study.planned("triangular", 40.0, angle_deg=45.0)
    P = np.asarray(mv.points, float)
    stop = np.zeros(len(P), bool)
    stop[[0, -1]] = True
    speed = np.full(len(P) - 1, 40.0)
    path = blend_path(P, speed, stop, distance=5.0)
    spans = plan_spans(path, speed, stop, kuka.path_acc, kuka.path_jerk, *kuka.dec)
    prof = profile_spans(spans)
    rng = np.random.default_rng(1)
    si = rng.integers(0, len(prof.duration), 4000)
    tau = rng.random(4000) * prof.duration[si] * 1.1  # beyond the end too
    got = fine._positions(prof, fine._phase_starts(prof), si, tau)
    assert np.array_equal(got, evaluate(prof, si, tau)[0])


def test_dwell_lines_are_the_lines_that_name_a_dwell():
    """As str.splitlines cuts them: CR LF, CR alone, vertical tab and file separators, non-ASCII
    texts (line by line) and dotted capital I (an re.IGNORECASE match of "i")."""

    def plain(text):
        return [line for line in text.splitlines() if run._DWELL_HIT.search(line)]

    pieces = [
        "WAIT SEC 1.5 ; ignition dwell",
        "\n",
        "\r\n",
        "\r",
        "\x0b",
        "\x1c",
        "LIN P1",
        ";- IGNITION DWELL 2 s",
        " ",
        "ignition dwell",
        "\f",
        "G4 P500 ; ignition dwell 0.5 s",
        "é",
        "\u0130gnition dwell",
    ]
    rnd = random.Random(1)
    found = 0
    for trial in range(2000):
        text = "".join(rnd.choice(pieces[:-2] if trial % 2 else pieces) for _ in range(rnd.randint(0, 30)))
        assert run._dwell_lines(text) == plain(text), repr(text)
        found += len(plain(text))
    assert found > 1000
    text = "LIN P1\r\nWAIT SEC 2.5 ; ignition dwell\r\nLIN P2\rWAIT SEC 1 ; Ignition Dwell\n"
    assert run._dwell_lines(text) == ["WAIT SEC 2.5 ; ignition dwell", "WAIT SEC 1 ; Ignition Dwell"]
    assert run.program_settings("krl", {"a.src": text})["ignition_dwells_s"] == (2.5, 1.0)


def test_moving_average_is_the_interpolated_cumulative_sum():
    """Row slices where the window's lower ends are consecutive, gathers where rounding moved
    one: the same numbers as gathering every row (windows of 1 to 37.3 samples, 1 to 40000 rows)."""

    def gathered(x, w):
        npad = int(np.ceil(w))
        pad = np.vstack([np.repeat(x[:1], npad, axis=0), x])
        c = np.vstack([np.zeros((1, x.shape[1])), np.cumsum(pad, axis=0)])
        hi = np.arange(len(x)) + npad + 1
        lo = hi - w
        l0 = np.floor(lo).astype(np.int64)
        frac = (lo - l0)[:, None]
        return (c[hi] - (c[l0] * (1 - frac) + c[l0 + 1] * frac)) / w

    rng = np.random.default_rng(2)
    for w in (1.5, 12.000000000000002, 25.0, 37.3, 3.0000000001):
        for k in (1, 2, 5, 3000, 40000):
            x = np.cumsum(rng.normal(size=(k, 4)), axis=0)
            assert np.array_equal(fine.moving_average(x, w), gathered(x, w)), (w, k)
    x = np.arange(12.0).reshape(6, 2)
    assert fine.moving_average(x, 1.0) is x
    assert fine.moving_average(x, 2.0)[:, 0].tolist() == [0.0, 1.0, 3.0, 5.0, 7.0, 9.0]


def test_arc_clock_counts_the_arc_on_time():
    clock = fine.arc_clock([(1.0, 2.5), (4.0, 4.5)])
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.25, 10.0, np.inf])
    assert clock(t).tolist() == [0.0, 0.0, 1.0, 1.5, 1.75, 2.0, 2.0]
    assert fine.arc_clock([])(t).tolist() == [0.0] * 7
    assert float(clock(np.inf)) == 2.0 and float(clock(2.0)) == 1.0  # one time, not an array
