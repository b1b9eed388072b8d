"""Seams (issue #22): where sections ignite layer after layer, minimum arc run, the MPP order rule."""

import math
from pathlib import Path

import numpy as np
import pytest
from shapely.geometry import box

from waamflow.core.model import Layer, LayerPaths, SectionPath, as_multipolygon
from waamflow.engine.executor import FileResolver, execute
from waamflow.engine.graph import build_graph
from waamflow.engine.recipe import apply_overrides, load_recipe, parse_set
from waamflow.sequencing import sequence_layer, sequence_part
from waamflow.sequencing.arc_runs import arc_runs, enforce_min_run
from waamflow.sequencing import seams
from waamflow.sequencing.seams import SeamSpec, entries, ignition_points, nearest_distance, reverse_path, rethread_path
from waamflow.zoning import ZoneSpec, apply_zone_params, zone_lengths, zone_path

GRAPHS = Path(__file__).resolve().parents[2] / "graphs"


def section(key, strategy, xy, z, arc=None, inside=None, speed=5.0):
    pts = np.column_stack([np.asarray(xy, float), np.full(len(xy), z)])
    n = len(pts) - 1
    return SectionPath(
        key,
        strategy,
        pts,
        np.ones(n, bool) if arc is None else np.asarray(arc, bool),
        np.ones(n, bool) if inside is None else np.asarray(inside, bool),
        np.full(n, speed),
    )


def cross_layer(i, dz=1.5):
    """The cross of graphs/mpp-cross.json: A oscillated along y through the middle, B and C two-pass
    serpentines; C's guide starts at the junction with A (x = 6)."""
    z = dz * (i + 1)
    ys = np.arange(-60.0, 60.0 + 1e-9, 3.0)
    a = section("A", "oscillate", [(3.0 if k % 2 == 0 else -3.0, y) for k, y in enumerate(ys)], z)
    b = section("B", "parallel", [(-60, -3), (-6, -3), (-6, 3), (-60, 3)], z)
    c = section("C", "parallel", [(6, -3), (60, -3), (60, 3), (6, 3)], z)
    spec = ZoneSpec(10, 10)
    params = {"start": {"travel_speed": 6.0}, "z1": {"travel_speed": 8.0}, "end": {"travel_speed": 4.0}}
    secs = tuple(apply_zone_params(zone_path(s, spec), params) for s in (a, b, c))
    return LayerPaths(Layer(i, z, dz, as_multipolygon(box(-70, -70, 70, 70))), secs)


def ignition_gaps(layers):
    gaps, below = [], None
    for lp in layers:
        ign = ignition_points(lp.sections)
        if below is not None:
            gaps += [nearest_distance(p, below) for p in ign]
        below = ign
    return gaps


def test_cross_seams_never_stack_and_never_start_at_the_junction():
    layers = [cross_layer(i) for i in range(6)]
    planned, _ = sequence_part(layers)
    assert min(ignition_gaps(planned)) == 0.0  # before: every layer ignites at the same 3 points
    out, _ = sequence_part(layers, seam=SeamSpec("auto", 6.0))
    assert min(ignition_gaps(out)) == pytest.approx(6.0)  # one bead width: the 2-pass serpentines swap ends
    for lp in out:
        secs = {s.key: s for s in lp.sections}
        assert abs(secs["C"].points[0][0]) == pytest.approx(60.0)  # C: free end, re-threaded
        assert abs(secs["B"].points[0][0]) == pytest.approx(60.0)
        assert abs(secs["A"].points[0][1]) == pytest.approx(60.0)  # A: alternates ends, 120 mm apart
        for s in lp.sections:  # zones re-measured at the new ends, speeds re-applied
            zl = zone_lengths(s)
            assert zl["start"] == pytest.approx(10.0) and zl["end"] == pytest.approx(10.0)
            assert s.zone[0] == "start" and s.zone[-1] == "end"
            on = dict(zip(s.zone, s.speed))
            assert (on["start"], on["z1"], on["end"]) == (6.0, 8.0, 4.0)
            assert s.length == pytest.approx(next(p for p in cross_layer(0).sections if p.key == s.key).length)
    a_starts = [next(s for s in lp.sections if s.key == "A").points[0][1] for lp in out]
    assert a_starts == [-60.0, 60.0] * 3


