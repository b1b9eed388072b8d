"""Placing a part: unit conversion, uniform scale, rotation about x/y/z, translation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Exact by definition (international inch 25.4 mm; US survey foot 1200/3937 m; au 149 597 870 700 m
# (IAU 2012); light year 9 460 730 472 580 800 m (IAU); parsec 648 000/π au): every length unit a
# DXF $INSUNITS code, an IGES unit flag, a STEP file or a 3MF model can declare.
UNIT_TO_MM: dict[str, float] = {
    "mm": 1.0,
    "cm": 10.0,
    "m": 1000.0,
    "in": 25.4,
    "ft": 304.8,
    "um": 0.001,
    "dm": 100.0,
    "km": 1e6,
    "mi": 1_609_344.0,
    "yd": 914.4,
    "mil": 0.0254,
    "uin": 25.4e-6,
    "angstrom": 1e-7,
    "nm": 1e-6,
    "dam": 1e4,
    "hm": 1e5,
    "Gm": 1e12,
    "au": 149_597_870_700e3,
    "ly": 9_460_730_472_580_800e3,
    "pc": 648_000 / 3.141592653589793 * 149_597_870_700e3,
    "us_ft": 1_200_000 / 3937,
    "us_in": 100_000 / 3937,
    "us_yd": 3_600_000 / 3937,
    "us_mi": 6_336_000_000 / 3937,
}
UNIT_NAMES: dict[str, str] = {
    "mm": "millimetre",
    "cm": "centimetre",
    "m": "metre",
    "in": "inch",
    "ft": "foot",
    "um": "micrometre",
    "dm": "decimetre",
    "km": "kilometre",
    "mi": "mile",
    "yd": "yard",
    "mil": "mil",
    "uin": "microinch",
    "angstrom": "ångström",
    "nm": "nanometre",
    "dam": "decametre",
    "hm": "hectometre",
    "Gm": "gigametre",
    "au": "astronomical unit",
    "ly": "light year",
    "pc": "parsec",
    "us_ft": "US survey foot",
    "us_in": "US survey inch",
    "us_yd": "US survey yard",
    "us_mi": "US survey mile",
}


def unit_scale(units: str) -> float:
    """Factor from `units` (a key of UNIT_TO_MM: mm, cm, m, in, ft, um, yd, ...) to millimetres."""
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

    def apply(self, points: np.ndarray) -> np.ndarray:
        """(n, 3) float mm → (n, 3) float64 mm."""
        p = np.asarray(points, dtype=np.float64)
        if self.is_identity:
            return p
        m = rotation_matrix(self.rotate_deg) * self.scale
        return p @ m.T + np.asarray(self.translate, dtype=float)
