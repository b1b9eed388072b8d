"""Bead-height model H(Ts) and its inverse (Rauch et al., J. Machine Engineering 21, 2021).

The study fits, for 316L GMAW at a fixed wire feed of 8.1 m/min, the bead height H (mm) against
the travel speed Ts (mm/min) with a second-order polynomial (its eq. for H, adjusted R² 0.9098):

    H(Ts) = 1.2245e-6·Ts² − 0.0032·Ts + 4.3126,   valid for Ts ∈ [400, 1200] mm/min,

i.e. H from 3.23 mm (400 mm/min) down to 2.24 mm (1200 mm/min). Measured means: Ts 500 → 3.04,
675 → 2.61, 850 → 2.49, 1025 → 2.34, 1200 → 2.17 mm. The coefficients are parameters so another
material/process can be fitted. The model must be monotonic on its validity range (it is: the
parabola's vertex, 1306.6 mm/min, lies above 1200), so each height in range has one speed.

The feasibility rule (curvature–size ratio): a fan layer needs height r·Δθ at distance r from
the slicing axis, so a wall spanning r_min..r_max needs heights in the ratio r_min/r_max, which
the process can span only if r_min/r_max ≥ H_min/H_max = q. With RC the radius to the middle of
the radial extent and D the radial extent (RC = (r_min + r_max)/2, D = r_max − r_min),
r_min/r_max ≥ q ⇔ RC/D ≥ (1 + q) / (2·(1 − q)) — the minimum CSratio (2.7 for 2.2/3.2 mm). The
closed form printed in the paper reduces to a constant and is not used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

STUDY_COEFFICIENTS = (1.2245e-6, -0.0032, 4.3126)  # a2 (mm/(mm/min)²), a1 (mm/(mm/min)), a0 (mm)
STUDY_SPEED_RANGE = (400.0, 1200.0)  # mm/min


@dataclass(frozen=True)
class BeadModel:
    """H(Ts) = a2·Ts² + a1·Ts + a0 (H mm, Ts mm/min), valid for Ts in [ts_min, ts_max] mm/min."""

    a2: float = STUDY_COEFFICIENTS[0]
    a1: float = STUDY_COEFFICIENTS[1]
    a0: float = STUDY_COEFFICIENTS[2]
    ts_min: float = STUDY_SPEED_RANGE[0]
    ts_max: float = STUDY_SPEED_RANGE[1]

    def __post_init__(self) -> None:
        if not 0 < self.ts_min < self.ts_max:
            raise ValueError("need 0 < ts_min < ts_max (mm/min)")
        if self.a2 != 0:
            vertex = -self.a1 / (2 * self.a2)
            if self.ts_min < vertex < self.ts_max:
                raise ValueError(
                    f"H(Ts) is not monotonic on [{self.ts_min}, {self.ts_max}] mm/min "
                    f"(vertex at {vertex:.1f}): a height would have two speeds"
                )
        if self.height(self.ts_min) == self.height(self.ts_max):
            raise ValueError("H(Ts) is constant: travel speed cannot set the height")
        low = min((self.ts_min, self.ts_max), key=lambda ts: float(self.height(ts)))  # monotonic: an end
        if float(self.height(low)) <= 0:
            raise ValueError(
                f"H(Ts) reaches {float(self.height(low)):.3f} mm at Ts = {low:g} mm/min: a bead has a height "
                "above 0 over the whole speed range; check a0 (mm), a1 and a2, or ts_min / ts_max"
            )

    def height(self, ts):
        """Bead height (mm) at travel speed ts (mm/min); array or scalar."""
        ts = np.asarray(ts, float)
        return self.a2 * ts**2 + self.a1 * ts + self.a0

    @property
    def h_range(self) -> tuple[float, float]:
        """(H_min, H_max) mm over the validity range."""
        a, b = float(self.height(self.ts_min)), float(self.height(self.ts_max))
        return (min(a, b), max(a, b))

    def speed_for_height(self, h) -> tuple[np.ndarray, np.ndarray]:
        """Inverse model: travel speed Ts (mm/min) giving height h (mm), and a bool mask of the
        heights outside [H_min, H_max] (clamped to the nearest end of the speed range)."""
        h = np.atleast_1d(np.asarray(h, float))
        lo, hi = self.h_range
        out = (h < lo) | (h > hi)
        hc = np.clip(h, lo, hi)
        if self.a2 == 0:
            ts = (hc - self.a0) / self.a1
        else:
            disc = np.maximum(self.a1**2 - 4 * self.a2 * (self.a0 - hc), 0.0)
            r1 = (-self.a1 - np.sqrt(disc)) / (2 * self.a2)
            r2 = (-self.a1 + np.sqrt(disc)) / (2 * self.a2)
            span = self.ts_max - self.ts_min
            in1 = (r1 >= self.ts_min - 1e-9 * span) & (r1 <= self.ts_max + 1e-9 * span)
            ts = np.where(in1, r1, r2)
        return np.clip(ts, self.ts_min, self.ts_max), out


def min_csratio(h_min: float, h_max: float) -> float:
    """Minimum admissible CSratio = (1 + q) / (2·(1 − q)), q = H_min/H_max (2.7 for 2.2/3.2)."""
    q = h_min / h_max
    if not 0 < q < 1:
        raise ValueError("need 0 < H_min < H_max")
    return (1 + q) / (2 * (1 - q))


def csratio(r_min: float, r_max: float) -> float:
    """CSratio = RC / D with RC = (r_min + r_max)/2 and D = r_max − r_min (mm/mm); inf for D = 0."""
    d = r_max - r_min
    return math.inf if d <= 0 else (r_min + r_max) / 2.0 / d


def dtheta_window(r_min: float, r_max: float, h_min: float, h_max: float) -> tuple[float, float]:
    """Admissible fan increments (rad): Δθ ≥ H_min/r_min (thinnest point not below H_min) and
    Δθ ≤ H_max/r_max (thickest point not above H_max). Empty (lo > hi) when infeasible, as when a
    point lies on the axis (r_min 0: no Δθ makes it H_min thick)."""
    return h_min / r_min if r_min > 0 else math.inf, h_max / r_max if r_max > 0 else math.inf