def test_rethread_moves_links_to_the_other_side_and_aligned_keeps_the_plan():
    c = cross_layer(0).sections[2]
    re = rethread_path(c)
    xy = re.points[:, :2].tolist()
    assert xy[0] == [60, -3] and xy[-1] == [60, 3]
    k = xy.index([6, -3])
    assert xy[k + 1] == [6, 3] and re.zone[k] == "z1"  # the link moved to the junction side, inside z1
    assert re.length == pytest.approx(c.length)
    # aligned: as planned, except where that ignites at a junction (C) -> the first allowed entry
    lp, _ = sequence_layer(cross_layer(1), seam=SeamSpec("aligned", 6.0))
    starts = {s.key: s.points[0][:2].tolist() for s in lp.sections}
    assert starts == {"A": [3.0, -60.0], "B": [-60.0, -3.0], "C": [60.0, -3.0]}
    # a junction accepted on request
    lp, _ = sequence_layer(cross_layer(1), seam=SeamSpec("aligned", 6.0, at_junctions=True))
    assert lp.sections[2].points[0][:2].tolist() == [6.0, -3.0]


def test_alternate_reverses_open_sections_on_odd_layers():
    layers = [
        LayerPaths(
            Layer(i, 1.5 * (i + 1), 1.5, as_multipolygon(box(-10, -10, 110, 10))),
            (section("W", "parallel", [(0, 0), (100, 0)], 1.5 * (i + 1)),),
        )
        for i in range(4)
    ]
    out, _ = sequence_part(layers, alternate=True, seam=SeamSpec("alternate"))
    assert [lp.sections[0].points[0][0] for lp in out] == [0.0, 100.0, 0.0, 100.0]


def test_closed_loops_stagger_by_the_shift_per_layer():
    sq = [(0, 0), (40, 0), (40, 40), (0, 40), (0, 0)]
    layers = [
        LayerPaths(
            Layer(i, 1.5 * (i + 1), 1.5, as_multipolygon(box(-10, -10, 50, 50))),
            (section("L", "contour", sq, 1.5 * (i + 1)),),
        )
        for i in range(4)
    ]
    out, _ = sequence_part(layers, seam=SeamSpec("stagger", 6.0, 12.0))
    assert [lp.sections[0].points[0][:2].tolist() for lp in out] == [[0, 0], [12, 0], [24, 0], [36, 0]]
    assert all(lp.sections[0].length == pytest.approx(160.0) for lp in out)
    assert min(ignition_gaps(out)) == pytest.approx(12.0)


def test_stock_first_for_thin_walls_and_a_flag_when_there_is_none():
    # a wall with a machining-stock lead at its end only: it ignites there on every layer
    w = section("wall0", "wall", [(0, 0), (50, 0), (57, 7)], 1.5, inside=[True, False])
    lp = LayerPaths(Layer(0, 1.5, 1.5, as_multipolygon(box(-10, -10, 70, 70))), (w,))
    out, _ = sequence_layer(lp, seam=SeamSpec("aligned", 4.0))
    assert out.sections[0].points[0][:2].tolist() == [57.0, 7.0] and not out.sections[0].inside[0]


def toy_raster():
    """A raster on a crescent: runs of 40, 0.18, 30 and 3 mm; the 3 mm run sits after an outside link."""
    xy = [(0, 0), (40, 0), (40, 2), (40.18, 2), (45, 2), (75, 2), (75, 30), (78, 30)]
    arc = [True, False, True, False, True, False, True]
    inside = [True, True, True, True, True, False, True]
    return section("S", "raster", xy, 1.5, arc=arc, inside=inside)


