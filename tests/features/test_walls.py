"""Feature strategies: crossing construction lengths, free-end extension, tubular laps, helix pitch."""

import math

import numpy as np
from curve_shapes import c, circle
import pytest

from waamflow.features import (
    WallSpec,
    aligned_loop,
    crossing_geometry,
    helix,
    plan_layer_walls,
    recognise,
    scattered_loop,
)
from waamflow.features.tubular import GOLDEN


def plan(curves, **kw):
    spec = WallSpec(**kw)
    return plan_layer_walls(curves, recognise(curves), spec)


def fillet(ri, rc, alpha_deg):
    return math.sqrt(ri**2 + rc**2 - 2 * ri * rc * math.cos(math.radians(alpha_deg) / 2))


def test_crossing_geometry_lengths_from_radii():
    dirs = [(1, 0), (0, 1), (-1, 0), (0, -1)]
    g = crossing_geometry((5, 5), dirs, 2.0, 10.0, 30.0)
    assert np.allclose(np.hypot(*(g.cut_points - 5).T), 2.0)
    assert np.allclose(np.hypot(*(g.influence_points - 5).T), 10.0)
    assert np.allclose(g.fillet_lengths, fillet(10, 2, 90))  # 8.7015 mm each
    assert g.fillet_lengths[0] == pytest.approx(8.70148, abs=1e-5)
    # study's first trial 7.0/2.5
    g2 = crossing_geometry((0, 0), dirs, 2.5, 7.0, 30.0)
    assert g2.fillet_lengths[0] == pytest.approx(fillet(7, 2.5, 90), abs=1e-9)


def test_direct_crossing_paths():
    lw = plan([c((-30, 0), (30, 0)), c((0, -30), (0, 30))], free_end_extension=0.0)
    assert len(lw.passes) == 4  # four branches, each its own entity
    lead = fillet(10, 2, 90)
    for p in lw.passes:
        assert p.length == pytest.approx(28.0 + lead, abs=1e-9)  # 30 − cut radius + fillet segment
        assert int((~p.inside).sum()) == 1  # the fillet lead starts in stock
    # the walls inside the cutting circle are gone: deposited wall length = 4·30 − 4·2
    wall = sum(float(np.hypot(*np.diff(p.xy, axis=0).T)[p.inside].sum()) for p in lw.passes)
    assert wall == pytest.approx(120.0 - 8.0, abs=1e-9)
    # four distinct influence points, one in each quadrant
    infl = {tuple(np.sign(np.round(p.xy[0] if not p.inside[0] else p.xy[-1], 6))) for p in lw.passes}
    assert infl == {(1, 1), (-1, 1), (-1, -1), (1, -1)}


def test_t_crossing_two_fillets_and_a_bridge():
    lw = plan([c((-30, 0), (30, 0)), c((0, 0), (0, 30))], free_end_extension=0.0)
    assert len(lw.passes) == 3
    lengths = sorted(round(p.length, 6) for p in lw.passes)
    lead = fillet(10, 2, 90)
    # the straight side has no fillet: one branch bridges the 4 mm across the cutting circle
    assert lengths == sorted([round(28 + lead, 6), round(28 + lead, 6), round(28 + 4.0, 6)])
    assert sum(int((~p.inside).sum()) for p in lw.passes) == 2


def test_radii_are_parameters():
    lw = plan(
        [c((-30, 0), (30, 0)), c((0, -30), (0, 30))], free_end_extension=0.0, cut_radius=2.0, influence_radius=8.0
    )
    assert lw.passes[0].length == pytest.approx(28.0 + fillet(8, 2, 90), abs=1e-9)


def test_free_end_extension_and_corner_in_one_go():
    lw = plan([c((0, 0), (40, 0)), c((40, 0), (40, 30))], free_end_extension=5.0)
    assert len(lw.passes) == 1  # the corner is deposited in one go
    p = lw.passes[0]
    assert p.length == pytest.approx(70.0 + 10.0, abs=1e-9)
    assert p.inside.tolist() == [False, True, True, False]
    ends = {tuple(np.round(p.xy[0], 9)), tuple(np.round(p.xy[-1], 9))}
    assert ends == {(-5.0, 0.0), (40.0, 35.0)}


