"""Layer path: section order, arc-OFF travel with retract, nearest neighbour + 2-opt, dwell."""

import itertools

import numpy as np
import pytest
from shapely.geometry import box

from waamflow.core.model import Layer, LayerPaths, SectionPath, as_multipolygon
from waamflow.core.moves import TRAVEL, flatten
from waamflow.sequencing import nearest_order, sequence_layer, sequence_part
from waamflow.sequencing.layer_path import part_travel, tour_length, travel_cost


def sp(key, a, b, z):
    pts = np.array([[a[0], a[1], z], [b[0], b[1], z]], float)
    return SectionPath(key, "parallel", pts, np.ones(1, bool), np.ones(1, bool), np.full(1, 5.0))


def layer_paths(i, segs, dz=1.5):
    z = dz * (i + 1)
    layer = Layer(i, z, dz, as_multipolygon(box(-100, -100, 100, 100)))
    return LayerPaths(layer, tuple(sp(k, a, b, z) for k, a, b in segs))


# four 10 mm beads along x, 10 mm apart: 0→10, 20→30, 40→50, 60→70 (y = 0)
ROW = [("s0", (0, 0), (10, 0)), ("s1", (20, 0), (30, 0)), ("s2", (40, 0), (50, 0)), ("s3", (60, 0), (70, 0))]


def test_mask_order_travel_and_retract():
    lp, travel = sequence_layer(layer_paths(0, ROW), retract_height=5.0)
    assert [s.key for s in lp.sections] == ["s0", "s1", "s2", "s3"]
    # each hop: 5 up, 10 across, 5 down = 20 mm; three hops
    assert travel == pytest.approx(60.0)
    assert lp.sections[1].approach.tolist() == [[10, 0, 6.5], [20, 0, 6.5]]
    assert lp.sections[0].approach.tolist() == [[0, 0, 6.5]]  # first section of the part: come down


def test_nearest_order_shortens_travel_versus_a_bad_explicit_order():
    bad = ["s3", "s0", "s2", "s1"]
    lp_bad, t_bad = sequence_layer(layer_paths(0, ROW), order=bad, retract_height=5.0)
    lp_nn, t_nn = sequence_layer(
        layer_paths(0, ROW), order="nearest", retract_height=5.0, prev_end=np.array([-5.0, 0.0, 0.0])
    )
    assert [s.key for s in lp_bad.sections] == bad
    # bad: 70→0 (+10 vert) 80, 10→40: 40, 50→20: 40 → 160 mm
    assert t_bad == pytest.approx(160.0)
    assert [s.key for s in lp_nn.sections] == ["s0", "s1", "s2", "s3"]
    # from (-5, 0, 0): up to 1.5 + 5 = 6.5 → 6.5, across 5, down 5 → 16.5; then 3 × 20
    assert t_nn == pytest.approx(16.5 + 60.0)


def test_explicit_order_lists_the_rest_in_mask_order():
    lp, _ = sequence_layer(layer_paths(0, ROW), order=["s2"])
    assert [s.key for s in lp.sections] == ["s2", "s0", "s1", "s3"]


def random_layer(rng, n):
    starts, ends = rng.uniform(0, 100, (n, 3)), rng.uniform(0, 100, (n, 3))
    starts[:, 2] = ends[:, 2] = 0
    return travel_cost(ends, starts), np.linalg.norm(starts, axis=1)


def test_small_layers_are_ordered_exactly():
    rng = np.random.default_rng(3)
    for _ in range(20):
        cost, sc = random_layer(rng, 6)
        best = min(tour_length(p, cost, sc) for p in itertools.permutations(range(6)))
        assert tour_length(nearest_order(cost, sc), cost, sc) == pytest.approx(best)


def test_local_search_on_large_layers_never_worse_than_mask_order_and_close_to_optimal():
    from waamflow.sequencing import tour

    rng = np.random.default_rng(3)
    ratios = []
    for _ in range(15):
        cost, sc = random_layer(rng, 8)
        order = nearest_order(cost, sc)  # 8 > EXACT_MAX: nearest neighbour + local search
        assert sorted(order) == list(range(8))
        got = tour_length(order, cost, sc)
        assert got <= tour_length(list(range(8)), cost, sc) + 1e-9
        best = tour_length(tour._exact_order(cost, sc), cost, sc)  # 40320 orders, still fast
        ratios.append(got / best)
    assert min(ratios) >= 1 - 1e-9
    assert np.mean(ratios) < 1.03 and max(ratios) < 1.15