def test_min_arc_run_bridges_inside_gaps_and_drops_the_rest():
    sp = toy_raster()
    lengths = [float(sp.segment_lengths[a:b].sum()) for a, b in arc_runs(sp.arc)]
    assert lengths == pytest.approx([40.0, 0.18, 30.0, 3.0])
    new, fixes = enforce_min_run(sp, 12.0)
    assert [(f.action, round(f.length, 2)) for f in fixes] == [("bridged", 0.18), ("dropped", 3.0)]
    runs = [float(new.segment_lengths[a:b].sum()) for a, b in arc_runs(new.arc)]
    # 0.18 mm run bridged over the 2 mm gap before it (inside, shorter than the 4.82 mm one after)
    assert runs == pytest.approx([40.0 + 2.0 + 0.18, 30.0])
    assert min(runs) >= 12.0
    notes = []
    lp = LayerPaths(Layer(3, 1.5, 1.5, as_multipolygon(box(-10, -10, 90, 40))), (sp,))
    sequence_layer(lp, min_run=12.0, notes=notes)
    assert [(n["kind"], n["layer"], n["section"]) for n in notes] == [("bridged", 3, "S"), ("dropped", 3, "S")]


def test_nearest_keeps_the_oscillated_section_first():
    # the torch ends next to B and C: pure nearest would deposit B, C, then A
    lp = cross_layer(0)
    notes = []
    out, _ = sequence_layer(lp, order="nearest", prev_end=np.array([-60.0, 0.0, 0.0]), notes=notes)
    assert [s.key for s in out.sections][0] == "A" and notes == []
    out, _ = sequence_layer(lp, order="nearest", prev_end=np.array([-60.0, 0.0, 0.0]), precedence=("C",))
    assert [s.key for s in out.sections][:2] == ["C", "A"]
    # an explicit order against the rule is kept, and noted
    out, _ = sequence_layer(lp, order=["B", "A"], notes=notes)
    assert [s.key for s in out.sections] == ["B", "A", "C"]
    assert [(n["kind"], n["section"], n["before"]) for n in notes] == [("order-rule", "A", "B")]


def run_sequence(recipe, *sets, node="sequence"):
    r = apply_overrides(load_recipe(GRAPHS / recipe), parse_set(list(sets)))
    res = execute(build_graph(r), resolver=FileResolver(GRAPHS), artifacts=False, workers=1, targets=[node])
    return [lp for lp in res.outputs[node]["toolpath"]], res


@pytest.mark.parametrize("recipe, gap", [("mpp-cross.json", 6.0), ("mpp-slotted-wall.json", 20.0)])
def test_shipped_mpp_recipes_never_stack_ignitions(recipe, gap):
    """min distance from each ignition to the nearest one on the layer below: 0 mm before."""
    layers, res = run_sequence(recipe)
    assert min(ignition_gaps(layers)) == pytest.approx(gap)
    assert res.stats["sequence"].to_dict()["report"]["min_ignition_gap_to_layer_below_mm"] == pytest.approx(gap)


def test_mpp_cross_nearest_deposits_the_oscillated_arm_first():
    layers, res = run_sequence("mpp-cross.json", "order=nearest")
    assert all([s.key for s in lp.sections][0] == "bs1/A" for lp in layers)
    assert not [w for w in res.warnings if w["node"] == "sequence"]


def test_thin_wall_panel_ignites_in_machining_stock():
    layers, _ = run_sequence("thin-wall-panel.json")
    walls = [s for lp in layers for s in lp.sections if s.strategy == "wall"]
    assert len(walls) == 300
    assert sum(bool(s.inside[0]) for s in walls) == 0  # before: 126 ignited on the finished wall


def entry_paths():
    """Open section paths of every kind the choice meets: the cross's oscillated arm and serpentines
    (zoned), both ways round, a raster with an outside link and a wall with a stock lead."""
    out = [sp for i in range(2) for sp in cross_layer(i).sections]
    out += [reverse_path(sp) for sp in out]
    out += [toy_raster(), section("wall0", "wall", [(0, 0), (50, 0), (57, 7)], 1.5, inside=[True, False])]
    out.append(section("w1", "wall", [(57, 7), (50, 0), (0, 0)], 1.5, inside=[False, True]))
    return out


def test_an_entrys_ignition_and_stock_test_are_those_of_the_path_it_builds():
    """The choice reads an entry's first point and first `inside` before (and mostly without)
    building its path: they must be the built path's own, for every entry of every kind."""
    checked = 0
    for sp in entry_paths():
        for e in entries(sp):
            ign, stock = e.ignition.copy(), e.in_stock
            built = e.path
            assert ign.tolist() == np.asarray(built.points[0], float).tolist(), (sp.key, e.name)
            assert stock == (not bool(built.inside[0])), (sp.key, e.name)
            checked += 1
    assert checked == 4 * 8 + 2 * 4 + 2 + 2 * 2  # 8 serpentines 4 entries each; 4 arms, the raster, 2 walls 2


