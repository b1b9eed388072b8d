"""Random sections through every pattern, bounded (a fixed seed, ~60 plans): no kernel stops, and a
whole region's path, as the strategy node plans it, welds nowhere more than a bead off the section.

The faults this net caught are tested on their own with the shapes that showed them
(test_contour_links.py: a ring's core welded across its hole, slivers whose corners lie a hair
apart). Seed 18 fails on the code before those fixes (main at 4709d1b: contour welded 9.3 mm a
bead off a ring, section #3). `WAAMFLOW_FUZZ_ALL=1` runs 20 times as many sections."""

from __future__ import annotations

import os

import numpy as np
import pytest
import shapely
from shapely import affinity
from shapely.geometry import LineString, Point, box

from waamflow.paths import StrategySpec
from waamflow.paths.whole import plan_whole

PATTERNS = ("contour", "parallel", "raster", "spiral", "oscillate")
COUNT = 12 * (20 if os.environ.get("WAAMFLOW_FUZZ_ALL") else 1)


def _sections(seed: int, count: int):
    """(section, bead width) pairs: unions of 2-5 random bars (1.5-12 mm wide), some with a hole,
    and rings (20-60 mm, a hole 20-80 % of that, off centre)."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        if rng.random() < 0.5:
            bars = []
            for _ in range(rng.integers(2, 6)):
                length, width = rng.uniform(10, 80), rng.uniform(1.5, 12)
                bar = affinity.rotate(box(-length / 2, -width / 2, length / 2, width / 2), rng.uniform(0, 180))
                bars.append(affinity.translate(bar, rng.uniform(-30, 30), rng.uniform(-30, 30)))
            region = shapely.union_all(bars)
            if rng.random() < 0.4:
                region = region.difference(Point(rng.uniform(-20, 20), rng.uniform(-20, 20)).buffer(rng.uniform(2, 6)))
        else:
            outer = rng.uniform(20, 60)
            inner = rng.uniform(0.2, 0.8) * outer
            shift = rng.uniform(-0.3, 0.3) * (outer - inner)
            region = Point(0, 0).buffer(outer, quad_segs=16).difference(Point(shift, 0).buffer(inner, quad_segs=16))
        for part in shapely.get_parts(region):
            if part.area >= 20:
                out.append((part, float(rng.uniform(3, 8))))
    return out[:count]


@pytest.mark.parametrize("seed", [18, 101, 202])
def test_random_sections_plan_on_the_part(seed):
    problems = []
    for k, (section, width) in enumerate(_sections(seed, COUNT)):
        near = section.buffer(width, quad_segs=8)
        for pattern in PATTERNS:
            try:
                path = plan_whole(section, None, StrategySpec(pattern=pattern, bead_width=width), adapt=True).path
            except ValueError as e:  # said to the user: too small for the pattern's margins
                if "too small" in str(e) or "zero length" in str(e):
                    continue
                problems.append(f"#{k} {pattern} {width:.2f} mm: {e}")
                continue
            on = [LineString(path.points[i : i + 2]) for i in np.flatnonzero(path.arc)]
            off = sum(s.difference(near).length for s in on if s.length > 0)
            if off > 0.5:
                problems.append(f"#{k} {pattern} {width:.2f} mm: {off:.1f} mm of weld a bead off the section")
    assert problems == []
