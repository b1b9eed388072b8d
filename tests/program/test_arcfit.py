import numpy as np

from waamflow.program.arcfit import circle_through, fit_arcs

from conftest import half_ring


def test_circle_through_tilted_circle():
    rng = np.random.default_rng(3)
    center = np.array([5.0, -2.0, 7.0])
    n = np.array([1.0, 2.0, 2.0]) / 3.0
    u = np.cross(n, [0, 0, 1.0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    a = np.sort(rng.uniform(0, 5, 3))
    pts = center + 12.5 * (np.outer(np.cos(a), u) + np.outer(np.sin(a), v))
    c, normal, r = circle_through(*pts)
    assert np.allclose(c, center, atol=1e-9)
    assert abs(r - 12.5) < 1e-9
    assert abs(abs(normal @ n) - 1.0) < 1e-12
    assert circle_through(np.zeros(3), np.ones(3), 2 * np.ones(3)) is None


def test_semicircle_fits_within_sagitta_tolerance():
    pts = half_ring(0.0, r=15.0, n=25)  # 7.5° chords: sagitta 15(1 - cos 3.75°) = 0.0321 mm
    arcs = fit_arcs(pts, 0.05)
    assert len(arcs) == 1
    a = arcs[0]
    assert (a.start, a.end) == (0, 24)
    assert np.allclose(a.center, [20, 30, 0], atol=1e-9) and abs(a.radius - 15.0) < 1e-9
    assert abs(a.sweep - np.pi) < 1e-9
    assert a.normal[2] > 0.999  # counter-clockwise seen from +Z
    assert fit_arcs(pts, 0.03) == []  # tolerance below the chord sagitta: keep the polyline


def test_lines_stay_lines_and_mixed_polyline():
    line = np.column_stack([np.linspace(0, 10, 11), np.zeros(11), np.zeros(11)])
    assert fit_arcs(line, 0.1) == []
    ring = half_ring(0.0, r=15.0, n=25)  # starts at (20, 15)
    lead = np.column_stack([np.linspace(0, 20, 5)[:-1], np.full(4, 15.0), np.zeros(4)])
    pts = np.vstack([lead, ring])
    arcs = fit_arcs(pts, 0.05)
    assert len(arcs) == 1
    assert arcs[0].end == len(pts) - 1
    assert arcs[0].start in (3, 4)  # the tangent lead-in vertex may join the arc
    assert abs(arcs[0].radius - 15.0) < 0.05


def test_plane_restriction():
    ring = half_ring(0.0, r=15.0, n=25)
    t = np.radians(20.0)  # the same circle turned 20° about a line parallel to X through its centre
    rel = ring - [20.0, 30.0, 0.0]
    tilted = np.column_stack([rel[:, 0], rel[:, 1] * np.cos(t), rel[:, 1] * np.sin(t)]) + [20.0, 30.0, 0.0]
    arcs = fit_arcs(tilted, 0.05)
    assert len(arcs) == 1 and abs(arcs[0].radius - 15.0) < 1e-9
    assert abs(arcs[0].normal @ [0.0, -np.sin(t), np.cos(t)] - 1.0) < 1e-9
    assert fit_arcs(tilted, 0.05, plane_normal=(0, 0, 1)) == []
    assert len(fit_arcs(ring, 0.05, plane_normal=(0, 0, 1))) == 1