def test_the_choice_builds_only_the_entry_it_takes(monkeypatch):
    """Re-zoning a candidate path (`_rezone`) is what entries cost: the choice does it for the
    entry it returns only (it did it for all four of a serpentine), and chooses the same."""
    calls = []
    real = seams._rezone
    monkeypatch.setattr(seams, "_rezone", lambda *a: calls.append(1) or real(*a))
    lp = cross_layer(3)
    below = ignition_points(cross_layer(2).sections)
    spec = SeamSpec("auto", 6.0, 12.0)
    for k, sp in enumerate(lp.sections):
        others = lp.sections[:k] + lp.sections[k + 1 :]
        calls.clear()
        entry, ok = seams.choose_entry(sp, 3, spec, others, below)
        path = entry.path
        assert len(calls) <= 1 + (entry.name == "rethreaded-reversed"), (sp.key, entry.name, len(calls))
        eager = {e.name: e.path for e in entries(sp)}[entry.name]
        assert np.array_equal(path.points, eager.points) and path.zone == eager.zone, sp.key


def test_a_u_shaped_wall_is_never_rethreaded():
    """A thin wall's path is the wall. A U (two sides and the top between them) reads as a
    serpentine of two passes and a link; re-threaded, its top edge was replaced by a bead across
    the open bottom (ezdxf's recover01.dxf, every other layer: 16.9 % of the part without metal)."""
    u = [(0.0, 1.5), (0.0, 40.0), (30.0, 40.0), (30.0, 1.5)]
    wall = section("wall0", "wall", u, 2.0)
    assert [e.name for e in entries(wall)] == ["planned", "reversed"]
    below = np.array([[0.0, 1.5, 0.0], [30.0, 1.5, 0.0]])  # ignitions below at both ends: auto looks further
    out, _ = sequence_layer(
        LayerPaths(Layer(1, 2.0, 2.0, as_multipolygon(box(-1, -1, 31, 41))), (wall,)),
        seam=SeamSpec("auto", 4.0, 8.0),
        below=below,
    )
    (got,) = out.sections
    # the same segments, either way round: the top edge is deposited
    segs = {tuple(sorted((tuple(a), tuple(b)))) for a, b in zip(got.points[:-1, :2], got.points[1:, :2])}
    assert ((0.0, 40.0), (30.0, 40.0)) in segs and ((0.0, 1.5), (30.0, 1.5)) not in segs
    assert got.length == pytest.approx(38.5 + 30.0 + 38.5)
    # a fill serpentine of the same shape may still be re-threaded
    assert "rethreaded" in [e.name for e in entries(section("A", "parallel", u, 2.0))]


def test_junction_ignitions_warn_once_a_section_naming_its_layers_and_what_to_do():
    """A rib whose both ends meet the other walls (an H: no entry off a junction) ignites at a
    junction on every layer: one warning for the rib naming the layers, and the wall's remedy (no
    guide to change: a sketch's wall has none); a mask section keeps 'change the guide'. Before,
    each layer warned apart (ezdxf's wipeout_door.dxf: 1,975 warnings) and every one said 'change
    the guide'."""
    from waamflow.nodes.sequence import _report

    def h_layer(i, rib_strategy):
        z = 1.5 * (i + 1)
        left = section("left", "wall", [(0, -50), (0, 50)], z)
        right = section("right", "wall", [(80, -50), (80, 50)], z)
        rib = section("rib", rib_strategy, [(0, 0), (80, 0)], z)
        return LayerPaths(Layer(i, z, 1.5, as_multipolygon(box(-10, -60, 90, 60))), (left, rib, right))

    class Ctx:
        def __init__(self):
            self.warnings, self.reports = [], []

        def warn(self, message, **where):
            self.warnings.append((message, where))

        def report(self, data):
            self.reports.append(data)

    for strategy, remedy in (("wall", "both ends of the wall meet other walls"), ("parallel", "change the guide")):
        notes = []
        layers = [h_layer(i, strategy) for i in (0, 1, 2, 3, 6)]
        out = [sequence_layer(lp, seam=SeamSpec("aligned", 4.0), notes=notes)[0] for lp in layers]
        junction = [n for n in notes if n["kind"] == "junction"]
        assert {(n["section"], n["strategy"]) for n in junction} == {("rib", strategy)} and len(junction) == 5
        ctx = Ctx()
        _report(ctx, None, out, notes)
        (msg, where), *rest = [w for w in ctx.warnings if "junction" in w[0]]
        assert not rest and where == {"layer": 0, "section": "rib"}
        assert "on 5 layers (0-3, 6)" in msg and remedy in msg and "seam_at_junctions" in msg
        assert ctx.reports[0]["junction_ignitions"] == 5


