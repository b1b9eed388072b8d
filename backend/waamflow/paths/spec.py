"""What a strategy kernel takes (`StrategySpec`) and returns (`Path2D`).

Units: mm and degrees. Points are layer-local (x, y) in mm, like the section regions they fill.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator


def _pattern_enum(schema: dict) -> None:
    from .registry import PATTERNS  # lazy: the registry imports the kernels, which import this module

    schema["enum"] = sorted(PATTERNS)


class StrategySpec(BaseModel):
    """How to fill one section. Every field has a unit and bounds; defaults are the robot study's
    small objective rectangle values where the study gives one (da Silva Viola et al. 2023)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    pattern: str = Field(
        "oscillate",
        description="Fill pattern (see waamflow.paths.PATTERNS)",
        json_schema_extra=_pattern_enum,
        title="Fill pattern",
    )
    spacing: float = Field(
        4.43,
        gt=0.05,
        le=100.0,
        json_schema_extra={"unit": "mm"},
        description="Bead spacing W_WB: distance between neighbouring passes (robot study: 4.43 mm)",
        title="Bead spacing",
    )
    bead_width: float = Field(
        6.0,
        gt=0.05,
        le=100.0,
        json_schema_extra={"unit": "mm"},
        description="Bead width; oscillate keeps half of it inside each side of the section (MPP study: 6 mm)",
        title="Bead width",
    )
    step: float = Field(
        3.0,
        gt=0.05,
        le=100.0,
        json_schema_extra={"unit": "mm"},
        description="Oscillate: advance along the guide per weave stroke",
        title="Weave step",
    )
    angle_deg: float = Field(
        45.0,
        gt=0.0,
        lt=180.0,
        json_schema_extra={"unit": "deg"},
        description="Triangular: apex angle of the isosceles link (45, 60, 90, ...)",
        title="Triangle apex angle",
    )
    arc_outside: Literal["on", "off"] = Field(
        "on",
        description="Arc outside the section: 'on' keeps depositing, 'off' switches the arc at every boundary crossing",
        title="Arc outside the section",
    )
    extension_before: float = Field(
        0.0,
        ge=0.0,
        le=200.0,
        json_schema_extra={"unit": "mm"},
        description="Run-up before the section along each pass (acceleration, ≈4.5 mm at 40 mm/s in the robot study)",
        title="Run-up",
    )
    extension_after: float = Field(
        0.0,
        ge=0.0,
        le=200.0,
        json_schema_extra={"unit": "mm"},
        description="Run-out after the section along each pass (deceleration, ≈3.6 mm at 40 mm/s in the robot study)",
        title="Run-out",
    )
    chord_tol: float = Field(
        0.01,
        gt=1e-4,
        le=1.0,
        json_schema_extra={"unit": "mm"},
        description="Semicircular: chordal tolerance of the discretised half circles",
        title="Chordal tolerance",
    )
    swipe_advance: float = Field(
        1.0 / 3.0,
        gt=0.01,
        le=1.0,
        json_schema_extra={"unit": "1"},
        description="Swiping: sideways advance per zig-zag leg as a fraction of "
        "the bead spacing (1/3: each bead overlaps two thirds of the last)",
        title="Swipe advance",
    )

    @field_validator("pattern")
    @classmethod
    def _known(cls, v: str) -> str:
        from .registry import PATTERNS

        if v not in PATTERNS:
            raise ValueError(f"unknown pattern {v!r}; known: {', '.join(sorted(PATTERNS))}")
        return v


@dataclass(frozen=True, eq=False)
class Path2D:
    """A planned section path in layer-local coordinates.

    points: (n, 2) float, mm. arc: (n - 1,) bool, arc ON per segment. inside: (n - 1,) bool, the
    segment lies in the section region (False for links and run-ups the strategy takes outside;
    segments are split where they cross the region boundary, so each is wholly in or out).
    """

    points: np.ndarray
    arc: np.ndarray
    inside: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.points)
        if self.points.ndim != 2 or self.points.shape[1] != 2:
            raise ValueError(f"Path2D points must be (n, 2), got {self.points.shape}")
        for name in ("arc", "inside"):
            if len(getattr(self, name)) != max(n - 1, 0):
                raise ValueError(f"Path2D {name} has {len(getattr(self, name))} entries for {n} points")

    @property
    def segment_lengths(self) -> np.ndarray:
        """(n - 1,) float, mm."""
        return np.linalg.norm(np.diff(self.points, axis=0), axis=1)

    @property
    def length(self) -> float:
        """Programmed length, mm."""
        return float(self.segment_lengths.sum())

    @property
    def arc_on_length(self) -> float:
        return float(self.segment_lengths[self.arc].sum())

    @property
    def outside_length(self) -> float:
        return float(self.segment_lengths[~self.inside].sum())

    @property
    def arc_switches(self) -> int:
        """Arc ignitions plus extinctions along the path (each stretch of arc ON counts two)."""
        a = np.concatenate([[False], self.arc.astype(bool), [False]])
        return int(np.count_nonzero(a[1:] != a[:-1]))
