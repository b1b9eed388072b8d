"""The charts' point lists: one % over all points gives the text an f-string per point gave."""

import numpy as np
import pytest

from waamflow.process.svgplot import Chart


@pytest.mark.parametrize(
    "xs, ys",
    [
        (np.linspace(0, 10, 1001), np.sin(np.linspace(0, 10, 1001))),
        ([], []),
        ([5.0], [np.nan]),
        (np.array([0.0, -0.0004, 3.25]), np.array([np.inf, -0.00001, 0.05])),
    ],
)
def test_points_text_equals_one_fstring_per_point(xs, ys):
    c = Chart(10, 20, 300, 200, (0, 10), (-1, 1))
    per_point = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(c.px(xs), c.py(ys)))
    assert c._pts(xs, ys) == per_point
    assert c._pts(xs, ys).count(",") == len(xs)