def test_every_wall_deposited_once_on_panel_like_layout():
    rect = c((0, 0), (100, 0), (100, 50), (0, 50), (0, 0))
    curves = [rect, c((50, 0), (50, 50)), c((0, 25), (100, 25))]
    lw = plan(curves, free_end_extension=5.0)
    # 4 T-crossings + 1 X: skin in 4 pieces, ribs in 4 + 4 pieces... rib y=25: 2 pieces (X at 50), x=50: 2
    assert len(lw.passes) == 4 + 2 + 2
    total = 300.0 + 50.0 + 100.0
    wall = sum(float(np.hypot(*np.diff(p.xy, axis=0).T)[p.inside].sum()) for p in lw.passes)
    bridges = 4 * 4.0  # one per T (flat skin side)
    removed = 4 * (3 * 2.0) + 4 * 2.0  # 3 branches per T, 4 at the X, r_c each
    assert wall == pytest.approx(total - removed + bridges, abs=1e-6)


def test_tubular_laps():
    ring = circle(0, 0, 10, 72)
    L = 2 * 72 * 10 * math.sin(math.pi / 72)
    lap = aligned_loop(ring, 5.0)
    assert float(np.hypot(*np.diff(lap, axis=0).T).sum()) == pytest.approx(L + 5.0, abs=1e-9)
    assert np.allclose(lap[0], ring[0])
    s3 = scattered_loop(ring, 3, 0.0)
    start = 3 * GOLDEN % 1.0 * L
    angle = math.atan2(s3[0][1], s3[0][0]) % (2 * math.pi)
    assert angle * 10 == pytest.approx(start, abs=0.05)  # on a circle arc length ≈ r·angle
    assert float(np.hypot(*np.diff(s3, axis=0).T).sum()) == pytest.approx(L, abs=1e-9)


def test_helix_pitch_equals_layer_height():
    ring = circle(0, 0, 10, 36)
    zs = [2.0, 4.0, 6.0, 8.0]
    pts = helix(ring, zs)
    assert len(pts) == 37 + 3 * 36
    assert np.all(pts[:37, 2] == 2.0)  # first lap flat on the substrate
    # one lap after the first: same xy, z higher by exactly one layer height
    for k in range(1, 4):
        a, b = 36 + 36 * (k - 1), 36 + 36 * k
        assert np.allclose(pts[a, :2], pts[b, :2])
        assert pts[b, 2] - pts[a, 2] == pytest.approx(2.0, abs=1e-12)
    assert np.all(np.diff(pts[36:, 2]) > 0)  # rises continuously
    assert pts[-1, 2] == 8.0


def test_isolated_tube_goes_helical_non_isolated_scattered():
    wall = c((0, 0), (40, 0))
    lw = plan([wall, circle(40, 40, 8)])
    assert [k for k, _ in lw.helical] == ["tube0"]
    lw = plan([wall, circle(40, 20, 8)])
    assert lw.helical == () and [p.strategy for p in lw.passes if p.key == "tube0"] == ["scattered"]
    assert any("not isolated" in w for w in lw.warnings)


def test_crossing_radii_bounds():
    from waamflow.features import crossing_bounds
    from waamflow.features.walls import crossing_window

    rc_max, ri_min = crossing_bounds(4.0, 90.0)
    assert rc_max == pytest.approx(2.0)  # w/2: the cut wall ends reach the crossing
    assert ri_min == pytest.approx(4.0 * math.sqrt(2))  # w/sin(45°): one bead width off both branches
    assert crossing_bounds(4.0, 60.0) == (2.0, pytest.approx(8.0))  # narrower corner: larger influence
    assert crossing_window(5.0, 90.0) == (pytest.approx(2.0), pytest.approx(10.0))  # the study's Test 3
    curves = [c((-30, 0), (30, 0)), c((0, -30), (0, 30))]
    ok = plan(curves, bead_width=5.0)
    assert ok.warnings == ()
    bad = plan(curves, bead_width=5.0, cut_radius=3.5)
    assert len(bad.warnings) == 1 and "void" in bad.warnings[0] and "beyond the bound itself" in bad.warnings[0]
    bad = plan(curves, bead_width=5.0, cut_radius=2.0, influence_radius=2.5)
    assert len(bad.warnings) == 1 and "thin fillets" in bad.warnings[0] and "below the bound itself" in bad.warnings[0]


def test_self_crossing_is_cut_like_a_direct_crossing():
    loop = c((-10, 0), (10, 0), (10, 10), (0, 10), (0, -10))
    lw = plan([loop], free_end_extension=0.0)
    # split at both passes: (−10,0)→X, X→…→X (the lap through the corners), X→(0,−10)
    assert len(lw.passes) == 3
    wall = sum(float(np.hypot(*np.diff(p.xy, axis=0).T)[p.inside].sum()) for p in lw.passes)
    assert wall == pytest.approx(60.0 - 4 * 2.0, abs=1e-9)  # 20 + 10 + 10 + 20 mm, less 4 r_c
    assert sum(int((~p.inside).sum()) for p in lw.passes) == 4  # four fillet leads


