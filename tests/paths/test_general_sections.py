"""Every pattern on sections that are not axis-aligned rectangles: a trapezoid, a rotated
rectangle, a curved band with a curved guide, a non-convex L."""

import math

import numpy as np
import pytest
from shapely import affinity
from shapely.geometry import LineString, Polygon, box

from waamflow.paths import PATTERNS, StrategySpec, plan_section

from .helpers import assert_inside_flags_hold

TRAPEZOID = Polygon([(0, 0), (50, 0), (40, 20), (8, 20)])
IN_SECTION = ("contour", "rectangular", "spiral", "swiping", "oscillate", "parallel", "raster")


def band(r0=40.0, r1=55.0, a0=0.0, a1=90.0, k=90):
    """Quarter annulus around the origin (a curved MPP section) and its mid-radius guide."""
    a = np.radians(np.linspace(a0, a1, k + 1))
    outer = np.column_stack([r1 * np.cos(a), r1 * np.sin(a)])
    inner = np.column_stack([r0 * np.cos(a), r0 * np.sin(a)])[::-1]
    rm = 0.5 * (r0 + r1)
    guide = LineString(np.column_stack([rm * np.cos(a), rm * np.sin(a)]))
    return Polygon(np.vstack([outer, inner])), guide


@pytest.mark.parametrize("pattern", sorted(PATTERNS))
def test_trapezoid_flags_and_containment(pattern):
    p = plan_section(TRAPEZOID, None, StrategySpec(pattern=pattern))
    assert_inside_flags_hold(p, TRAPEZOID)
    if pattern in IN_SECTION:
        assert p.inside.all(), pattern
    else:  # semicircular / triangular leave it only for their links
        assert 0 < p.outside_length < 0.3 * p.length
    # the fill spans the section: some point within a spacing of both long edges
    ys = p.points[:, 1]
    assert ys.min() < 4.43 and ys.max() > 20 - 4.43


def test_trapezoid_passes_follow_the_slanted_ends():
    p = plan_section(TRAPEZOID, None, StrategySpec(pattern="triangular", angle_deg=90))
    # 20 mm wide → 5 passes (margin (20 - 17.72)/2 = 1.14 mm); each pass spans its own chord
    on = p.points[np.r_[p.inside, False] | np.r_[False, p.inside]]
    for y in 1.14 + 4.43 * np.arange(5):
        row = on[np.isclose(on[:, 1], y)]
        lo, hi = 8 * y / 20, 50 - 10 * y / 20
        assert row[:, 0].min() == pytest.approx(lo, abs=1e-9)
        assert row[:, 0].max() >= hi - 1e-9


@pytest.mark.parametrize("pattern", sorted(PATTERNS))
def test_rotated_rectangle_gives_the_same_lengths(pattern):
    """Patterns work along the guide, not along x: rotating the section rotates the path."""
    r = box(0, 0, 43, 21.5)
    rot = affinity.rotate(r, 30, origin=(0, 0))
    g = affinity.rotate(LineString([(0, 10.75), (43, 10.75)]), 30, origin=(0, 0))
    a = plan_section(r, LineString([(0, 10.75), (43, 10.75)]), StrategySpec(pattern=pattern))
    b = plan_section(rot, g, StrategySpec(pattern=pattern))
    assert b.length == pytest.approx(a.length, rel=1e-9)
    assert b.outside_length == pytest.approx(a.outside_length, abs=1e-6)
    assert_inside_flags_hold(b, rot)


def test_oscillate_follows_a_curved_guide_with_local_width():
    region, guide = band()
    spec = StrategySpec(pattern="oscillate", bead_width=6.0, step=3.0)
    p = plan_section(region, guide, spec)
    assert p.inside.all()
    assert_inside_flags_hold(p, region)
    r = np.hypot(*p.points.T)
    # vertices alternate half a bead inside the inner and outer arcs: amplitude = 15 - 6 = 9 mm
    # (the band is a 90-gon: its chords sit up to r·(1 - cos 0.5°) ≈ 2e-3 mm inside the true arcs)
    assert r.min() == pytest.approx(43.0, abs=3e-3)
    assert r.max() == pytest.approx(52.0, abs=3e-3)
    # constant advance along the guide: stations every ≤ 3 mm of the 47.5 mm-radius quarter arc
    n_strokes = math.ceil(47.5 * math.pi / 2 / 3.0)
    assert len(p.points) - 1 == n_strokes
    ang = np.unwrap(np.arctan2(p.points[:, 1], p.points[:, 0]))
    # (normals of the 90-gon guide tilt by up to 0.5° from radial: ±4.5 mm·sin 0.5° / 47.5 mm)
    assert np.diff(ang) == pytest.approx(np.full(n_strokes, (math.pi / 2) / n_strokes), abs=1e-3)