def test_distances_of_many_ignitions_at_once_are_each_ones_own_bit_for_bit():
    """`distances_to_segments` / `nearest_distances` (a path's candidate ignitions in one call):
    each figure equals the one-point formula's exactly (the junction and below tests compare them
    with thresholds and ties), zero-length segments, no segments and no points included."""
    from waamflow.sequencing.seams import distances_to_segments, nearest_distances

    def one_segment_distance(p, a, b):  # the one-point formula
        if not len(a):
            return math.inf
        p2, a2, b2 = p[:2], a[:, :2], b[:, :2]
        d = b2 - a2
        dd = np.einsum("ij,ij->i", d, d)
        t = np.clip(np.einsum("ij,ij->i", p2 - a2, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
        return float(np.min(np.linalg.norm(a2 + t[:, None] * d - p2, axis=1)))

    def one_point_distance(p, pts):
        return math.inf if not len(pts) else float(np.min(np.linalg.norm(pts[:, :2] - p[:2], axis=1)))

    rng = np.random.default_rng(3)
    for trial in range(400):
        m, k = int(rng.integers(0, 40)), int(rng.integers(1, 6))
        a = rng.normal(0.0, 50.0, (m, 3))
        b = a + rng.normal(0.0, 8.0, (m, 3))
        b[: m // 3] = a[: m // 3]  # zero-length segments
        ps = rng.normal(0.0, 50.0, (k, 3))
        assert distances_to_segments(ps, a, b).tolist() == [one_segment_distance(p, a, b) for p in ps]
        assert nearest_distances(ps, a).tolist() == [one_point_distance(p, a) for p in ps]


def test_a_short_run_is_not_bridged_across_a_gap_longer_than_a_bead():
    """compas_slicer's bunny (low res), layer 50, parallel re-planned as contour: a 0.9 mm run after
    a 76.3 mm arc-OFF link across the section was 'bridged': 76 mm of weld, arc on, dragged over the
    layer's beads to save 0.9 mm (the preflight failed the program: retrace, 60 mm of a 92.8 mm run on
    earlier beads). A gap is bridged only when it is at most `max_bridge` (the sequence's bead width)
    long; a run that cannot be is dropped."""
    xy = [
        (0, 0),
        (40, 0),
        (40, 2),
        (41, 2),
        (41, 32),
        (41.9, 32),
    ]  # 40 mm run, 2 mm gap, 1 mm run, 30 mm gap, 0.9 mm run
    arc = [True, False, True, False, True]
    sp = section("S", "contour", xy, 1.5, arc=arc, inside=[True] * 5)
    new, fixes = enforce_min_run(sp, 12.0, max_bridge=6.0)
    assert [(f.action, round(f.length, 2)) for f in fixes] == [("bridged", 1.0), ("dropped", 0.9)]
    assert new.arc.tolist() == [True, True, True, False, False]
    same, fixes_inf = enforce_min_run(sp, 12.0)  # no limit given: as before
    assert [f.action for f in fixes_inf] == ["bridged", "bridged"]
    notes = []
    lp = LayerPaths(Layer(50, 1.5, 1.5, as_multipolygon(box(-10, -10, 90, 40))), (sp,))
    sequence_layer(lp, min_run=12.0, notes=notes, seam=SeamSpec("aligned", 6.0))
    assert [n["kind"] for n in notes] == ["bridged", "dropped"]  # the layer's bead width is the limit