def test_wall_passes_ignite_in_their_machining_stock():
    """Issue #22 (Venturini et al. 2018): a pass with stock at one end only (free-end extension)
    ignites in that stock whichever end the torch is nearer; "nearest" keeps the old choice."""
    from waamflow.features.walls import WallPass, order_passes, passes_without_stock

    xy = np.array([[0.0, 0.0], [100.0, 0.0], [105.0, 0.0]])
    p = WallPass("wall0", "wall", xy, np.array([True, False]))
    near_start = np.array([-1.0, 0.0])
    assert order_passes([p], near_start, "nearest")[0].xy[0].tolist() == [0.0, 0.0]
    assert order_passes([p], near_start)[0].xy[0].tolist() == [105.0, 0.0]
    bare = WallPass("wall1", "wall", xy[:2], np.array([True]))
    assert passes_without_stock([p, bare]) == ["wall1"]


def test_chain_ends_grid_finds_the_ends_a_scan_of_every_chain_finds():
    """The junctions' search for chain ends through a hash grid: the same chains and ends, in the
    same order (chain by chain, start before end), as testing every chain, before and after
    chains are trimmed and dropped; ends at exactly tol count, beyond it not."""
    from waamflow.features.walls import _Chain, _ChainEnds

    rng = np.random.default_rng(3)
    tol = 1e-3
    grid = rng.integers(-20, 20, size=(300, 2, 2)).astype(float) * 5.0  # shared end points
    chains = [_Chain(np.array([a, (a + b) / 2 + 0.1, b])) for a, b in grid]
    index = _ChainEnds(chains, tol)

    def scan(J):
        out = []
        for ch in chains:
            if ch.dropped:
                continue
            for at_start, p in ((True, ch.xy[0]), (False, ch.xy[-1])):
                if np.hypot(*(p - J)) <= tol:
                    out.append((id(ch), at_start))
        return out

    probes = np.vstack([grid.reshape(-1, 2)[:200], grid.reshape(-1, 2)[:50] + [tol, 0.0]])
    probes = np.vstack([probes, grid.reshape(-1, 2)[:50] + [0.0, 1.01 * tol], rng.uniform(-100, 100, (50, 2))])
    for J in probes:
        assert [(id(ch), s) for ch, s in index.at(J)] == scan(J)
    hits = sum(len(index.at(J)) for J in probes)
    assert hits > 250  # the probes on and at tol from an end
    for k, ch in enumerate(chains[:120]):  # trims move ends, drops remove them
        if k % 3 == 0:
            ch.dropped = True
        else:
            ch.xy = ch.xy[1:] if k % 2 else ch.xy[:-1]
        index.moved(ch)
    for J in np.vstack([probes, [ch.xy[1] for ch in chains[:120]]]):
        assert [(id(ch), s) for ch, s in index.at(J)] == scan(J)


def test_layers_with_the_same_curves_share_their_wall_passes():
    """An extrusion's layers plan their walls once (plan_layer_walls `memo`): the passes, their
    order from each layer's own start point, and the notes are those planned layer by layer."""
    rect = c((0, 0), (100, 0), (100, 50), (0, 50), (0, 0))
    curves = [rect, c((50, 0), (50, 50)), c((0, 25), (100, 25)), circle(150, 25, 10, 48)]
    feats = recognise(curves)
    spec = WallSpec(free_end_extension=5.0, fillet_radius=1.0, bead_width=4.0, tubular="scattered")
    memo: dict = {}
    for layer, start in enumerate([None, (100.0, 50.0), (0.0, 0.0), (160.0, 25.0)]):
        lf = [dict(f, layer=layer, z=1.5 * layer) for f in feats]
        shared = plan_layer_walls(curves, lf, spec, layer_index=layer, start=start, memo=memo)
        alone = plan_layer_walls(curves, lf, spec, layer_index=layer, start=start)
        assert [p.key for p in shared.passes] == [p.key for p in alone.passes]
        for a, b in zip(shared.passes, alone.passes):
            assert np.array_equal(a.xy, b.xy) and np.array_equal(a.inside, b.inside)
        assert shared.warnings == alone.warnings
    assert len(memo) == 1  # planned once for the four layers
    assert len({p.key for p in shared.passes}) == 9  # 8 wall pieces + the scattered tube
    plan_layer_walls(curves[:3], recognise(curves[:3]), spec, memo=memo)
    assert len(memo) == 2  # other curves: planned anew
