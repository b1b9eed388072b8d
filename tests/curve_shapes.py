"""2D curve builders shared by the thin-wall tests (mm)."""

import math

import numpy as np


def c(*pts):
    """A polyline from points: (n, 2) float."""
    return np.array(pts, float)


def circle(cx, cy, r, n=64):
    """A closed circle polyline of n segments (first point repeated at the end)."""
    t = np.linspace(0.0, 2 * math.pi, n + 1)
    pts = np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)])
    pts[-1] = pts[0]
    return pts
