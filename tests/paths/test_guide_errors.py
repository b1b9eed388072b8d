"""A guide whose offsets cannot cross its section stops the strategy with what to do, not a bare
"no pass fits the section" (a fuzzed guide of four points turning back on itself over a 3.8 mm
bar: every offset came back in pieces, none crossing the bar)."""

from __future__ import annotations

import pytest
from shapely.geometry import LineString, Polygon

from waamflow.paths import StrategySpec
from waamflow.paths.registry import plan_section

BAR = Polygon([(-17.56, 24.76), (-15.63, 28.02), (36.48, -2.82), (34.55, -6.09)])
HAIRPIN = LineString([(21.39, 37.97), (31.54, -1.87), (-18.66, 7.53), (4.49, 16.91)])


@pytest.mark.parametrize("pattern", ["parallel", "raster", "triangular", "swiping"])
def test_a_guide_turning_back_on_itself_says_so(pattern):
    assert HAIRPIN.intersection(BAR).length > 10.0  # the guide does cross the bar
    with pytest.raises(ValueError) as got:
        plan_section(BAR, HAIRPIN, StrategySpec(pattern=pattern, bead_width=6.06))
    text = str(got.value)
    assert text.startswith("no pass fits the section: none of the ")
    assert "turns back on itself" in text and "choose contour" in text
    # contour ignores the guide and fills the bar
    assert plan_section(BAR, HAIRPIN, StrategySpec(pattern="contour", bead_width=6.06)).arc.any()
