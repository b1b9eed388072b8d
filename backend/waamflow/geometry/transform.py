"""Placing a part: unit conversion, uniform scale, rotation about x/y/z, translation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

UNIT_TO_MM: dict[str, float] = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4, "ft": 304.8, "um": 0.001}


def unit_scale(units: str) -> float:
    """Factor from `units` (mm, cm, m, in, ft, um) to millimetres."""
    try:
        return UNIT_TO_MM[units]
    except KeyError:
        raise ValueError(f"unknown length unit {units!r}; use one of {', '.join(UNIT_TO_MM)}") from None


def rotation_matrix(rotate_deg: tuple[float, float, float]) -> np.ndarray:
    """(3, 3) rotation: first about x, then y, then z (fixed axes), angles in degrees."""
    rx, ry, rz = np.radians(np.asarray(rotate_deg, dtype=float))
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    mx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    my = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    mz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return mz @ my @ mx


@dataclass(frozen=True)
class Transform:
    """p' = R(rotate_deg) · (scale · p) + translate, applied after conversion to mm.

    translate: (3,) mm. rotate_deg: (3,) degrees about x, y, z (in that order, fixed axes).
    scale: uniform factor (dimensionless).
    """

    translate: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotate_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    scale: float = 1.0

    @property
    def is_identity(self) -> bool:
        return self.scale == 1.0 and not any(self.translate) and not any(self.rotate_deg)

    @property
    def flips(self) -> bool:
        """A negative scale mirrors the part: face winding must be reversed to stay outward."""
        return self.scale < 0

    def apply(self, points: np.ndarray) -> np.ndarray:
        """(n, 3) float mm → (n, 3) float64 mm."""
        p = np.asarray(points, dtype=np.float64)
        if self.is_identity:
            return p
        m = rotation_matrix(self.rotate_deg) * self.scale
        return p @ m.T + np.asarray(self.translate, dtype=float)
