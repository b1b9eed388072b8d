"""Expected values derived from the robot study's rules (da Silva Viola et al. 2023), written out
independently of the kernels."""

from __future__ import annotations

import math

import numpy as np
import shapely

D = 4.43  # W_WB, mm


def layout(width: float, d: float = D) -> tuple[int, float]:
    """The study's rule as published: one extra pass if the margin exceeds 0.4·W_WB."""
    n = math.floor(width / d)
    m = (width - (n - 1) * d) / 2
    if m > 0.4 * d:
        n += 1
        m = (width - (n - 1) * d) / 2
    return n, m


def raster(L, W, d=D):
    n, _ = layout(W, d)
    return n * L + (n - 1) * math.hypot(L, d)


def semicircular(L, W, d=D):
    n, _ = layout(W, d)
    return n * L + (n - 1) * math.pi * d / 2


def triangular(L, W, angle, d=D):
    n, _ = layout(W, d)
    return n * L + (n - 1) * 2 * (d / 2) / math.sin(math.radians(angle) / 2)


def rectangular(L, W, d=D):
    n, m = layout(W, d)
    return n * (L - 2 * m) + (n - 1) * d + 2 * m


def spiral(L, W, d=D):
    """Rectangular spiral inward from a corner, rings W_WB apart, centre pass when n is odd."""
    n, m = layout(W, d)
    a, b = L - 2 * m, (n - 1) * d
    rings = n // 2
    total = m + sum(2 * (a - 2 * k * d) + 2 * (b - 2 * k * d) - d for k in range(rings)) + (rings - 1) * d
    if n % 2:
        total += d + (a - (n - 1) * d)
    return total


def swiping(L, W, d=D, advance=1 / 3):
    n, _ = layout(W, d)
    band = (n - 1) * d
    legs = math.ceil(band / (advance * d) - 1e-6)
    return legs * math.hypot(L - d, band / legs)


def assert_inside_flags_hold(path, region, tol=1e-6):
    """Every segment flagged inside lies within region.buffer(tol); every one flagged outside
    does not lie in the region's interior."""
    grown = region.buffer(tol)
    shrunk = region.buffer(-tol)
    segs = shapely.linestrings(np.stack([path.points[:-1], path.points[1:]], axis=1))
    bad_in = path.inside & ~shapely.within(segs, grown)
    bad_out = ~path.inside & shapely.within(segs, shrunk)
    assert not bad_in.any(), path.points[np.flatnonzero(bad_in)[:3]]
    assert not bad_out.any(), path.points[np.flatnonzero(bad_out)[:3]]


def max_gap(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).max())