def test_part_chains_layers_alternates_and_dwells():
    layers = [layer_paths(i, ROW[:2]) for i in range(3)]
    out, travel = sequence_part(layers, retract_height=2.0, alternate=True, dwell_after_s=30.0)
    assert [[s.key for s in lp.sections] for lp in out] == [["s0", "s1"], ["s1", "s0"], ["s0", "s1"]]
    assert all(lp.dwell_after_s == 30.0 for lp in out)
    # layer 1 starts at s1 (20, 0, 3.0) from layer 0's end (30, 0, 1.5): up 1.5+2, across 10, down 2
    assert out[1].sections[0].approach.tolist() == [[30, 0, 5.0], [20, 0, 5.0]]
    assert travel[1] == pytest.approx(3.5 + 10 + 2 + (2 + 30 + 2))
    assert part_travel(out) == pytest.approx(travel)
    moves = flatten(out)
    tr = moves.kind == TRAVEL
    assert moves.segment_lengths[tr].sum() == pytest.approx(sum(travel))
    assert moves.dwell_before.sum() == pytest.approx(60.0)  # dwell after layers 0 and 1 lands before layers 1, 2


def test_nearest_starts_from_the_previous_layer_end():
    layers = [layer_paths(0, [("a", (0, 0), (10, 0))]), layer_paths(1, ROW)]
    out, _ = sequence_part(layers, order="nearest")
    assert out[1].sections[0].key == "s0"
    # three beads stacked in y; the previous layer ended next to the top one → top to bottom
    stack = [("b0", (0, 0), (10, 0)), ("b1", (0, 20), (10, 20)), ("b2", (0, 40), (10, 40))]
    out, travel = sequence_part(
        [layer_paths(0, [("a", (10, 45), (0, 45))]), layer_paths(1, stack)], order="nearest", retract_height=0.0
    )
    assert [s.key for s in out[1].sections] == ["b2", "b1", "b0"]
    _, mask_travel = sequence_part(
        [layer_paths(0, [("a", (10, 45), (0, 45))]), layer_paths(1, stack)], retract_height=0.0
    )
    assert travel[1] == pytest.approx(1.5 + 5 + 2 * np.hypot(10, 20))
    assert mask_travel[1] == pytest.approx(1.5 + 45 + 2 * np.hypot(10, 20))


def test_none_layers_break_the_chain():
    out, travel = sequence_part([None, layer_paths(1, ROW[:1])])
    assert out[0] is None and travel == [0.0, 0.0]


@pytest.mark.parametrize("seed", range(6))
def test_local_search_by_length_changes_makes_the_same_moves_as_scoring_whole_tours(seed):
    """The 2-opt/Or-opt moves are scored by their change of the tour's length (a DXF of ~200 walls a
    layer took 46 s for 5 layers when every candidate tour was summed anew): on random open,
    asymmetric tours of 7-30 sections, with and without a start point and with tied costs, the
    moves and the order they give are exactly those of scoring every candidate tour whole."""
    import sys
    from pathlib import Path

    from waamflow.sequencing import tour

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
    from bench_sequence import reference_local_search  # the bench's peer: one definition

    rng = np.random.default_rng(seed)
    for trial in range(12):
        n = int(rng.integers(7, 31))
        ends = rng.uniform(0, 100, (n, 2))
        starts = ends + rng.normal(0, 10, (n, 2)) if trial % 3 else rng.uniform(0, 100, (n, 2))
        cost = travel_cost(ends, starts)
        if trial % 4 == 0:
            cost = np.round(cost)  # ties
        start = None if trial % 2 else rng.uniform(0, 100, n)
        lo = 1 if start is None else 0
        seed_order = list(rng.permutation(n)) if start is not None else [0, *(1 + rng.permutation(n - 1))]
        seed_order = [int(x) for x in seed_order]
        got = tour._local_search(list(seed_order), cost, start, lo)
        want = reference_local_search(list(seed_order), cost, start, lo)
        assert got == want
        assert tour_length(got, cost, start) <= tour_length(seed_order, cost, start) + 1e-9
