"""Contour fills weld each stretch once: no long arc-ON link across the section, no ring laid
around a sliver (its two sides one bead on another).

Found on compas_slicer's `distorted_a` test part (layer 65, 5 mm beads): the offset of one level
split into a 17 mm ring and a 0.5 mm sliver; the ring was chained to its parent by a 33 mm arc-ON
step across the section's middle, and the sliver's "ring" ran out and back over that step's bead —
the preflight failed the program (`retrace`, 98 % of a run welded twice)."""

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, MultiLineString, Point, Polygon, box

from waamflow.geometry.chordal_axis import chordal_axis
from waamflow.paths import StrategySpec, plan_section
from waamflow.paths.contour import offset_rings, step_over
from waamflow.paths.deposit import deposit
from waamflow.preflight.read.core import Run
from waamflow.preflight.retrace import _layer_retrace

W = 5.0
D = step_over(W)  # 3.69 mm

# two 40 mm lobes joined by a 10 mm neck: the first offset goes round both, the second splits in two
DUMBBELL = shapely.union_all([box(0, 0, 40, 40), box(40, 15, 60, 25), box(60, 0, 100, 40)])


def _plan(region, guide=None, w=W):
    return plan_section(region, guide, StrategySpec(pattern="contour", bead_width=w))


def _links(p, region, w=W) -> list[float]:
    """Lengths of the arc-ON segments that lie on no offset ring: the steps between nested loops."""
    rings = MultiLineString([r for lv in offset_rings(region, w) for r in lv if len(r) > 1])
    out = []
    for i in np.flatnonzero(p.arc):
        mid = 0.5 * (p.points[i] + p.points[i + 1])
        if rings.distance(Point(mid)) > 1e-6:
            out.append(float(np.hypot(*(p.points[i + 1] - p.points[i]))))
    return out


def _runs(p) -> list[Run]:
    pts = np.column_stack([p.points, np.zeros(len(p.points))])
    runs, cur = [], [0]
    for i, on in enumerate(p.arc):
        if on:
            cur.append(i + 1)
            continue
        if len(cur) > 1:
            runs.append(cur)
        cur = [i + 1]
    if len(cur) > 1:
        runs.append(cur)
    return [
        Run(pts[r], np.full(len(r) - 1, 10.0), np.full(len(r) - 1, 3.0), np.ones(len(r) - 1, bool), 0, "s", 0)
        for r in runs
    ]


def _arc_on(p) -> float:
    return float(np.hypot(*np.diff(p.points, axis=0).T)[p.arc].sum())


@pytest.mark.parametrize("guide", [((0, 0), (100, 0)), ((100, 40), (0, 40)), ((0, 40), (100, 0))])
def test_nested_loops_are_linked_where_they_are_close(guide):
    """Whichever lobe the chain's inner loop lies in, each arc-ON step between nested loops is at
    most two step-overs long (a mitred corner's step is √2·d); before, starting from the far lobe
    gave 37.6 and 20.0 mm steps dragged across the section."""
    p = _plan(DUMBBELL, LineString(guide))
    links = _links(p, DUMBBELL)
    assert links, "the chains' loops are still joined arc-ON"
    assert max(links) <= 2 * D + 1e-6, links
    assert _layer_retrace(_runs(p), W) is None


def test_sliver_is_welded_once_along_its_axis():
    """A 40 × 5.3 mm section with 5 mm beads: the first offset is a 35 × 0.3 mm sliver. Its ring
    welded 70.6 mm, every millimetre of the strip twice 0.3 mm apart; one pass along its axis
    welds 35 mm."""
    region = box(0, 0, 40, 5.3)
    p = _plan(region)
    assert _arc_on(p) == pytest.approx(35.0, abs=0.3)
    on = p.points[np.r_[p.arc, False] | np.r_[False, p.arc]]
    assert np.allclose(on[:, 1], 2.65, atol=0.05)


def test_inner_sliver_after_a_ring():
    """One ring, then a 0.5 mm sliver inside it (the distorted_a case): ring + a short step + the
    sliver's axis once, and no run retraces another."""
    h = W + 2 * D + 0.5
    region = box(0, 0, 60, h)
    p = _plan(region)
    ring = offset_rings(region, W)[0][0]
    ring_len = LineString(ring).length
    axis = 60 - W - 2 * D  # the sliver's length
    assert _arc_on(p) == pytest.approx(ring_len + D + axis, abs=0.5)
    assert _layer_retrace(_runs(p), W) is None


