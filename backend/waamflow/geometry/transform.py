"""Placing a part: unit conversion, uniform scale, rotation about x/y/z, translation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

UNIT_TO_MM: dict[str, float] = {"um": 0.001, "mm": 1.0, "cm": 10.0, "dm": 100.0, "m": 1000.0, "in": 25.4, "ft": 304.8}

# 3MF <model unit="..."> values (3MF core spec, default millimeter) → our unit names
THREEMF_UNITS: dict[str, str] = {"micron": "um", "millimeter": "mm", "centimeter": "cm", "inch": "in",
                                 "foot": "ft", "meter": "m"}
# DXF $INSUNITS codes with a length meaning for parts (0 = unitless → None, the caller's default)
DXF_INSUNITS: dict[int, str] = {1: "in", 2: "ft", 4: "mm", 5: "cm", 6: "m", 13: "um", 14: "dm"}

# A WAAM part outside this size range (largest bounding-box side, mm) probably has wrong units
PLAUSIBLE_SIZE_MM = (5.0, 5000.0)

PLACEMENTS = ("as_is", "build_plate", "centred")


def size_warning(extent_mm: float, units: str, source: str) -> str | None:
    """A warning when the part's largest side (mm) is implausible for WAAM, naming the units used."""
    lo, hi = PLAUSIBLE_SIZE_MM
    if lo <= extent_mm <= hi:
        return None
    what = "small" if extent_mm < lo else "large"
    return (f"part is {extent_mm:.4g} mm across (read as {source}): implausibly {what} for WAAM "
            f"({lo:g} mm - {hi / 1000:g} m); set the node's 'units' param if the file's unit is wrong")


def placement_offset(bounds: np.ndarray, placement: str) -> np.ndarray:
    """(3,) mm translation applying a placement to a part with bounds (2, 3) mm.

    as_is: none. build_plate: z_min → 0 (x, y kept). centred: bounding-box centre of x, y → 0 and
    z_min → 0 (the part stands on the plate at the origin)."""
    lo, hi = np.asarray(bounds, dtype=float)
    if placement == "as_is":
        return np.zeros(3)
    if placement == "build_plate":
        return np.array([0.0, 0.0, -lo[2]])
    if placement == "centred":
        c = (lo + hi) / 2.0
        return np.array([-c[0], -c[1], -lo[2]])
    raise ValueError(f"unknown placement {placement!r}; use one of {', '.join(PLACEMENTS)}")


def unit_scale(units: str) -> float:
    """Factor from `units` (um, mm, cm, dm, m, in, ft) to millimetres."""
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
