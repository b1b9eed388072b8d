"""A section's path leaving one large place with no bead is re-planned (a whole region) or warned
(a drawn section), even under max_uncovered: the preflight's `hole` check fails such a layer.
compas_slicer's bunny_closed_low_res at 2 mm, spiral: layer 29's left lobe kept a 263 mm² centre
with no bead (10.5 widths of a 5 mm bead, 1.7 % of the section) and the program failed the
preflight; here a peanut-shaped section, whose spiral leaves its small lobe's centre (46.6 widths,
3.65 % of it), under a max_uncovered of 10 %."""

from __future__ import annotations

import pytest
from shapely import affinity
from shapely.geometry import MultiPolygon, Point

from waamflow.core.model import Layer, LayerSections, Section
from waamflow.engine.node import load_nodes
from waamflow.paths import StrategySpec
from waamflow.paths.whole import HOLE_MAX_WIDTHS, plan_whole

PEANUT = affinity.scale(
    Point(0, 0).buffer(60, quad_segs=32).union(Point(-70, 10).buffer(35, quad_segs=32)), 2, 2, origin=(0, 0)
)
SPIRAL = StrategySpec(pattern="spiral", bead_width=5.0, spacing=4.0)


def test_the_spiral_leaves_a_hole_under_max_uncovered():
    got = plan_whole(PEANUT, None, SPIRAL, adapt=False)
    assert got.uncovered_share == pytest.approx(0.0365, abs=0.002)
    assert got.hole_widths == pytest.approx(46.6, abs=1.0)


def test_a_whole_region_is_re_planned_for_its_hole():
    got = plan_whole(PEANUT, None, SPIRAL, adapt=True, max_uncovered=0.10)
    assert got.how != "as planned" and got.hole_widths <= HOLE_MAX_WIDTHS
    assert got.uncovered_share < 0.01


class _Ctx:
    def __init__(self) -> None:
        self.warnings: list[tuple[str, int | None, str | None]] = []

    def warn(self, message, layer=None, section=None, **_kw) -> None:
        self.warnings.append((message, layer, section))


def test_a_drawn_section_with_a_hole_is_warned():
    strategy = load_nodes()["strategy"]
    params = strategy.Params.model_validate(
        {"default": {"pattern": "spiral", "bead_width": 5, "spacing": 4}, "max_uncovered": 10}
    )
    layer = Layer(index=3, z=6.0, thickness=2.0, region=MultiPolygon([PEANUT]))
    ctx = _Ctx()
    strategy().run_layer(ctx, params, 3, {"sections": LayerSections(layer, (Section("m1/A", PEANUT),))})
    (hole,) = [w for w in ctx.warnings if "(hole)" in w[0]]
    assert hole[1:] == (3, "m1/A") and "46.6 bead widths of bead" in hole[0] and "1165 mm²" in hole[0]