def test_an_outer_piece_a_little_wider_keeps_its_ring():
    """A 40 × 6.2 mm section (a 1.2 mm first offset): its ring's beads reach both edges, one bead
    along the middle would leave 0.6 mm strips unwelded along them; the ring stays."""
    region = box(0, 0, 40, 6.2)
    p = _plan(region)
    assert _arc_on(p) == pytest.approx(2 * (35 + 1.2), abs=0.1)
    corners = 4 * (W / 2) ** 2 * (1 - math.pi / 4)  # a round bead's end in a square corner
    assert region.difference(deposit(p.points, p.arc, W)).area == pytest.approx(corners, abs=0.1)


def test_curved_sliver_follows_its_arc():
    """A 270° band whose first offset is a 0.4 mm curved strip: the pass follows the strip's arc
    (r = 30 mm) once, not a chord and not round both sides."""
    r0, r1 = 30 - (W + 0.4) / 2, 30 + (W + 0.4) / 2
    a = np.radians(np.linspace(0, 270, 181))
    band = Polygon(
        np.vstack(
            [np.column_stack([r1 * np.cos(a), r1 * np.sin(a)]), np.column_stack([r0 * np.cos(a), r0 * np.sin(a)])[::-1]]
        )
    )
    p = _plan(band)
    on = p.points[np.r_[p.arc, False] | np.r_[False, p.arc]]
    assert np.allclose(np.hypot(on[:, 0], on[:, 1]), 30.0, atol=0.15)
    assert _arc_on(p) == pytest.approx(30 * math.radians(270) - W, abs=0.5)  # offset w/2 off each end


def test_chordal_axis_of_a_strip_and_an_l():
    from waamflow.geometry.chordal_axis import chordal_axis

    strip = chordal_axis(box(0, 0, 20, 1))
    assert LineString(strip).length == pytest.approx(20.0, abs=0.6)
    assert np.allclose(strip[:, 1], 0.5, atol=1e-6)
    ell = shapely.union(box(0, 0, 30, 1), box(0, 0, 1, 20))  # an L of 1 mm legs
    axis = LineString(chordal_axis(ell))
    assert axis.length == pytest.approx(30 + 20 - 1, abs=1.5)
    assert ell.buffer(1e-6).contains(axis)


def test_a_lobe_too_narrow_for_a_second_ring_gets_a_pass_along_its_core():
    """A 40 mm block with an 11.5 × 30 mm lobe (5 mm beads): the lobe's second offset vanishes,
    and the first ring's beads leave a 1.5 mm core along the lobe's middle. Without a pass along
    it 32.7 mm² of the lobe got no bead (51.6 mm² of the section); with it the lobe's square end
    corners are all that is left."""
    region = shapely.union(box(0, 0, 40, 40), box(40, 14.25, 70, 25.75))
    p = _plan(region)
    uncovered = region.difference(deposit(p.points, p.arc, W))
    corners = (W / 2) ** 2 * (1 - math.pi / 4)  # a round bead's end in a square corner
    assert uncovered.intersection(box(45, 14.25, 70, 25.75)).area == pytest.approx(2 * corners, abs=0.1)
    assert uncovered.area < 10.0
    assert max(_links(p, region)) <= 2 * D + 1e-6


def test_a_chordal_axis_whose_spurs_are_all_pruned_keeps_its_tree():
    """gumyr/build123d's low_poly_benchy.stl, contour, layer 15: a 7.5 mm² sliver (a near-duplicate
    corner 4e-12 mm from another) whose axis tree lost every branch to the spur pruning, two nodes
    and no edge left, and the strategy node stopped with "IndexError: index 1 is out of bounds"."""
    sliver = Polygon(
        [
            (10.763473124906998, -6.572944821710626),
            (10.763473124906998, -6.572944821706847),
            (10.763589815007066, -5.984974470931165),
            (10.764021298887792, -5.145314391997722),
            (11.512155825509407, -5.149345418190999),
            (13.070943818891797, -5.14086572418369),
            (12.999473744050832, -6.016889943598313),
            (12.948083793379501, -6.642838646376644),
            (12.808291421988628, -7.884461076985955),
            (12.622901996169826, -8.670223097415834),
            (10.762679468938117, -8.639893366502132),
        ]
    )
    axis = chordal_axis(sliver, 1.25)
    assert len(axis) >= 2
    length = float(np.hypot(*np.diff(axis, axis=0).T).sum())
    assert 2.0 < length < 6.0  # across a 2.3 × 3.5 mm sliver, end to end
    assert shapely.LineString(axis).buffer(1e-6).intersects(sliver)


