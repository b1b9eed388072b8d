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
    monkeypatch.setattr(fine, "CHUNK", 777)          # several chunks and a short last one
    got = fine.nearest_segment(q, P, guess, reach=2)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    assert int((got[1] != guess).sum()) > 0          # the search moved some samples off their guess


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
    tau = rng.random(4000) * prof.duration[si] * 1.1           # beyond the end too
    got = fine._positions(prof, fine._phase_starts(prof), si, tau)
    assert np.array_equal(got, evaluate(prof, si, tau)[0])


def test_dwell_lines_are_the_lines_that_name_a_dwell():
    """As str.splitlines cuts them: CR LF, CR alone, vertical tab and file separators, non-ASCII
    texts (line by line) and dotted capital I (an re.IGNORECASE match of "i")."""
    def plain(text):
        return [line for line in text.splitlines() if run._DWELL_HIT.search(line)]

    pieces = ["WAIT SEC 1.5 ; ignition dwell", "\n", "\r\n", "\r", "\x0b", "\x1c", "LIN P1", ";- IGNITION DWELL 2 s",
              " ", "ignition dwell", "\f", "G4 P500 ; ignition dwell 0.5 s", "é", "\u0130gnition dwell"]
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