def test_oscillate_amplitude_follows_width_on_a_taper():
    # a wedge 4 → 24 mm wide over 60 mm, guide along its axis
    wedge = Polygon([(0, -2), (60, -12), (60, 12), (0, 2)])
    p = plan_section(wedge, LineString([(0, 0), (60, 0)]), StrategySpec(pattern="oscillate", bead_width=4.0, step=2.0))
    x, y = p.points.T
    half_width = 2 + 10 * x / 60
    expected = np.maximum(half_width - 2.0, 0.0)  # local half width minus half a bead
    assert np.abs(y) == pytest.approx(expected, abs=1e-5)
    assert p.inside.all()


def test_parallel_offsets_a_curved_guide():
    region, guide = band()
    p = plan_section(region, guide, StrategySpec(pattern="parallel", spacing=4.43))
    assert_inside_flags_hold(p, region)
    assert p.inside.all()
    r = np.hypot(*p.points.T)
    # width 15 → n = 3, margin 3.07 > 1.772 → 4 passes, margin 0.855 mm: radii 40.855 + k·4.43
    radii = 40.855 + 4.43 * np.arange(4)
    for rad in radii:
        assert np.isclose(r, rad, atol=3e-3).sum() >= 20
    # (the band is a 90-gon: its chords sit up to r·(1 - cos 0.5°) ≈ 2e-3 mm inside the true arcs)
    assert np.all(np.min(np.abs(r[:, None] - radii[None, :]), axis=1) < 3e-3)
    # passes span the full quarter (to the straight ends) and alternate direction
    ends = np.degrees(np.arctan2(p.points[:, 1], p.points[:, 0]))
    assert ends.min() == pytest.approx(0, abs=1e-6) and ends.max() == pytest.approx(90, abs=1e-6)


@pytest.mark.parametrize("pattern", sorted(PATTERNS))
def test_curved_band_every_pattern(pattern):
    region, guide = band()
    p = plan_section(region, guide, StrategySpec(pattern=pattern, arc_outside="off"))
    assert_inside_flags_hold(p, region)
    assert np.all(p.arc <= p.inside)  # arc OFF wherever the path is outside
    assert p.length > 0


@pytest.mark.parametrize("pattern", sorted(PATTERNS))
def test_non_convex_section(pattern):
    ell = Polygon([(0, 0), (40, 0), (40, 12), (12, 12), (12, 30), (0, 30)])
    p = plan_section(ell, None, StrategySpec(pattern=pattern, arc_outside="off"))
    assert_inside_flags_hold(p, ell)
    assert np.all(p.arc <= p.inside)
    assert p.inside.any()


def test_oscillate_run_ups_follow_the_guide():
    r = box(0, 0, 43, 21.5)
    g = LineString([(0, 10.75), (43, 10.75)])
    base = plan_section(r, g, StrategySpec(pattern="oscillate"))
    ext = plan_section(
        r, g, StrategySpec(pattern="oscillate", extension_before=4.5, extension_after=3.6, arc_outside="off")
    )
    assert ext.length == pytest.approx(base.length + 8.1)
    assert ext.outside_length == pytest.approx(8.1)
    assert ext.points[0] == pytest.approx(base.points[0] - [4.5, 0])
    assert ext.points[-1] == pytest.approx(base.points[-1] + [3.6, 0])
    assert ext.arc_on_length == pytest.approx(base.length)