@pytest.mark.parametrize("hole", [10.5, 11.5, 12.0])
def test_a_ring_shaped_core_is_welded_round_its_hole_not_across_it(hole):
    """pythonocc-demos' torus_default_resolution.stl, contour, layers 3-6: the core the innermost
    rings of an annulus left was itself an annulus; its "chordal axis" was taken with the hole
    filled and zigzagged arc-ON across the hole (35 mm of weld up to 10.5 mm off the part: preflight
    fail). A core with one hole is welded along its centre loop."""
    region = Point(0, 0).buffer(30.0, quad_segs=32).difference(Point(0, 0).buffer(hole, quad_segs=32))
    spec = StrategySpec(pattern="contour", bead_width=5.0)
    path = plan_section(region, None, spec)
    inside_hole = Point(0, 0).buffer(hole - 0.5)
    on = [LineString(path.points[i : i + 2]) for i in range(len(path.arc)) if path.arc[i]]
    assert sum(s.intersection(inside_hole).length for s in on) == pytest.approx(0.0, abs=1e-9)
    bare = region.difference(deposit(path.points, path.arc, 5.0)).area
    assert bare / region.area < 0.02


def test_a_sliver_with_corners_a_hair_apart_has_an_axis():
    """A fuzzed section's split piece (contour, 7 mm beads): two corners 1e-16 mm apart gave a
    degenerate triangle whose two chords were one chord, the axis tree a node paired with itself,
    and the strategy node stopped with "IndexError: index 1 is out of bounds"."""
    piece = Polygon(
        [
            (12.252339036033884, 5.649909715605903),
            (12.252339036033884, 5.6499097156059035),
            (13.050948639420389, 6.333414936498042),
            (9.472405731340444, 15.68644006689191),
            (11.038418166915076, 16.285609064853816),
            (14.403348025940865, 7.490891677947521),
        ]
    )
    axis = chordal_axis(piece, 1.745368379920603)
    length = float(np.hypot(*np.diff(axis, axis=0).T).sum())
    assert len(axis) >= 2 and 8.0 < length < 12.0  # along the 1.7 mm wide, ~10 mm long sliver


def test_a_sliver_geos_cannot_triangulate_at_one_subdivision_has_an_axis():
    """Fuzzed sections' split pieces (contour, 3.4-6.2 mm beads): GEOS's constrained Delaunay
    triangulation of the boundary, subdivided at the piece's thickness, stopped with "Unable to
    find a convex corner" and so did the strategy node. Other subdivisions triangulate."""
    piece = Polygon(
        [
            (17.243117275495067, -8.602212782650993),
            (18.472882607806252, -2.339596009371936),
            (12.248232661735305, -3.0930578687353645),
            (12.248232661735305, -3.093057868735363),
            (20.94202623972748, -2.040718872816322),
            (19.524258140756007, -9.260745364010283),
            (19.524065454520844, -9.261726624431772),
            (19.228581434154663, -10.766487844772408),
            (16.947633255128885, -10.10697400299163),
        ]
    )
    axis = chordal_axis(piece, 1.0288768687424004)
    assert len(axis) >= 2
    assert float(np.hypot(*np.diff(axis, axis=0).T).sum()) > 5.0


@pytest.mark.parametrize("pattern", ["oscillate", "parallel"])
def test_a_sliver_whose_mitre_growth_crosses_itself_is_planned(pattern):
    """A fuzzed section's split piece (4.4 mm beads): its two corners 1e-16 mm apart made GEOS's
    mitre buffer by 1e-6 mm come back crossing itself, and the chords the weave and the passes cut
    from it stopped the strategy node with "TopologyException: side location conflict"."""
    piece = Polygon(
        [
            (-5.647623353382841, 2.3033966369108576),
            (0.5103385346962916, 10.884722141989041),
            (1.670044128185606, 10.052517042453625),
            (1.6700441281856053, 10.052517042453626),
            (2.3225800061554205, 9.58425709068225),
            (-4.107530781511144, 1.1982257217547525),
        ]
    )
    path = plan_section(piece, None, StrategySpec(pattern=pattern, bead_width=4.355904305765767))
    assert len(path.points) >= 2 and path.arc.any()


def test_a_one_pass_spiral_section_whose_long_axis_misses_it_has_a_pass():
    """A fuzzed section one spiral pass wide, V-shaped (two 27 mm arms 1.6 mm wide): the long axis of
    its bounding rectangle lies outside it, no centre line was found, and a bare `assert` stopped
    the strategy node ("AssertionError: "). Its chordal axis is the pass now."""
    from waamflow.paths.spiral import _single_pass

    v = Polygon(
        [
            (26.22697643367202, 6.445249664405813),
            (22.81148937322997, 33.342257642238465),
            (24.44687931843356, 33.54992584091778),
            (27.766724693713048, 7.406097460403762),
            (34.39877811504475, 11.544692111361465),
        ]
    )
    spec = StrategySpec(pattern="spiral", bead_width=6.858402455946726)
    draft = _single_pass(v, 2.159545856005882, np.array([26.98041218, 35.23817973]), spec)
    line = LineString(draft.points)
    assert line.length > 20.0  # along an arm, not a stub
    assert v.buffer(0.5).contains(line)  # the pass stays on the section
