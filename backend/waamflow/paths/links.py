"""Boustrophedon over the study's passes with pluggable end links (semicircular, triangular, ...)."""

from __future__ import annotations

from typing import Callable

import numpy as np

from .flags import Draft
from .passes import PassPlan, end_direction, oriented

#: link(a, b, tau) → intermediate points (each (2,), mm) between a pass end a and the next pass
#: start b; tau (2,) is the unit travel direction at a (pointing out of the section).
Link = Callable[[np.ndarray, np.ndarray, np.ndarray], list]


def boustrophedon(plan: PassPlan, link: Link, before: float = 0.0, after: float = 0.0) -> Draft:
    """Passes in alternating directions (the first along the guide), each extended by `before` mm
    at its start and `after` mm at its end, joined by `link` at alternating ends."""
    pts: list = []
    for i, p in enumerate(plan.passes):
        run = oriented(p, i % 2 == 0, before, after)
        if pts:
            tau = end_direction(np.asarray(pts), at_start=False)
            pts.extend(link(pts[-1], run[0], tau))
        pts.extend(run)
    arr = np.asarray(pts)
    return Draft(arr, np.ones(len(arr) - 1, dtype=bool))


def flush(a: np.ndarray, b: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, list, list]:
    """Bring the pass end a and the next pass start b level along tau (the one further in gets a
    straight stub out to the other), so a link symmetric about their middle can join them.
    Returns (a', b', stub after a, stub before b)."""
    delta = float((b - a) @ tau)
    if delta > 1e-12:
        a2 = a + delta * tau
        return a2, b, [a2], []
    if delta < -1e-12:
        b2 = b - delta * tau
        return a, b2, [], [b2]
    return a, b, [], []