@pytest.mark.parametrize("pattern", ["raster", "semicircular", "triangular", "rectangular", "swiping", "parallel"])
def test_pass_patterns_follow_a_curved_guide(pattern):
    """Passes are offsets of the guide: on a quarter annulus they are concentric arcs, and the path
    leaves the section only where the pattern links passes (beyond the straight ends) or travels."""
    region, guide = band()
    p = plan_section(region, guide, StrategySpec(pattern=pattern, angle_deg=60))
    assert_inside_flags_hold(p, region)
    ang = np.degrees(np.arctan2(p.points[:, 1], p.points[:, 0]))
    r = np.hypot(*p.points.T)
    # 15 mm wide → 4 passes at radii 40.855 + k·4.43 (margin 0.855 mm)
    if pattern not in ("swiping", "rectangular"):
        for rad in 40.855 + 4.43 * np.arange(4):
            assert np.isclose(r, rad, atol=3e-3).sum() >= 20, rad
    if pattern in ("rectangular", "swiping", "parallel"):
        assert p.inside.all()
    elif pattern == "raster":
        assert np.all(p.arc <= p.inside) and p.arc_switches == 8  # returns cut across the hole, arc OFF
    else:
        mids = 0.5 * (ang[:-1] + ang[1:])
        assert np.all((mids[~p.inside] < 0) | (mids[~p.inside] > 90))
        assert p.outside_length == pytest.approx(
            3 * (math.pi * 4.43 / 2 if pattern == "semicircular" else 2 * 4.43), rel=1e-2
        )  # 90-gon: end tangents off by ≤ 0.5°


@pytest.mark.parametrize("pattern", sorted(PATTERNS))
def test_one_pass_wide_section(pattern):
    """Narrower than a bead spacing: one pass along the middle (no pattern fails or vanishes)."""
    strip = box(0, 0, 40, 3)
    p = plan_section(strip, None, StrategySpec(pattern=pattern))
    assert p.inside.all()
    if pattern != "oscillate":
        assert np.allclose(p.points[:, 1], 1.5)
    assert 35.5 < p.length <= 40 + 1e-9


@pytest.mark.parametrize("seed", [0, 1])
def test_random_sections_never_fail_and_flags_hold(seed):
    """Random convex/star-shaped sections, random guide directions (given whole, clipped, or
    default), random spacing/run-ups/arc policy: every pattern plans and its flags are true."""
    rng = np.random.default_rng(seed)
    planned = 0
    for it in range(12):
        k = int(rng.integers(3, 10))
        ang = np.sort(rng.uniform(0, 2 * np.pi, k))
        rad = rng.uniform(5, 40, k) if it % 2 else np.full(k, rng.uniform(5, 40))
        poly = Polygon(np.column_stack([rad * np.cos(ang), rng.uniform(0.3, 1) * rad * np.sin(ang)])).buffer(0)
        if poly.geom_type != "Polygon" or poly.area < 1:
            continue
        th = rng.uniform(0, np.pi)
        c = np.asarray(poly.centroid.coords[0])
        u = np.array([np.cos(th), np.sin(th)])
        guide = None if it % 3 == 0 else LineString([c - 100 * u, c + 100 * u])
        if guide is not None and it % 3 == 2:
            guide = guide.intersection(poly)
            if guide.geom_type != "LineString":
                continue
        for pattern in sorted(PATTERNS):
            spec = StrategySpec(
                pattern=pattern,
                spacing=float(rng.choice([2.0, 4.43, 6.0])),
                arc_outside=str(rng.choice(["on", "off"])),
                extension_before=float(rng.choice([0, 3])),
                extension_after=float(rng.choice([0, 2])),
            )
            p = plan_section(poly, guide, spec)
            assert_inside_flags_hold(p, poly)
            if spec.arc_outside == "off":
                assert np.all(p.arc <= p.inside)
            assert p.length > 0
            planned += 1
    assert planned >= 8 * 8


@pytest.mark.parametrize("pattern", sorted(PATTERNS))
def test_every_pattern_plans_the_bunnys_layer_41(pattern):
    """compas_slicer's bunny_closed_low_res, layer 41 at 2 mm (14,247 mm², its auto guide): the spiral
    began with two equal points, its lead-in direction 0/0, and GEOS stopped the strategy ("Edge
    direction cannot be determined because endpoints are equal", exit 3). Every pattern plans it,
    inside flags holding."""
    from pathlib import Path

    import shapely

    data = Path(__file__).parent / "data"
    region = shapely.from_wkb((data / "bunny_layer41.wkb").read_text().strip())
    guide = LineString([(-99.5408614168598, 4.098290965541384), (86.36318909698471, -30.501561287459854)])
    p = plan_section(region, guide, StrategySpec(pattern=pattern, bead_width=5.0, spacing=4.0))
    assert np.isfinite(p.points).all() and p.arc_on_length > 0.5 * region.area / 5.0
    assert_inside_flags_hold(p, region)
