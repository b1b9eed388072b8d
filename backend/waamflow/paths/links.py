"""Boustrophedon over the study's passes with pluggable end links (semicircular, triangular, ...)."""

from __future__ import annotations

from typing import Callable

import numpy as np

from .flags import Draft
from .frame import PassPlan

#: link(a, b, side) → intermediate (s, t) points between pass end a and next pass start b, both
#: (2,) in frame coordinates on the same end of the passes; side = +1 at the high-s end, −1 low.
Link = Callable[[np.ndarray, np.ndarray, int], list]


def boustrophedon(plan: PassPlan, link: Link, before: float = 0.0, after: float = 0.0) -> Draft:
    """Passes in alternating directions (first along +s), each extended by `before` mm at its start
    and `after` mm at its end, joined by `link` at alternating ends. Returns layer-local points."""
    st: list = []
    prev_side = 0
    for i, p in enumerate(plan.passes):
        fwd = i % 2 == 0
        start = np.array([p.s_lo - before, p.t]) if fwd else np.array([p.s_hi + before, p.t])
        end = np.array([p.s_hi + after, p.t]) if fwd else np.array([p.s_lo - after, p.t])
        if st:
            st.extend(link(st[-1], start, prev_side))
        st.extend([start, end])
        prev_side = 1 if fwd else -1
    pts = plan.frame.to_world(np.array(st))
    return Draft(pts, np.ones(len(pts) - 1, dtype=bool))


def flush(a: np.ndarray, b: np.ndarray, side: int) -> tuple[float, list]:
    """The outermost s of two pass ends on one side, and the straight stub that brings the shorter
    pass out to it (so a symmetric link can start there). Returns (s*, [stub point from a])."""
    s_star = max(a[0], b[0]) if side > 0 else min(a[0], b[0])
    stub = [] if abs(a[0] - s_star) < 1e-12 else [np.array([s_star, a[1]])]
    return s_star, stub


def closing_stub(b: np.ndarray, s_star: float) -> list:
    return [] if abs(b[0] - s_star) < 1e-12 else [np.array([s_star, b[1]])]
