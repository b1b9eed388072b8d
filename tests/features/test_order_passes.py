"""`order_passes` scores every (pass, way round) of a step at once and keeps the scan's rule (the
first nearer by more than 1e-9 mm than the best so far): the same order as the loop it replaced."""

import numpy as np
import pytest

from waamflow.features.walls import WallPass, order_passes, stock_ends


def loop_over_passes(passes, start=None, seam="stock"):
    """order_passes as it was before 2026-11-26."""
    left = list(passes)
    pos = np.asarray(start, float) if start is not None else np.vstack([p.xy for p in left]).min(axis=0)
    out = []
    while left:
        best = None
        for k, p in enumerate(left):
            s0, s1 = stock_ends(p)
            for rev in (False, True):
                if seam == "stock" and s0 != s1 and (s1 if not rev else s0):
                    continue
                q = p.xy[-1] if rev else p.xy[0]
                d = float(np.hypot(*(q - pos)))
                if best is None or d < best[0] - 1e-9:
                    best = (d, k, rev)
        _, k, rev = best
        p = left.pop(k)
        p = p.reversed() if rev else p
        out.append(p)
        pos = p.xy[-1]
    return out


def _passes(rng, n):
    out = []
    grid = rng.integers(0, 5, size=(n, 2, 2)).astype(float) * 10.0  # shared end points: ties
    for k in range(n):
        xy = np.array([grid[k, 0], grid[k, 0] + rng.normal(0, 3, 2), grid[k, 1] + rng.uniform(0, 1e-9)])
        inside = rng.random(2) < 0.7
        out.append(WallPass(f"w{k}", "wall", xy, inside))
    return out


@pytest.mark.parametrize("seed", range(200))
@pytest.mark.parametrize("seam", ["stock", "nearest"])
def test_the_same_order_as_the_loop(seed, seam):
    rng = np.random.default_rng(seed)
    passes = _passes(rng, int(rng.integers(1, 25)))
    start = None if seed % 3 == 0 else rng.uniform(-10, 50, 2)
    want, got = loop_over_passes(passes, start, seam), order_passes(passes, start, seam)
    assert [p.key for p in got] == [p.key for p in want]
    assert all(np.array_equal(a.xy, b.xy) for a, b in zip(got, want))
